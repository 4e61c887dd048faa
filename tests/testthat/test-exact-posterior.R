# Proof the sampler targets the right posterior: with every hyperparameter
# fixed, the kappa draws must match the posterior computed on a grid in plain
# R from dense_loglik() (helper-dense.R, one dense Cholesky of the full
# covariance) plus the Beta(1.1, 1.1) prior, which the default stretches over
# the simulator design's range of kappa (so on the sampler's [0, 1] scale it
# is the plain Beta density). The first test runs the default kernel (the
# Matérn 5/2 for both GPs); the others are written in the power
# exponential's parameters (their references and the data drawn from the
# model include the smoothness), so they name `kernelS = "powexp"`.

# (alphaS, alphaB: NULL for a family without a smoothness)
all_fixed <- function(thetaS, alphaS = NULL, thetaB, alphaB = NULL, sigma2S, sigma2B, sigma2E, muB) {
  smooth <- if (!is.null(alphaS)) {
    list(alphaSDist = "fixed", alphaSInit = alphaS, alphaBDist = "fixed", alphaBInit = alphaB)
  }
  do.call(set_hyperPriors, c(list(
    thetaSDist = "fixed", thetaSInit = thetaS, thetaBDist = "fixed", thetaBInit = thetaB,
    sigma2SDist = "fixed", sigma2SInit = sigma2S, sigma2BDist = "fixed", sigma2BInit = sigma2B,
    sigma2EDist = "fixed", sigma2EInit = sigma2E, muBDist = "fixed", muBInit = muB
  ), smooth))
}

# Posterior density (unnormalised, dense plain-R likelihood times the prior)
# of phi[cols] on the grid g x g, the other coordinates at the fit's last
# state (they are fixed).
grid_posterior_2d <- function(fit, cols, g, log_prior) {
  d <- fit$model$data
  phi <- fit$state$chains[[1]]$last
  lp <- outer(g, g, Vectorize(function(a, b) {
    phi[cols] <- c(a, b)
    dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, fbc_nugget)
  })) + outer(log_prior(g), log_prior(g), "+")
  exp(lp - max(lp))
}

# Largest error of the draws' quantiles against those of the j-th marginal
# of a 2-D grid density, in posterior standard deviations; `x` is the grid
# in the draws' units.
marginal_quantile_error <- function(draws, dens, j, x, probs = c(0.1, 0.25, 0.5, 0.75, 0.9)) {
  marg <- if (j == 1) rowSums(dens) else colSums(dens)
  ref <- grid_quantile(x, marg, probs)
  got <- stats::quantile(draws, probs, names = FALSE)
  max(abs(got - ref)) / stats::sd(draws)
}

# A q = 1 fit's kappa draws against the grid posterior (helper-grid.R) of
# dense_loglik() with the kernels' plain-R formulas and the fit's
# discrepancy model.
expect_dense_kappa_grid <- function(fit, kernS = "powexp", kernB = "powexp",
                                    u = seq(0, 1, length.out = 101)) {
  d <- fit$model$data
  expect_kappa_grid(fit, function(phi) {
    dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, fbc_nugget, kernS, kernB,
                 discrepancy = fit$model$discrepancy)
  }, u)
}

test_that("kappa draws match the grid posterior on the ball data (q = 1, default kernels)", {
  skip_if_not_slow()
  hyp <- all_fixed(thetaS = c(1.5, 0.2), thetaB = 2, sigma2S = 3.5, sigma2B = 0.9, sigma2E = 0.15,
                   muB = 0.2)
  set.seed(11)
  fit <- calibrate(ballSim, ballField, nMCMC = 9000, nBurn = 1000, thinning = 4,
                   nChains = 1, hypers = hyp)
  expect_identical(c(fit$model$kernelS, fit$model$kernelB), c("matern52", "matern52"))
  # fixed columns stay at their values and are not sampled
  expect_equal(unname(fit$Phi[1, -1]), c(1.5, 0.2, 2, 3.5, 0.9, 0.15, 0.2))
  expect_true(all(apply(fit$Phi[, -1], 2, stats::var) == 0))
  expect_true(all(is.na(fit$acceptance[-1])))
  # about 2000 nearly independent draws: quantile errors ~ 0.03-0.05 sd
  expect_dense_kappa_grid(fit, "matern52", "matern52")
})

