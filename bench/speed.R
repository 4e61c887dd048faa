# Speed benchmark of the FBC sampler against the Cholesky floor.
#
# Run after installing the package, from the package root:
#   Rscript bench/run.R speed [--quick]     # --quick: fewer sweeps, a smoke test
#   R_LIBS=/path/to/lib Rscript bench/run.R speed
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
# "blocks" rows use the default sampler (joint moves; see ?calibrate).
suppressPackageStartupMessages(library(FBC))
source("bench/options.R")
quick <- bench_options()$quick

# ---- helpers -------------------------------------------------------------
peak_mb <- function(field = "VmHWM") {
  s <- tryCatch(readLines("/proc/self/status"), error = function(e) character())
  v <- grep(paste0("^", field), s, value = TRUE)
  if (length(v)) as.numeric(gsub("[^0-9]", "", v)) / 1024 else NA_real_
}
reset_peak <- function() {
  # Linux >= 4.0: writing 5 resets the peak RSS to the current RSS
  invisible(tryCatch(writeLines("5", "/proc/self/clear_refs"), error = function(e) NULL,
                     warning = function(w) NULL))
}
# CPU seconds of this process (user + system). Single-threaded reference
# BLAS: equal to wall time on an idle machine, and much less sensitive than
# wall time to other jobs sharing the cores.
cpu <- function() sum(proc.time()[1:2])
# Median CPU time (ms) of R's chol() on a k x k SPD matrix, in batches of
# >= 50 ms (the CPU clock ticks in ms).
t_chol <- function(k, budget = 1.5) {
  set.seed(k)
  X <- matrix(rnorm(k * k), k)
  A <- crossprod(X) / k + diag(k)
  t0 <- cpu(); chol(A); chol(A); est <- max((cpu() - t0) / 2, 1e-5)
  reps <- max(1L, ceiling(0.05 / est))
  times <- numeric(0)
  t_end <- cpu() + budget
  repeat {
    t0 <- cpu()
    for (i in seq_len(reps)) chol(A)
    times <- c(times, (cpu() - t0) / reps)
    if (cpu() > t_end && length(times) >= 3) break
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

# Adapt the proposals with calibrate() (nAdapt sweeps of burn-in, sampler
# `sampler`), then time nSweep sweeps of .fbc_sample() from where it stopped
# with the proposals frozen, in `chunks` runs, each continuing the last from
# the returned state, with t_chol(n) and t_chol(n + m) measured between
# them: the medians of sweep time, floor and their ratio resist the load of
# other jobs on the shared cores. The "blocks" rows use the single-site
# rows' floor (a blocked sweep makes fewer factorizations than the floor
# counts: ratios below 1).
run_case <- function(prob, nAdapt, nSweep, chunks = 1, sampler = "single", floor_ms = NULL) {
  reset_peak()
  p <- ncol(prob$field) - 1L
  q <- ncol(prob$sim) - 1L - p
  n <- nrow(prob$field); m <- nrow(prob$sim)
  d <- 4 * p + 3 * q + 4
  set.seed(2)
  fit <- calibrate(prob$sim, prob$field, nMCMC = nAdapt + 2, nBurn = nAdapt, thinning = 1,
                   nChains = 1, sampler = sampler)
  dat <- fit$model$data
  state <- fit$state$chains[[1]]$sampler
  moves <- fit$model$moves
  invisible(gc())
  per <- ceiling(nSweep / chunks)
  el <- wall <- 0
  chunk_ms <- fl <- tn <- tnm <- numeric(chunks)
  draws <- NULL
  for (i in seq_len(chunks)) {
    t0 <- cpu(); w0 <- proc.time()[[3]]
    res <- FBC:::.fbc_sample(dat$Xf, dat$yf, dat$Xs, dat$ys, as.list(fit$model$spec$table), moves,
                             state, per, 0L, 1L, fit$settings$nugget, NULL)
    dt <- cpu() - t0
    el <- el + dt; wall <- wall + proc.time()[[3]] - w0
    chunk_ms[i] <- 1000 * dt / per
    state <- res$state
    draws <- rbind(draws, res$draws[seq_len(res$kept), seq_len(q), drop = FALSE])
    if (is.null(floor_ms)) {
      tn[i] <- t_chol(n, budget = 0.3); tnm[i] <- t_chol(n + m, budget = 0.3)
      fl[i] <- 2 * (p + q) * tnm[i] + (d - 1 - 2 * (p + q)) * tn[i]
    }
  }
  nSweep <- per * chunks
  sweep_ms <- stats::median(chunk_ms)
  if (is.null(floor_ms)) {
    floor_ms <- stats::median(fl)
    ratio <- stats::median(chunk_ms / fl)
    tn <- stats::median(tn); tnm <- stats::median(tnm)
  } else {
    ratio <- sweep_ms / floor_ms
    tn <- tnm <- NA_real_
  }
  essps <- vapply(seq_len(q), function(j) {
    if (nrow(draws) < 100) NA_real_ else ess(draws[, j]) / el
  }, 0)
  data.frame(case = prob$name, sampler = sampler,
             sweeps = nSweep, `ms/sweep` = sweep_ms, `wall ms` = 1000 * wall / nSweep,
             `t_chol(n)` = tn, `t_chol(n+m)` = tnm, `floor ms` = floor_ms,
             ratio = ratio,
             `ESS/s kappa` = paste(sprintf("%.3g", essps), collapse = " "),
             `peak MB` = peak_mb(), check.names = FALSE)
}

# ---- run -----------------------------------------------------------------
cases <- list(
  list(prob = ball_problem(), nAdapt = 1000, nSweep = if (quick) 300 else 3000,
       chunks = if (quick) 2 else 6),
  list(prob = synthetic_problem(60, 300), nAdapt = if (quick) 100 else 600,
       nSweep = if (quick) 50 else 600, chunks = if (quick) 2 else 4),
  list(prob = synthetic_problem(60, 1000), nAdapt = 1, nSweep = if (quick) 2 else 6,
       chunks = if (quick) 1 else 2)
)
invisible(gc())
baseline_mb <- peak_mb("VmRSS")
t_start <- proc.time()[[3]]
rows <- list()
for (cs in cases) {
  single <- run_case(cs$prob, cs$nAdapt, cs$nSweep, cs$chunks)
  rows[[length(rows) + 1]] <- single
  if (cs$nAdapt > 1) {
    rows[[length(rows) + 1]] <- run_case(cs$prob, cs$nAdapt, cs$nSweep, cs$chunks,
                                         sampler = "blocks", floor_ms = single[["floor ms"]])
  }
}
tab <- do.call(rbind, rows)
num <- vapply(tab, is.numeric, TRUE)
tab[num] <- lapply(tab[num], function(x) signif(x, 3))

cat(sprintf("FBC %s speed benchmark, %s\n", utils::packageVersion("FBC"), format(Sys.time(), "%Y-%m-%d %H:%M")))
si <- utils::sessionInfo()
cat(sprintf("%s; %s; %d cores; BLAS: %s\n", R.version.string, si$running,
            as.integer(parallelly::availableCores()), basename(si$BLAS)))
cat("ms/sweep: CPU ms per sweep of frozen-proposal runs after calibrate()'s adaptation\n",
    "(median over chunks; wall ms alongside, the cores are shared).\n",
    "floor = 2(p+q) t_chol(n+m) + (d-1-2(p+q)) t_chol(n), t_chol = CPU ms of R's chol()\n",
    "measured between the chunks; ratio = median over chunks of ms/sweep / floor.\n",
    "ESS/s kappa: posterior::ess_bulk of each kappa / CPU s (m = 1000: too few sweeps).\n",
    "blocks = the default sampler (joint moves, see ?calibrate), same floor as single.\n",
    sprintf("peak MB: VmHWM of the R process during the case (R + FBC alone: %.0f MB).\n\n",
            baseline_mb), sep = "")
print(tab, row.names = FALSE)
cat(sprintf("\nTotal benchmark time: %.0f s (wall)\n", proc.time()[[3]] - t_start))
