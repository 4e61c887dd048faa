# The simulator as an R function: FBC's calibrate(f, field)
# beside RobustCalibration's rcalibration(simul_type = 1, math_model = f),
# in the same process, on
#   - RobustCalibration's documented example (?rcalibration): reality
#     x cos(1.5 x) + x, 15 field points on [0, 5] with noise sd 0.1
#     (set.seed(1), as there), model sin(theta x) + x, theta in [0, 3];
#   - the chemical kinetics data of Bayarri et al. (2007) (FBC's
#     kineticField; RobustCalibration does not ship them): model 5 exp(-u t),
#     u in [0.5, 3] (kineticSim's range).
# For each discrepancy model ("none", "gp", "sgasp"; the peer's
# "no-discrepancy", "GaSP", "S-GaSP"): CPU seconds (user + sys of this
# process), kappa's median and 90% interval, max R-hat and bulk ESS of
# kappa over 4 chains, and kappa's ESS per CPU second.
#   FBC: the defaults (4 chains, sequential plan, warm-up until settled, run
#   until every R-hat < 1.01 and bulk ESS >= 400).
#   FBC, 4 x 10000: the peer's run length (nMCMC = 10000, nBurn = 2000,
#   thinning = 1), for ESS per CPU second at equal lengths.
#   RobustCalibration: 4 chains (4 calls, seeds 1-4) of its documented
#   length, S = 10000 with S_0 = 2000 burn-in; R-hat and ESS of theta from
#   the 4 chains by the posterior package (the same estimators as FBC's).
#
#   R_LIBS=<FBC lib>:<RobustCalibration lib> Rscript bench/run.R function [--reps=2]
#
# reps: repeats of each FBC fit with seeds 1, 2, ... (default 2). Then the
# bimodal example (no discrepancy): its exact posterior on a grid against
# 10 default runs. Results: bench/RESULTS-function.md.
library(FBC)
source("bench/options.R")
reps <- bench_options(list(reps = 2L))$reps
peer <- requireNamespace("RobustCalibration", quietly = TRUE)

cpu <- function() sum(proc.time()[c("user.self", "sys.self")])

problems <- list(
  rc_example = local({
    set.seed(1)
    x <- seq(0, 5, 5 / 14)
    y <- x * cos(3 / 2 * x) + x + stats::rnorm(15, 0, 0.1)
    list(field = data.frame(y = y, x = x),
         f = function(x, kappa) sin(kappa[["theta"]] * x$x) + x$x,
         peer = function(x, theta) sin(theta * x) + x,
         lower = c(theta = 0), upper = c(theta = 3))
  }),
  kinetics = list(
    field = as.data.frame(kineticField),
    f = function(x, kappa) 5 * exp(-kappa[["u"]] * x$t),
    peer = function(x, theta) 5 * exp(-theta * x),
    lower = c(u = 0.5), upper = c(u = 3))
)

summarise <- function(draws, chain, secs) {
  ess <- posterior::ess_bulk(matrix(draws, ncol = length(unique(chain))))
  rh <- posterior::rhat(matrix(draws, ncol = length(unique(chain))))
  q <- stats::quantile(draws, c(0.05, 0.5, 0.95), names = FALSE)
  data.frame(cpu = secs, median = q[2], lo90 = q[1], hi90 = q[3], rhat = rh, ess = ess,
             essPerSec = ess / secs)
}

fbc_row <- function(pr, disc, seed, fixed = FALSE) {
  set.seed(seed)
  t0 <- cpu()
  fit <- if (fixed) {
    # the peer's length: 4 chains of 10000 sweeps, 2000 of warm-up, all kept
    calibrate(pr$f, pr$field, kappaDist = "uniform", kappaP1 = pr$lower, kappaP2 = pr$upper,
              discrepancy = disc, nMCMC = 10000, nBurn = 2000, thinning = 1)
  } else {
    calibrate(pr$f, pr$field, kappaDist = "uniform", kappaP1 = pr$lower,
              kappaP2 = pr$upper, discrepancy = disc)
  }
  secs <- cpu() - t0
  est <- fit$estimates
  q <- stats::quantile(fit$Phi[, "kappa1"], c(0.05, 0.5, 0.95), names = FALSE)
  data.frame(cpu = secs, median = q[2], lo90 = q[1], hi90 = q[3],
             rhat = est["kappa1", "rhat"], ess = est["kappa1", "ess"],
             essPerSec = est["kappa1", "ess"] / secs, maxRhatAll = max(est[, "rhat"]),
             minEssAll = min(est[, "ess"]), sweeps = fit$settings$nMCMC,
             converged = if (fixed) NA else isTRUE(fit$settings$converge$converged))
}