test_that("Matern families: kappa draws match the grid posterior on the ball data", {
  skip_if_not_slow()
  # the reference: dense_loglik() with the Matern formulas of ?correlation
  # written in plain R (helper-dense.R), times the Beta(1.1, 1.1) prior
  hyp <- set_hyperPriors(
    thetaSDist = "fixed", thetaSInit = c(1.5, 0.2), thetaBDist = "fixed", thetaBInit = 2,
    sigma2SDist = "fixed", sigma2SInit = 3.5, sigma2BDist = "fixed", sigma2BInit = 0.9,
    sigma2EDist = "fixed", sigma2EInit = 0.15, muBDist = "fixed", muBInit = 0.2)
  set.seed(12)
  fit <- calibrate(ballSim, ballField, nMCMC = 9000, nBurn = 1000, thinning = 4,
                   nChains = 1, hypers = hyp, kernelS = "matern52", kernelB = "matern32")
  expect_identical(colnames(fit$Phi), c("kappa1", "thetaS1", "thetaS2", "thetaB1", "sigma2S",
                                        "sigma2B", "sigma2E", "muB"))
  expect_dense_kappa_grid(fit, "matern52", "matern32")
})

test_that("without a discrepancy, kappa draws match the grid posterior on the ball data", {
  skip_if_not_slow()
  # the reference: dense_loglik(discrepancy = "none") (no bias block) times
  # the Beta(1.1, 1.1) prior; the posterior is narrow, so a fine grid
  hyp <- set_hyperPriors(thetaSDist = "fixed", thetaSInit = c(3.6, 0.42), alphaSDist = "fixed",
                         alphaSInit = 1.95, sigma2SDist = "fixed", sigma2SInit = 3.3,
                         sigma2EDist = "fixed", sigma2EInit = 0.15)
  set.seed(13)
  fit <- calibrate(ballSim, ballField, nMCMC = 9000, nBurn = 1000, thinning = 4,
                   nChains = 1, hypers = hyp, discrepancy = "none", kernelS = "powexp")
  expect_identical(colnames(fit$Phi), c("kappa1", "thetaS1", "thetaS2", "alphaS1", "alphaS2",
                                        "sigma2S", "sigma2E"))
  expect_dense_kappa_grid(fit, u = seq(0, 1, length.out = 1001))
})

