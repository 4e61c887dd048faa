# Speed benchmark of the FBC sampler against the Cholesky floor (issue 4).
#
# Run after installing the package:
#   Rscript inst/bench/bench.R                  # or, from an installed copy,
#   Rscript "$(Rscript -e 'cat(system.file("bench", "bench.R", package = "FBC"))')"
#   R_LIBS=/path/to/lib Rscript inst/bench/bench.R
# Optional first argument: "quick" (fewer sweeps, for a smoke test).
#
# For each problem it reports, in one run on one machine:
#   ms/sweep  time of one Metropolis-within-Gibbs sweep (every free parameter
#             proposed once), from a calibrate()-equivalent .fbc_sample() run
#             with the adapted proposal SDs frozen (adapt = FALSE);
#   floor     2(p+q) t_chol(n+m) + (d - 1 - 2(p+q)) t_chol(n), with t_chol
#             measured here by R's own chol() on SPD matrices of those sizes
#             (same BLAS/LAPACK as the package): a thetaS/alphaS move changes
#             the whole covariance, every other move but muB's needs at least
#             an n x n factorization;
#   ratio     ms/sweep / floor;
#   ESS/s     posterior::ess_bulk of each kappa's draws / the run's time;
#   peak MB   peak resident memory (VmHWM) of this R process during the case.
# Blocked rows (if present) use the joint thetaS/alphaS move (blockSim = TRUE).
suppressPackageStartupMessages(library(FBC))
args <- commandArgs(trailingOnly = TRUE)
quick <- length(args) > 0 && args[1] == "quick"

# ---- helpers -------------------------------------------------------------
peak_mb <- function() {
  s <- tryCatch(readLines("/proc/self/status"), error = function(e) character())
  v <- grep("^VmHWM", s, value = TRUE)
  if (length(v)) as.numeric(gsub("[^0-9]", "", v)) / 1024 else NA_real_
}
reset_peak <- function() {
  # Linux >= 4.0: writing 5 resets the peak RSS to the current RSS
  invisible(tryCatch(writeLines("5", "/proc/self/clear_refs"), error = function(e) NULL,
                     warning = function(w) NULL))
}
# Median time (ms) of R's chol() on a k x k SPD matrix.
t_chol <- function(k, budget = 1.5) {
  set.seed(k)
  X <- matrix(rnorm(k * k), k)
  A <- crossprod(X) / k + diag(k)
  times <- numeric(0)
  t_end <- proc.time()[[3]] + budget
  reps <- max(1L, ceiling(2e6 / k^3 * 50))  # ~ a few ms per batch
  repeat {
    t0 <- proc.time()[[3]]
    for (i in seq_len(reps)) chol(A)
    times <- c(times, (proc.time()[[3]] - t0) / reps)
    if (proc.time()[[3]] > t_end && length(times) >= 3) break
  }
  1000 * stats::median(times)
}
ess <- function(x) {
  if (requireNamespace("posterior", quietly = TRUE)) posterior::ess_bulk(x)
  else unname(coda::effectiveSize(x))
}
ball_problem <- function() list(name = "ball", sim = ballSim, field = ballField)
# A smooth 2 + 2 input simulator, a biased noisy field at kappa = (0.3, 0.7).
synthetic_problem <- function(n, m, seed = 1) {
  set.seed(seed)
  eta <- function(x1, x2, t1, t2) sin(2 * pi * x1) * (1 + t1) + exp(-x2) * t2 + x1 * x2 * t1 * t2
  D <- if (requireNamespace("lhs", quietly = TRUE)) lhs::randomLHS(m, 4) else matrix(runif(4 * m), m)
  sim <- data.frame(y = eta(D[, 1], D[, 2], D[, 3], D[, 4]), x1 = D[, 1], x2 = D[, 2],
                    t1 = D[, 3], t2 = D[, 4])
  xf <- matrix(runif(2 * n), n)
  field <- data.frame(y = eta(xf[, 1], xf[, 2], 0.3, 0.7) + 0.1 * xf[, 1] + rnorm(n, 0, 0.05),
                      x1 = xf[, 1], x2 = xf[, 2])
  list(name = sprintf("p=q=2 n=%d m=%d", n, m), sim = sim, field = field)
}

