# Threads inside a chain: the sweep of the nearest-neighbour algebra with 1
# and 2 threads (calibrate(threads =)).
#
#   Rscript bench/run.R threads                     # m = 20,000, 3 repeats
#   Rscript bench/run.R threads --sizes=20000,100000 --reps=5
#   ... --sweeps=200 --k=10                          # sweeps per run, neighbours
# Add --quick for a smoke test (m = 2000, 2 repeats, 40 sweeps). On a machine
# whose cores are busy with other work, OMP_WAIT_POLICY=passive in the
# environment makes waiting threads sleep instead of spin (the footer says
# which policy ran).
#
# Problem: bench/problems.R's scattered design (p = 2, q = 3, n = 100 above
# m = 2000), Matérn 5/2 for both GPs, `algebra = "vecchia"`. The model is
# built once (calibrate(fit = FALSE): ordering, neighbours); each run is
# calibrate(model, nMCMC = sweeps, nBurn = 20, nChains = 1, threads = t)
# after set.seed(1), the thread counts alternating (1, 2, 1, 2, ...) so both
# see the same load. Per run: elapsed and CPU ms per sweep (all sweeps,
# burn-in included) and whether its draws are those of the first one-thread
# run (identical()). The 16-core projection is Amdahl's law with the serial
# fraction s read off the medians, T2 / T1 = s + (1 - s) / 2: T16 / T1 = s
# + (1 - s) / 16, which assumes 16 free cores, no memory-bandwidth limit
# and the 2-thread run's overhead per thread as measured.
suppressPackageStartupMessages(library(FBC))
source("bench/options.R")
source("bench/problems.R")
opt <- bench_options(list(sizes = 20000L, reps = 3L, sweeps = 100L, k = 10L))
if (opt$quick) { opt$sizes <- 2000L; opt$reps <- 2L; opt$sweeps <- 40L }
if (!FBC:::.has_openmp()) stop("this FBC was built without OpenMP: one thread only", call. = FALSE)

load1 <- function() as.numeric(strsplit(readLines("/proc/loadavg"), " ")[[1]][1])

rows <- list()
for (m in opt$sizes) {
  pr <- scattered_problem(m)
  model <- suppressMessages(calibrate(pr$sim, pr$field, algebra = "vecchia", neighbours = opt$k,
                                      kernelS = "matern52", kernelB = "matern52", fit = FALSE))
  nSweep <- opt$sweeps + 20L
  ref <- NULL
  for (r in seq_len(opt$reps)) {
    for (t in 1:2) {
      l0 <- load1()
      set.seed(1)
      t0 <- proc.time()
      fit <- calibrate(model, nMCMC = opt$sweeps, nBurn = 20, nChains = 1, thinning = 1,
                       converge = FALSE, showProgress = FALSE, threads = t)
      tm <- proc.time() - t0
      if (is.null(ref)) ref <- fit$Phi
      rows[[length(rows) + 1L]] <- data.frame(
        m = m, k = opt$k, threads = t, rep = r,
        elapsed.ms = 1000 * tm[["elapsed"]] / nSweep,
        cpu.ms = 1000 * sum(tm[c("user.self", "sys.self")]) / nSweep,
        same.draws = identical(fit$Phi, ref), load = l0)
    }
  }
}
res <- do.call(rbind, rows)
print(res, digits = 4, row.names = FALSE)

cat("\nSummary (elapsed ms per sweep: range over repeats; ratio of medians)\n")
summ <- do.call(rbind, lapply(split(res, res$m), function(d) {
  e1 <- d$elapsed.ms[d$threads == 1]
  e2 <- d$elapsed.ms[d$threads == 2]
  ratio <- stats::median(e2) / stats::median(e1)
  # Amdahl: ratio = s + (1 - s) / 2; no fraction when 2 threads were no
  # faster (a machine without a free core measures the load, not the code)
  s <- if (ratio < 1) max(0, 2 * ratio - 1) else NA_real_
  data.frame(m = d$m[1], k = d$k[1],
             one.thread = sprintf("%.1f-%.1f", min(e1), max(e1)),
             two.threads = sprintf("%.1f-%.1f", min(e2), max(e2)),
             ratio = round(ratio, 2), serial.fraction = round(s, 2),
             projected.16 = round(s + (1 - s) / 16, 2),
             same.draws = all(d$same.draws),
             load = sprintf("%.1f-%.1f", min(d$load), max(d$load)))
}))
print(summ, row.names = FALSE)
cat(sprintf("\n%s, R %s, BLAS %s, %d cores, OMP_WAIT_POLICY %s\n",
            format(Sys.time(), "%Y-%m-%d %H:%M %Z"), getRversion(), extSoftVersion()[["BLAS"]],
            parallel::detectCores(), Sys.getenv("OMP_WAIT_POLICY", "unset")))