test_that("under the S-GaSP, kappa and lambdaZ draws match their grid posteriors (ball data)", {
  skip_if_not_slow()
  # the reference: dense_loglik(discrepancy = "sgasp"), the S-GaSP bias block
  # written from Gu and Wang's discretized kernel in plain R
  # (helper-dense.R), times the priors
  fixedBias <- list(thetaSDist = "fixed", thetaSInit = c(3.6, 0.42), alphaSDist = "fixed",
                    alphaSInit = 1.95, thetaBDist = "fixed", thetaBInit = 2,
                    alphaBDist = "fixed", alphaBInit = 1.8, sigma2SDist = "fixed",
                    sigma2SInit = 3.3, sigma2BDist = "fixed", sigma2BInit = 0.9,
                    sigma2EDist = "fixed", sigma2EInit = 0.15)
  hyp <- do.call(set_hyperPriors, c(fixedBias, list(lambdaZDist = "fixed", lambdaZInit = 20)))
  set.seed(14)
  fit <- calibrate(ballSim, ballField, nMCMC = 9000, nBurn = 1000, thinning = 4,
                   nChains = 1, hypers = hyp, discrepancy = "sgasp", kernelS = "powexp",
                   kernelB = "powexp")
  expect_identical(colnames(fit$Phi), c("kappa1", "thetaS1", "thetaS2", "alphaS1", "alphaS2",
                                        "thetaB1", "alphaB1", "lambdaZ", "sigma2S", "sigma2B",
                                        "sigma2E"))
  expect_dense_kappa_grid(fit, u = seq(0, 1, length.out = 501))
  # lambdaZ sampled under its default lognormal(log 20, 1.5) prior, kappa
  # fixed at 8.5: the draws of log(lambdaZ) against the grid posterior of
  # log(lambdaZ) (density L(e^u) prior(e^u) e^u)
  hyp <- do.call(set_hyperPriors, fixedBias)
  set.seed(15)
  fit <- calibrate(ballSim, ballField, nMCMC = 9000, nBurn = 1000, thinning = 4, nChains = 1,
                   hypers = hyp, discrepancy = "sgasp", kappaDist = "fixed", kappaInit = 8.5,
                   kernelS = "powexp", kernelB = "powexp")
  d <- fit$model$data
  phi <- fit$state$chains[[1]]$last
  j <- match("lambdaZ", fit$model$spec$vars)
  u <- seq(log(0.01), log(1e5), length.out = 801)
  lp <- vapply(u, function(v) {
    phi[j] <- exp(v)
    dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, fbc_nugget, discrepancy = "sgasp")
  }, numeric(1)) + stats::dlnorm(exp(u), log(20), 1.5, log = TRUE) + u
  dens <- exp(lp - max(lp))
  draws <- log(fit$Phi[, "lambdaZ"])
  probs <- c(0.05, 0.25, 0.5, 0.75, 0.95)
  err <- abs(stats::quantile(draws, probs, names = FALSE) - grid_quantile(u, dens, probs))
  expect_lt(max(err) / stats::sd(draws), 0.15)
  ks <- suppressWarnings(stats::ks.test(draws, grid_cdf(u, dens))$statistic)
  expect_lt(ks, 0.06)
})

test_that("kappa draws match the 2-D grid posterior on a q = 2 problem", {
  skip_if_not_slow()
  # data drawn from the model itself (dense_cov) at kappa = (0.3, 0.7)
  set.seed(5)
  n <- 8; m <- 30
  Xf <- matrix(seq(0, 1, length.out = n), n, 1)
  Xs <- cbind(lhs_like(m, 3))
  truth <- c(0.3, 0.7, 2, 1, 1.5, 1.9, 1.9, 1.9, 3, 1.9, 1, 0.05, 0.01, 0)
  y <- drop(t(chol(dense_cov(Xf, Xs, truth))) %*% stats::rnorm(n + m))
  sim <- cbind(y = y[n + seq_len(m)], x = Xs[, 1], t1 = Xs[, 2], t2 = Xs[, 3])
  field <- cbind(y = y[seq_len(n)], x = Xf[, 1])
  hyp <- all_fixed(thetaS = c(2, 1, 1.5), alphaS = 1.9, thetaB = 3, alphaB = 1.9,
                   sigma2S = 1, sigma2B = 0.05, sigma2E = 0.01, muB = 0)
  # 4 chains: ESS about 1800 of the kappas, quantile errors ~0.04 sd
  fit <- calibrate(sim, field, nMCMC = 30000, nBurn = 1000, thinning = 4, nChains = 4,
                   hypers = hyp, kernelS = "powexp", kernelB = "powexp")
  g <- seq(0, 1, length.out = 51)
  dens <- grid_posterior_2d(fit, 1:2, g, function(u) stats::dbeta(u, 1.1, 1.1, log = TRUE))
  for (j in 1:2) {
    k <- fit$model$scale$xmin[1 + j] + (fit$model$scale$xmax[1 + j] - fit$model$scale$xmin[1 + j]) * g
    err <- marginal_quantile_error(fit$Phi[, paste0("kappa", j)], dens, j, k)
    # 5 MC standard errors; grid spacing 1/50 adds ~0.02 of the range
    expect_lt(err, 0.2, label = paste("kappa", j))
  }
})

