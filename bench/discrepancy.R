# Known-answer study of the discrepancy models: problems whose
# L2 projection theta* = argmin_theta integral (zeta(x) - eta(x, theta))^2 dx
# is computable, calibrated under discrepancy = "gp", "sgasp" and "none" on
# replicated field data sets. For each problem and model: coverage of
# theta* by the 90% interval of kappa, its mean width, the held-out RMSE of
# the predicted field process (type "mean": eta + delta, MAP) against zeta
# at 60 new inputs, the coverage of zeta by its 90% Bayesian intervals
# there, and CPU seconds per fit.
#
#   Rscript bench/run.R discrepancy [--reps=50] [--out=discrepancy-study.rds]
#
# Results accumulate in out.rds (default discrepancy-study.rds), one row per
# fit, so an interrupted study resumes; the table is printed at the end.
# bench/RESULTS-discrepancy.md holds the measured tables.
library(FBC)
source("bench/options.R")
opt <- bench_options(list(reps = 50L, out = "discrepancy-study.rds"))
reps <- opt$reps
out <- opt$out

# theta* on the problem's x range and theta range (one-dimensional)
l2_projection <- function(pr) {
  f <- function(th) stats::integrate(function(x) (pr$zeta(x) - pr$eta(x, th))^2,
                                     pr$x[1], pr$x[2], rel.tol = 1e-10)$value
  stats::optimize(f, pr$theta, tol = 1e-10)$minimum
}

problems <- list(
  # Bayarri et al. (2007), chemical kinetics: the simulator misses the
  # asymptote 1.5 (theta* = 0.642 on [0, 3], Plumlee 2017, Gu & Wang 2018)
  kinetics = list(
    zeta = function(x) 3.5 * exp(-1.7 * x) + 1.5,
    eta = function(x, th) 5 * exp(-th * x),
    x = c(0, 3), theta = c(0, 3), xf = seq(0.11, 3.01, length.out = 10), reps = 3, sd = 0.2),
  # Tuo and Wu (2015), section 6: zeta(x) = exp(x / 10) sin(x) on [0, 2 pi]
  # (theta* = -0.1789)
  tuowu = list(
    zeta = function(x) exp(x / 10) * sin(x),
    eta = function(x, th) exp(x / 10) * sin(x) - sqrt(th^2 - th + 1) * (sin(th * x) + cos(th * x)),
    x = c(0, 2 * pi), theta = c(-1, 1), xf = seq(0, 2 * pi, length.out = 15), reps = 1, sd = 0.2),
  # Plumlee (2017), example 1: a linear simulator theta x of 4x + x sin 5x
  # on [0, 1]
  plumlee = list(
    zeta = function(x) 4 * x + x * sin(5 * x),
    eta = function(x, th) th * x,
    x = c(0, 1), theta = c(2, 6), xf = seq(0.05, 0.95, length.out = 12), reps = 1, sd = 0.1)
)

# 40 simulator runs on a maximin Latin hypercube over (x, theta)
sim_runs <- function(pr, seed) {
  set.seed(seed)
  u <- if (requireNamespace("lhs", quietly = TRUE)) lhs::maximinLHS(40, 2) else
    cbind((sample(40) - runif(40)) / 40, (sample(40) - runif(40)) / 40)
  x <- pr$x[1] + diff(pr$x) * u[, 1]
  th <- pr$theta[1] + diff(pr$theta) * u[, 2]
  cbind(y = pr$eta(x, th), x = x, t = th)
}

one_fit <- function(pr, name, rep, disc, star) {
  set.seed(1000 * rep + match(name, names(problems)))
  sim <- sim_runs(pr, 7 + rep)
  xf <- rep(pr$xf, each = pr$reps)
  field <- cbind(y = pr$zeta(xf) + stats::rnorm(length(xf), 0, pr$sd), x = xf)
  t0 <- proc.time()
  fit <- suppressWarnings(calibrate(sim, field, nMCMC = 3000, nBurn = 1000, nChains = 2,
                                    kernelS = "matern52", kernelB = "matern52",
                                    discrepancy = disc))
  xt <- seq(pr$x[1], pr$x[2], length.out = 60)
  map <- predict(fit, xt, method = "MAP", type = "mean")
  bay <- suppressWarnings(predict(fit, xt, type = "mean", ndraws = 200, level = 0.9))
  cpu <- sum((proc.time() - t0)[c(1, 2)])
  k <- fit$Phi[, "kappa1"]
  q <- stats::quantile(k, c(0.05, 0.95), names = FALSE)
  z <- pr$zeta(xt)
  data.frame(problem = name, rep = rep, model = disc, theta = star,
             lower = q[1], upper = q[2], cover = q[1] <= star & star <= q[2], width = q[2] - q[1],
             rmse = sqrt(mean((map$pred - z)^2)),
             pcover = mean(bay$lower <= z & z <= bay$upper), cpu = cpu,
             rhat = max(fit$estimates$rhat, na.rm = TRUE))
}

res <- if (file.exists(out)) readRDS(out) else NULL
for (name in names(problems)) {
  pr <- problems[[name]]
  star <- l2_projection(pr)
  cat(sprintf("%s: theta* = %.4f\n", name, star))
  for (rep in seq_len(reps)) for (disc in c("gp", "sgasp", "none")) {
    if (!is.null(res) && any(res$problem == name & res$rep == rep & res$model == disc)) next
    res <- rbind(res, one_fit(pr, name, rep, disc, star))
    saveRDS(res, out)
  }
}

tab <- do.call(rbind, lapply(split(res, list(res$problem, res$model), drop = TRUE), function(d) {
  data.frame(problem = d$problem[1], model = d$model[1], fits = nrow(d),
             theta.star = round(d$theta[1], 4), coverage90 = mean(d$cover),
             width = mean(d$width), rmse = mean(d$rmse), pred.coverage90 = mean(d$pcover),
             cpu.s = mean(d$cpu), max.rhat = max(d$rhat))
}))
tab <- tab[order(tab$problem, match(tab$model, c("gp", "sgasp", "none"))), ]
rownames(tab) <- NULL
print(tab, digits = 3)