peer_row <- function(pr, disc) {
  type <- c(none = "no-discrepancy", gp = "GaSP", sgasp = "S-GaSP")[[disc]]
  t0 <- cpu()
  chains <- lapply(1:4, function(s) {
    set.seed(s)
    capture.output(m <- RobustCalibration::rcalibration(
      design = as.matrix(pr$field[, 2]), observations = pr$field[, 1], p_theta = 1,
      simul_type = 1, math_model = pr$peer, theta_range = matrix(c(pr$lower, pr$upper), 1, 2),
      S = 10000, S_0 = 2000, discrepancy_type = type))
    m@post_sample[, 1]
  })
  secs <- cpu() - t0
  n <- min(lengths(chains))
  draws <- unlist(lapply(chains, function(v) utils::tail(v, n)))
  out <- summarise(draws, rep(1:4, each = n), secs)
  out$sweeps <- 10000
  out
}

rows <- list()
for (name in names(problems)) {
  pr <- problems[[name]]
  for (disc in c("none", "gp", "sgasp")) {
    for (r in seq_len(reps)) {
      row <- fbc_row(pr, disc, r)
      rows[[length(rows) + 1]] <- cbind(problem = name, discrepancy = disc, software = "FBC",
                                        seed = r, row)
      print(utils::tail(rows, 1)[[1]], digits = 3)
    }
    row <- fbc_row(pr, disc, 1L, fixed = TRUE)
    rows[[length(rows) + 1]] <- cbind(problem = name, discrepancy = disc,
                                      software = "FBC, 4 x 10000", seed = 1L, row)
    print(utils::tail(rows, 1)[[1]], digits = 3)
    if (peer) {
      row <- peer_row(pr, disc)
      rows[[length(rows) + 1]] <- cbind(problem = name, discrepancy = disc,
                                        software = "RobustCalibration", seed = 1, row,
                                        maxRhatAll = NA, minEssAll = NA, converged = NA)
      print(utils::tail(rows, 1)[[1]], digits = 3)
    }
  }
}
# The bimodal example with no discrepancy: the exact posterior of theta on
# a grid (plain R: theta uniform on [0, 3], the scaled noise sd half-Cauchy
# (0, 1), FBC's default, integrated out on a grid of log s) against 10
# default runs (seeds 1-10): the small mode's mass (theta < 1), the 5% and
# 95% quantiles.
bimodal_grid <- function(pr) {
  y <- pr$field$y
  ysd <- stats::sd(y)
  th <- seq(0, 3, length.out = 30001)
  ls <- seq(log(1e-4), log(10), length.out = 4001)
  lps <- log(2 / pi) - log1p(exp(2 * ls)) + ls
  lpost <- vapply(th, function(t) {
    ss <- sum(((y - pr$f(pr$field, c(theta = t))) / ysd)^2)
    l <- -length(y) * ls - ss / (2 * exp(2 * ls)) + lps
    max(l) + log(sum(exp(l - max(l))))
  }, numeric(1))
  w <- exp(lpost - max(lpost))
  w <- w / sum(w)
  cdf <- cumsum(w)
  qs <- vapply(c(0.05, 0.5, 0.95), function(p) th[which(cdf >= p)[1]], numeric(1))
  data.frame(seed = NA, cpu = NA, sweeps = NA, small = sum(w[th < 1]), lo90 = qs[1],
             median = qs[2], hi90 = qs[3], rhat = NA, ess = NA)
}
pr <- problems$rc_example
bim <- list(cbind(run = "exact (grid)", bimodal_grid(pr)))
for (s in 1:10) {
  set.seed(s)
  t0 <- cpu()
  fit <- calibrate(pr$f, pr$field, kappaDist = "uniform", kappaP1 = pr$lower,
                   kappaP2 = pr$upper, discrepancy = "none", showProgress = FALSE)
  th <- fit$Phi[, "kappa1"]
  q <- stats::quantile(th, c(0.05, 0.5, 0.95), names = FALSE)
  bim[[length(bim) + 1]] <- data.frame(run = "FBC defaults", seed = s, cpu = cpu() - t0,
                                       sweeps = fit$settings$nMCMC, small = mean(th < 1),
                                       lo90 = q[1], median = q[2], hi90 = q[3],
                                       rhat = fit$estimates["kappa1", "rhat"],
                                       ess = fit$estimates["kappa1", "ess"])
}
bim <- do.call(rbind, bim)
print(bim, digits = 3, row.names = FALSE)
saveRDS(bim, "function-bimodal.rds")

tab <- do.call(rbind, lapply(rows, function(r) r[, c("problem", "discrepancy", "software", "seed",
                                                     "cpu", "sweeps", "median", "lo90", "hi90",
                                                     "rhat", "ess", "essPerSec", "converged")]))
print(tab, digits = 3, row.names = FALSE)
saveRDS(tab, "function-bench.rds")