test_that("the joint thetaS move (default sampler) matches the 2-D grid posterior of thetaS", {
  skip_if_not_slow()
  # Everything but thetaS = (thetaS1, thetaS2) fixed, Gamma(4, 2) priors on
  # both; the reference is the plain-R dense likelihood times the priors on a
  # grid of thetaS. The block move proposes both at once on the log scale, so
  # a missing or wrong Jacobian, or a wrongly adapted joint proposal, would
  # shift these marginals.
  set.seed(8)
  n <- 6; m <- 20
  Xf <- matrix(seq(0, 1, length.out = n), n, 1)
  Xs <- lhs_like(m, 2)
  truth <- c(0.4, 1.5, 3, 1.9, 1.9, 2, 1.9, 1, 0.05, 0.01, 0)
  y <- drop(t(chol(dense_cov(Xf, Xs, truth))) %*% stats::rnorm(n + m))
  sim <- cbind(y = y[n + seq_len(m)], x = Xs[, 1], t = Xs[, 2])
  field <- cbind(y = y[seq_len(n)], x = Xf[, 1])
  hyp <- set_hyperPriors(
    thetaSDist = "gamma", thetaSInit = 1, thetaSP1 = 4, thetaSP2 = 2,
    alphaSDist = "fixed", alphaSInit = 1.9, thetaBDist = "fixed", thetaBInit = 2,
    alphaBDist = "fixed", alphaBInit = 1.9, sigma2SDist = "fixed", sigma2SInit = 1,
    sigma2BDist = "fixed", sigma2BInit = 0.05, sigma2EDist = "fixed", sigma2EInit = 0.01,
    muBDist = "fixed", muBInit = 0
  )
  kappa0 <- min(Xs[, 2]) + 0.4 * diff(range(Xs[, 2]))
  # (the random design stops short of the field's x = 1: the warning is expected)
  fit <- suppressWarnings(
    calibrate(sim, field, nMCMC = 12000, nBurn = 2000, thinning = 2, nChains = 2,
              kappaDist = "fixed", kappaInit = kappa0, hypers = hyp, kernelS = "powexp",
              kernelB = "powexp"),
    classes = "fbc_extrapolation")
  expect_identical(fit$model$sampler, "blocks")
  expect_equal(fit$acceptance[["thetaS1"]], fit$acceptance[["thetaS2"]])
  g <- seq(0.02, 8, length.out = 100)
  dens <- grid_posterior_2d(fit, 2:3, g, function(x) stats::dgamma(x, 4, 2, log = TRUE))
  for (j in 1:2) {
    err <- marginal_quantile_error(fit$Phi[, paste0("thetaS", j)], dens, j, g)
    # ESS about 2500: quantile errors ~0.03 sd (measured 0.02); a dropped
    # log-scale Jacobian turns the Gamma(4, 2) prior into Gamma(3, 2), ~0.5 sd
    expect_lt(err, 0.12, label = paste("thetaS", j))
  }
})

# A small problem drawn from the model (n = 6, m = 20, p = q = 1) for the
# exact tests of the default sampler's joint moves.
small_model_problem <- function(seed) {
  set.seed(seed)
  n <- 6; m <- 20
  Xf <- matrix(seq(0, 1, length.out = n), n, 1)
  Xs <- lhs_like(m, 2)
  truth <- c(0.4, 1.5, 3, 1.9, 1.9, 2, 1.9, 1, 0.3, 0.05, 0.2)
  y <- drop(t(chol(dense_cov(Xf, Xs, truth))) %*% stats::rnorm(n + m)) + c(rep(0.2, n), rep(0, m))
  list(sim = cbind(y = y[n + seq_len(m)], x = Xs[, 1], t = Xs[, 2]),
       field = cbind(y = y[seq_len(n)], x = Xf[, 1]), kappa0 = min(Xs[, 2]) + 0.4 * diff(range(Xs[, 2])))
}

