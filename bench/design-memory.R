# Peak memory of the design step with several outputs : a batch
# of propose_runs() on the two-output kinetics problem of design.R
# (kinetics2 / kinetics2i: A -> B -> C, concentrations of A and B, field
# at u = 1.2, sd 0.2), fitted with shared outputs (one simulator GP over
# both outputs' runs) and with independent outputs (a GP per output). A
# script, not a timed test:
#
#   Rscript bench/run.R design-memory [--reps=3] [--m=50,150,300]
#
# Per m (runs, each giving both outputs) one fit each way with
# calibrate()'s defaults, then `reps` batches of 5 with propose_runs()'s
# defaults (method "plugin": the draws at the MAP's hyperparameters,
# pruned by their weight) and with method = "joint" (every draw kept, the
# largest look-ahead); default candidates, 100 d runs x 2 outputs. Columns:
#   peak MB   VmHWM during propose_runs() above the VmRSS before it, in a
#             fresh R process holding the fit (median over reps, range)
#   A MB      (joint) the look-ahead's per-draw candidate columns (100
#             draws x rows x candidate rows x 8 bytes): rows are all runs and field inputs
#             with shared outputs, the largest output's with independent
#             ones (earlier versions: all of them, zeros outside each
#             candidate's output; "A MB then")
#   CPU s     of the batch (median)
suppressPackageStartupMessages(library(FBC))
source("bench/options.R")
opt <- bench_options(list(reps = 3L, m = c(50L, 150L, 300L)))
reps <- opt$reps
ms <- opt$m

# (earlier versions of FBC counted every output's rows, design_field_rows())
rows_of <- if (exists("design_rows", envir = asNamespace("FBC"))) FBC:::design_rows else
  function(model) c(model$dims$m, FBC:::design_field_rows(model))
etas <- list(A = function(X) 5 * exp(-X[, 2] * X[, 1]),
             B = function(X) 5 * X[, 2] * X[, 1] * exp(-X[, 2] * X[, 1]))
tf <- as.data.frame(kineticField)$t

# `reps` batches of 5 on the fit saved in `file`, each in a fresh R process
# (callr) holding only the fit: in one process the memory of an earlier
# batch stays and hides the next one's peak. c(peak MB, CPU s) per batch.
batches <- function(file, method) {
  vapply(seq_len(reps), function(r) {
    callr::r(function(file, r, libs, method) {
      .libPaths(libs)
      suppressPackageStartupMessages(library(FBC))
      status_mb <- function(field) {
        v <- grep(paste0("^", field), readLines("/proc/self/status"), value = TRUE)
        as.numeric(gsub("[^0-9]", "", v)) / 1024
      }
      fit <- readRDS(file)
      set.seed(r)
      gc()
      before <- status_mb("VmRSS")
      # Linux >= 4.0: writing 5 resets the peak RSS to the current RSS
      writeLines("5", "/proc/self/clear_refs")
      t0 <- proc.time()
      pr <- suppressMessages(propose_runs(fit, n = 5, method = method))
      c(peak = status_mb("VmHWM") - before, time = sum((proc.time() - t0)[1:2]))
    }, list(file, r, .libPaths(), method))
  }, numeric(2))
}

rows <- list()
for (m in ms) {
  set.seed(m)
  X <- cbind(runif(m, 0, 3.1), runif(m, 0.5, 3))
  sim <- do.call(rbind, lapply(names(etas), function(k) {
    data.frame(y = etas[[k]](X), t = X[, 1], out = k, u1 = X[, 2])
  }))
  field <- do.call(rbind, lapply(names(etas), function(k) {
    data.frame(y = etas[[k]](cbind(tf, 1.2)) + rnorm(length(tf), 0, 0.2), t = tf, out = k)
  }))
  for (outputs in c("shared", "independent")) {
    set.seed(1)
    fit <- suppressWarnings(calibrate(sim, field, output = "out", outputs = outputs,
                                      showProgress = FALSE))
    file <- tempfile(fileext = ".rds")
    saveRDS(fit, file)
    # the joint look-ahead's A: 100 draws (ndraws, the default) x rows x
    # candidate rows (100 d = 200 runs x 2 outputs); rows as the size check
    # counts them (design_rows())
    N <- sum(rows_of(fit$model))
    if (outputs == "shared") Nall <- N  # every run and field input
    A <- function(rows) round(8 * min(100, nrow(fit$Phi)) * rows * 400 / 2^20)
    for (method in c("plugin", "joint")) {
      res <- batches(file, method)
      joint <- method == "joint"
      rows[[length(rows) + 1]] <- data.frame(
        m = m, outputs = outputs, method = method,
        `peak MB` = sprintf("%.0f (%.0f-%.0f)", median(res["peak", ]), min(res["peak", ]),
                            max(res["peak", ])),
        `A MB` = if (joint) A(N) else NA, `A MB then` = if (joint) A(Nall) else NA,
        `CPU s` = round(median(res["time", ]), 2), check.names = FALSE)
    }
    unlink(file)
  }
}
tab <- do.call(rbind, rows)
cat(sprintf("FBC %s, %s, BLAS %s\n\n", utils::packageVersion("FBC"), format(Sys.time(), "%Y-%m-%d"),
            basename(extSoftVersion()[["BLAS"]])))
print(tab, row.names = FALSE)
