# The Kronecker algebra's sweep under the BLAS this process has: its moves
# are two eigendecompositions and matrix products (LAPACK and BLAS), so its
# parallelism is the BLAS's, not FBC's own threads.
#
#   Rscript bench/run.R kronecker-blas [--grid=200x100] [--sweeps=300] [--reps=3]
#
# Run it once per BLAS to compare them, e.g. OpenBLAS with 1 and 2 threads
# where it is installed but not the system's BLAS:
#   OPENBLAS_NUM_THREADS=1 LD_PRELOAD="<openblas>/libblas.so.3 <openblas>/liblapack.so.3" \
#     Rscript bench/run.R kronecker-blas --out=ob1.rds
# Problem: bench/problems.R's product_curves(), a functional output on a
# complete product design of J run settings (t1, t2) x I output points, 10
# field points; calibrate(nMCMC = sweeps, nBurn = 100, nChains = 1, converge =
# FALSE) after set.seed(1) (nMCMC counts the burn-in), `threads = 1` and `threads = 2` alternating.
# Per run: CPU and elapsed ms per sweep (burn-in included) and whether the
# draws equal, to the bit, those of the first run and of the draws saved by
# an earlier run in --ref (an .rds file of Phi: another BLAS's).
suppressPackageStartupMessages(library(FBC))
source("bench/options.R")
source("bench/problems.R")
opt <- bench_options(list(grid = "200x100", sweeps = 300L, reps = 3L, out = "", ref = ""))
if (opt$quick) { opt$grid <- "40x20"; opt$sweeps <- 160L; opt$reps <- 1L }
sz <- as.integer(strsplit(opt$grid, "x", fixed = TRUE)[[1]])
J <- sz[1]; I <- sz[2]
pc <- product_curves(J, I)
model <- suppressMessages(calibrate(pc$sim, pc$field, fit = FALSE))
blas <- extSoftVersion()[["BLAS"]]
cat(sprintf("FBC %s, %s; BLAS %s; OPENBLAS_NUM_THREADS=%s; algebra %s; grid %d x %d (m = %d)\n",
            utils::packageVersion("FBC"), format(Sys.time(), "%Y-%m-%d %H:%M"), blas,
            Sys.getenv("OPENBLAS_NUM_THREADS", "unset"), model$algebra$name, J, I, J * I))
ref <- if (nzchar(opt$ref) && file.exists(opt$ref)) readRDS(opt$ref) else NULL
first <- NULL
rows <- list()
nSweep <- opt$sweeps
for (r in seq_len(opt$reps)) {
  for (t in 1:2) {
    set.seed(1)
    t0 <- proc.time()
    fit <- calibrate(model, nMCMC = opt$sweeps, nBurn = 100, nChains = 1, thinning = 1,
                     converge = FALSE, showProgress = FALSE, threads = t)
    tm <- proc.time() - t0
    if (is.null(first)) first <- fit$Phi
    rows[[length(rows) + 1L]] <- data.frame(
      rep = r, threads = t,
      cpu.ms = round(1000 * (tm[["user.self"]] + tm[["sys.self"]]) / nSweep, 2),
      elapsed.ms = round(1000 * tm[["elapsed"]] / nSweep, 2),
      same.as.first = identical(fit$Phi, first),
      same.as.ref = if (is.null(ref)) NA else identical(fit$Phi, ref),
      max.diff.ref = if (is.null(ref)) NA else max(abs(fit$Phi - ref)))
    print(rows[[length(rows)]], row.names = FALSE)
  }
}
if (nzchar(opt$out)) saveRDS(first, opt$out)
tab <- do.call(rbind, rows)
cat("\nmedians by threads (ms per sweep):\n")
print(stats::aggregate(cbind(cpu.ms, elapsed.ms) ~ threads, tab, stats::median), row.names = FALSE)