test_that("the exact muB draw matches muB's closed-form Gaussian posterior", {
  # Everything but muB fixed; muB ~ N(0.5, 0.8^2). The log-likelihood is
  # Gaussian in muB, so the posterior is N(mean, sd) computed here from the
  # plain-R dense likelihood at three points (a quadratic's exact fit).
  pr <- small_model_problem(21)
  hyp <- set_hyperPriors(
    thetaSDist = "fixed", thetaSInit = c(1.5, 3), alphaSDist = "fixed", alphaSInit = 1.9,
    thetaBDist = "fixed", thetaBInit = 2, alphaBDist = "fixed", alphaBInit = 1.9,
    sigma2SDist = "fixed", sigma2SInit = 1, sigma2BDist = "fixed", sigma2BInit = 0.3,
    sigma2EDist = "fixed", sigma2EInit = 0.05, muBDist = "gaussian", muBP1 = 0.5, muBP2 = 0.8
  )
  set.seed(22)
  fit <- suppressWarnings(  # field inputs past the random design: expected
    calibrate(pr$sim, pr$field, nMCMC = 4100, nBurn = 100, thinning = 1, nChains = 1,
              kappaDist = "fixed", kappaInit = pr$kappa0, hypers = hyp, kernelS = "powexp",
              kernelB = "powexp"),
    classes = "fbc_extrapolation")
  expect_identical(fit$acceptance[["muB"]], 1)
  d <- fit$model$data
  phi <- fit$state$chains[[1]]$last
  lpost <- function(mu) {
    phi[length(phi)] <- mu
    dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, fbc_nugget) + stats::dnorm(mu, 0.5, 0.8, log = TRUE)
  }
  f <- vapply(c(-1, 0, 1), lpost, numeric(1))
  a <- (f[3] + f[1] - 2 * f[2]) / 2  # lpost(mu) = a mu^2 + b mu + c
  b <- (f[3] - f[1]) / 2
  sd <- sqrt(-1 / (2 * a)); mean <- -b / (2 * a)
  draws <- fit$Phi[, "muB"]
  # 4000 independent draws: mean error ~0.016 sd, sd error ~1.1%
  expect_lt(abs(mean(draws) - mean) / sd, 0.07)
  expect_lt(abs(stats::sd(draws) / sd - 1), 0.05)
  expect_gt(stats::ks.test(draws, "pnorm", mean, sd)$p.value, 0.001)
})