# Adapt the proposals with calibrate() (nAdapt sweeps, all burn-in but 2
# thinned draws), then time nSweep frozen sweeps from where it stopped.
run_case <- function(prob, nAdapt, nSweep, blocked = FALSE) {
  reset_peak()
  p <- ncol(prob$field) - 1L
  q <- ncol(prob$sim) - 1L - p
  n <- nrow(prob$field); m <- nrow(prob$sim)
  d <- 4 * p + 3 * q + 4
  set.seed(2)
  fit <- calibrate(prob$sim, prob$field, nMCMC = nAdapt + 2, nBurn = nAdapt, thinning = 1)
  dat <- fit$data
  sample_args <- list(dat$Xf, dat$yf, dat$Xs, dat$ys, as.list(fit$spec$table),
                      fit$state$last, unname(fit$state$logsd), nSweep, 0L, 1L, FALSE,
                      fit$state$batch, fit$settings$nugget, NULL)
  if (blocked) sample_args$blockSim <- TRUE
  gc()
  t0 <- proc.time()[[3]]
  res <- do.call(FBC:::.fbc_sample, sample_args)
  el <- proc.time()[[3]] - t0
  tn <- t_chol(n); tnm <- t_chol(n + m)
  floor_ms <- 2 * (p + q) * tnm + (d - 1 - 2 * (p + q)) * tn
  sweep_ms <- 1000 * el / nSweep
  essps <- vapply(seq_len(q), function(j) ess(res$draws[seq_len(res$kept), j]) / el, 0)
  data.frame(case = prob$name, move = if (blocked) "blocked" else "single",
             n = n, m = m, d = d, sweeps = nSweep,
             `ms/sweep` = sweep_ms, `t_chol(n)` = tn, `t_chol(n+m)` = tnm,
             `floor ms` = floor_ms, ratio = sweep_ms / floor_ms,
             `ESS/s kappa` = paste(sprintf("%.1f", essps), collapse = " "),
             `peak MB` = peak_mb(), check.names = FALSE)
}

# ---- run -----------------------------------------------------------------
cases <- list(
  list(prob = ball_problem(), nAdapt = 1000, nSweep = if (quick) 300 else 3000),
  list(prob = synthetic_problem(60, 300), nAdapt = if (quick) 100 else 600,
       nSweep = if (quick) 50 else 600),
  list(prob = synthetic_problem(60, 1000), nAdapt = 0, nSweep = if (quick) 2 else 8)
)
has_block <- "blockSim" %in% names(formals(FBC:::.fbc_sample))
t_start <- proc.time()[[3]]
rows <- list()
for (cs in cases) {
  rows[[length(rows) + 1]] <- run_case(cs$prob, max(cs$nAdapt, 1), cs$nSweep)
  if (has_block && cs$prob$name != "p=q=2 n=60 m=1000") {
    rows[[length(rows) + 1]] <- run_case(cs$prob, max(cs$nAdapt, 1), cs$nSweep, blocked = TRUE)
  }
}
tab <- do.call(rbind, rows)
num <- vapply(tab, is.numeric, TRUE)
tab[num] <- lapply(tab[num], function(x) signif(x, 3))

cat(sprintf("FBC %s speed benchmark, %s\n", utils::packageVersion("FBC"), format(Sys.time(), "%Y-%m-%d %H:%M")))
si <- utils::sessionInfo()
cat(sprintf("%s; %s; %d cores; BLAS: %s\n", R.version.string, si$running,
            parallel::detectCores(), basename(si$BLAS)))
cat("ms/sweep from a frozen-proposal run after calibrate()'s adaptation; floor from R's chol().\n",
    "ESS/s kappa: posterior::ess_bulk / run time (few sweeps for m = 1000: indicative only).\n\n", sep = "")
print(tab, row.names = FALSE)
cat(sprintf("\nTotal benchmark time: %.0f s\n", proc.time()[[3]] - t_start))