test_that("the scale move and single-site variance moves match the 3-D grid posterior", {
  skip_if_not_slow()
  # sigma2S, sigma2B, sigma2E free (InvGamma(3, 1), (3, 0.5), (3, 0.2)),
  # everything else fixed: the default sampler moves each variance alone and
  # all three by one factor (C -> c C). A missing Jacobian (3e) or a wrong
  # closed-form likelihood of the scale move would shift these marginals.
  pr <- small_model_problem(23)
  hyp <- set_hyperPriors(
    thetaSDist = "fixed", thetaSInit = c(1.5, 3), alphaSDist = "fixed", alphaSInit = 1.9,
    thetaBDist = "fixed", thetaBInit = 2, alphaBDist = "fixed", alphaBInit = 1.9,
    sigma2SDist = "inversegamma", sigma2SInit = 1, sigma2SP1 = 3, sigma2SP2 = 1,
    sigma2BDist = "inversegamma", sigma2BInit = 0.3, sigma2BP1 = 3, sigma2BP2 = 0.5,
    sigma2EDist = "inversegamma", sigma2EInit = 0.1, sigma2EP1 = 3, sigma2EP2 = 0.2,
    muBDist = "fixed", muBInit = 0.2
  )
  set.seed(24)
  fit <- calibrate(pr$sim, pr$field, nMCMC = 16000, nBurn = 1000, thinning = 3, nChains = 2,
                   kappaDist = "fixed", kappaInit = pr$kappa0, hypers = hyp, kernelS = "powexp",
                   kernelB = "powexp")
  expect_true(fit$model$moves$scale)
  sc <- fit$state$chains[[1]]$scaleAcceptance
  expect_true(sc > 0.1 && sc < 0.9)
  d <- fit$model$data
  phi <- fit$state$chains[[1]]$last
  ix <- unlist(fit$indices[c("sigma2S", "sigma2B", "sigma2E")])
  # grids on the log scale, covering the posterior (exp(-4) .. exp(2.5))
  lg <- seq(-4.5, 2.5, length.out = 36)
  g <- exp(lg)
  shape <- c(3, 3, 3); rate <- c(1, 0.5, 0.2)
  lp <- array(NA_real_, c(36, 36, 36))
  for (i in 1:36) for (j in 1:36) for (k in 1:36) {
    phi[ix] <- g[c(i, j, k)]
    lp[i, j, k] <- dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, fbc_nugget) +
      sum(shape * log(rate) - lgamma(shape) - (shape + 1) * log(g[c(i, j, k)]) - rate / g[c(i, j, k)]) +
      sum(lg[c(i, j, k)])  # density of log sigma2 on the log grid
  }
  dens <- exp(lp - max(lp))
  for (a in 1:3) {
    marg <- apply(dens, a, sum)
    ref <- grid_quantile(lg, marg, c(0.1, 0.25, 0.5, 0.75, 0.9))
    x <- log(fit$Phi[, ix[a]])
    got <- stats::quantile(x, c(0.1, 0.25, 0.5, 0.75, 0.9), names = FALSE)
    # ESS of several hundred to thousands: quantile errors ~0.05 sd; grid
    # spacing 0.2 on the log scale adds ~0.03 sd
    expect_lt(max(abs(got - ref)) / stats::sd(x), 0.2, label = names(ix)[a])
  }
})

test_that("without a discrepancy the scale move of (sigma2S, sigma2E) matches the 2-D grid posterior", {
  skip_if_not_slow()
  # sigma2S, sigma2E free (InvGamma(3, 1), (3, 0.2)), everything else fixed,
  # no bias: the scale move multiplies the two variances that exist, with
  # Jacobian 2e (a Jacobian of 3e would shift these marginals)
  pr <- small_model_problem(27)
  hyp <- set_hyperPriors(
    thetaSDist = "fixed", thetaSInit = c(1.5, 3), alphaSDist = "fixed", alphaSInit = 1.9,
    sigma2SDist = "inversegamma", sigma2SInit = 1, sigma2SP1 = 3, sigma2SP2 = 1,
    sigma2EDist = "inversegamma", sigma2EInit = 0.1, sigma2EP1 = 3, sigma2EP2 = 0.2
  )
  set.seed(28)
  fit <- suppressWarnings(  # field inputs past the random design: expected
    calibrate(pr$sim, pr$field, nMCMC = 16000, nBurn = 1000, thinning = 3, nChains = 2,
              kappaDist = "fixed", kappaInit = pr$kappa0, hypers = hyp, discrepancy = "none",
              kernelS = "powexp"),
    classes = "fbc_extrapolation")
  expect_true(fit$model$moves$scale)
  expect_identical(FBC:::move_report(fit)$parameters[FBC:::move_report(fit)$move == "scale"],
                   "sigma2S,sigma2E")
  d <- fit$model$data
  phi <- fit$state$chains[[1]]$last
  ix <- unlist(fit$indices[c("sigma2S", "sigma2E")])
  lg <- seq(-4.5, 2.5, length.out = 71)
  g <- exp(lg)
  shape <- c(3, 3); rate <- c(1, 0.2)
  lp <- outer(seq_along(g), seq_along(g), Vectorize(function(i, j) {
    phi[ix] <- g[c(i, j)]
    dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, fbc_nugget, discrepancy = "none") +
      sum(shape * log(rate) - lgamma(shape) - (shape + 1) * log(g[c(i, j)]) - rate / g[c(i, j)]) +
      sum(lg[c(i, j)])  # density of log sigma2 on the log grid
  }))
  dens <- exp(lp - max(lp))
  for (a in 1:2) {
    err <- marginal_quantile_error(log(fit$Phi[, ix[a]]), dens, a, lg)
    # ESS in the thousands: quantile errors ~0.05 sd; grid spacing 0.1
    expect_lt(err, 0.2, label = names(ix)[a])
  }
})

test_that("the bias block (thetaB, sigma2B) matches the 2-D grid posterior", {
  skip_if_not_slow()
  pr <- small_model_problem(25)
  hyp <- set_hyperPriors(
    thetaSDist = "fixed", thetaSInit = c(1.5, 3), alphaSDist = "fixed", alphaSInit = 1.9,
    thetaBDist = "gamma", thetaBInit = 2, thetaBP1 = 3, thetaBP2 = 1,
    alphaBDist = "fixed", alphaBInit = 1.9, sigma2SDist = "fixed", sigma2SInit = 1,
    sigma2BDist = "inversegamma", sigma2BInit = 0.3, sigma2BP1 = 3, sigma2BP2 = 0.5,
    sigma2EDist = "fixed", sigma2EInit = 0.05, muBDist = "fixed", muBInit = 0.2
  )
  set.seed(26)
  fit <- calibrate(pr$sim, pr$field, nMCMC = 12000, nBurn = 1000, thinning = 2, nChains = 2,
                   kappaDist = "fixed", kappaInit = pr$kappa0, hypers = hyp, kernelS = "powexp",
                   kernelB = "powexp")
  ix <- c(fit$indices$thetaB, fit$indices$sigma2B)
  expect_identical(fit$model$moves$blocks, list(bias = ix))
  expect_equal(fit$acceptance[["thetaB1"]], fit$acceptance[["sigma2B"]])
  d <- fit$model$data
  phi <- fit$state$chains[[1]]$last
  lg <- seq(-5, 3, length.out = 81)
  g <- exp(lg)
  lp <- outer(seq_along(g), seq_along(g), Vectorize(function(i, j) {
    phi[ix] <- g[c(i, j)]
    dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, fbc_nugget) +
      stats::dgamma(g[i], 3, 1, log = TRUE) +
      3 * log(0.5) - lgamma(3) - 4 * log(g[j]) - 0.5 / g[j] + lg[i] + lg[j]
  }))
  dens <- exp(lp - max(lp))
  for (a in 1:2) {
    err <- marginal_quantile_error(log(fit$Phi[, ix[a]]), dens, a, lg)
    expect_lt(err, 0.15, label = names(fit$Phi[1, ix[a], drop = FALSE]))
  }
})

# Tuo and Wu's (2015) model, wrong for every kappa, on 20 random runs and 16
# field data, with the simulator GP's parameters and sigma2E fixed (a
# default fit's last state on these data): kappa's posterior has a mode
# near -0.2 and one near 0.55. A fit, one chain, 5000 draws (`...`:
# kappa's prior).
tuo_wu_fit <- function(seed, ...) {
  eta <- function(x, u) exp(x / 10) * sin(x) - sqrt(u^2 - u + 1) * (sin(u * x) + cos(u * x))
  xf <- rep(seq(0.2, 2 * pi - 0.2, length.out = 8), 2)
  set.seed(1001)
  field <- data.frame(y = exp(xf / 10) * sin(xf) + stats::rnorm(16, 0, 0.2), x = xf)
  set.seed(3)
  x <- stats::runif(20, 0, 2 * pi)
  u <- stats::runif(20, -1, 1)
  sim <- data.frame(y = eta(x, u), x = x, u1 = u)
  hyp <- set_hyperPriors(thetaSDist = "fixed", thetaSInit = c(3.28, 9.77), sigma2SDist = "fixed",
                         sigma2SInit = 1.68, sigma2EDist = "fixed", sigma2EInit = 0.0473)
  set.seed(seed)
  suppressWarnings(calibrate(sim, field, discrepancy = "none", hypers = hyp, nMCMC = 20000,
                             nBurn = 1000, thinning = 4, nChains = 1, ...))
}
# kappa's grid posterior given the fit's fixed parameters: dense_loglik()
# times the prior, exp(logPrior(kappa)), on the grid `kappa` (its units)
tuo_wu_density <- function(fit, kappa, logPrior) {
  d <- fit$model$data
  phi <- fit$state$chains[[1]]$last
  g <- (kappa - fit$model$scale$xmin[2]) / (fit$model$scale$xmax[2] - fit$model$scale$xmin[2])
  lp <- vapply(g, function(k) {
    phi[1] <- k
    dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, fbc_nugget, "matern52", "matern52",
                 discrepancy = "none")
  }, numeric(1)) + logPrior(kappa)
  exp(lp - max(lp))
}

test_that("kappa's jump move finds both modes of a bimodal posterior in their grid proportions", {
  # The default Beta(1.1, 1.1) prior on kappa's range (the runs' range of
  # u): the upper mode has about 28% of the grid's mass. Without the jump
  # (no_jump()) the chain never left the lower mode (share 0, no crossing,
  # seeds 4-8); with it the share was 0.277-0.292 with 630-680 crossings.
  fit <- tuo_wu_fit(4)
  expect_identical(FBC:::move_report(fit)$move, c("kappa1", "kappa1 jump"))
  lo <- fit$model$scale$xmin[2]
  w <- fit$model$scale$xmax[2] - lo
  kappa <- lo + w * seq(0, 1, length.out = 1001)
  dens <- tuo_wu_density(fit, kappa, function(k) stats::dbeta((k - lo) / w, 1.1, 1.1, log = TRUE))
  upper <- sum(dens[kappa > 0]) / sum(dens)
  expect_gt(upper, 0.2)  # two modes, each with mass
  expect_lt(upper, 0.4)
  # the share of the draws in the upper mode: 5000 draws, about 650
  # crossings between the modes (sd of the share about 0.01)
  expect_lt(abs(mean(fit$Phi[, "kappa1"] > 0) - upper), 0.04)
  ks <- suppressWarnings(stats::ks.test(fit$Phi[, "kappa1"], grid_cdf(kappa, dens))$statistic)
  expect_lt(ks, 0.06)
})

test_that("with a gaussian prior kappa jumps over the prior's central 99.9%, and finds both modes", {
  # kappa ~ N(0, 0.5^2), unbounded: the jump proposes uniformly over
  # [-1.645, 1.645] (qnorm(0.0005) and qnorm(0.9995)); the grid over
  # [-2.5, 2.5] puts 19% of the mass above 0.2 and 0.75% beyond +-1.
  # Seeds 4-8 (this build): share 0.165-0.222 (about 300 crossings), KS
  # 0.008-0.031. Without the jump the chain crossed twice or never (share
  # 0.25, 0 and 0.41 on seeds 4-6).
  fit <- tuo_wu_fit(4, kappaDist = "gaussian", kappaP1 = 0, kappaP2 = 0.5)
  expect_identical(FBC:::move_report(fit)$move, c("kappa1", "kappa1 jump"))
  rng <- fit$model$scale$xmin[2] + (fit$model$scale$xmax[2] - fit$model$scale$xmin[2]) * fit$model$moves$jumpRange
  expect_equal(c(rng), stats::qnorm(c(0.0005, 0.9995), 0, 0.5))
  kappa <- seq(-2.5, 2.5, length.out = 2001)
  dens <- tuo_wu_density(fit, kappa, function(k) stats::dnorm(k, 0, 0.5, log = TRUE))
  upper <- sum(dens[kappa > 0.2]) / sum(dens)
  expect_gt(upper, 0.1)
  expect_lt(upper, 0.3)
  expect_lt(abs(mean(fit$Phi[, "kappa1"] > 0.2) - upper), 0.05)
  ks <- suppressWarnings(stats::ks.test(fit$Phi[, "kappa1"], grid_cdf(kappa, dens))$statistic)
  expect_lt(ks, 0.06)
})
