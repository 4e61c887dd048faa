# The grid posterior of kappa1 against the sampler's draws: the reference
# that test-exact-posterior.R, test-kronecker.R, test-vecchia.R and
# test-factors.R each check their algebra against; and the walked
# parameters of a sampler test against theirs (expect_draws_match_grid()).

# Quantiles of a density tabulated on an equispaced grid (trapezoid CDF).
grid_quantile <- function(x, dens, probs) {
  cdf <- c(0, cumsum((dens[-1] + dens[-length(dens)]) / 2 * diff(x)))
  cdf <- cdf / cdf[length(cdf)]
  stats::approx(cdf, x, probs, ties = "ordered")$y
}
grid_cdf <- function(x, dens) {
  cdf <- c(0, cumsum((dens[-1] + dens[-length(dens)]) / 2 * diff(x)))
  stats::approxfun(x, cdf / cdf[length(cdf)], yleft = 0, yright = 1)
}

# A fit's kappa1 draws (every other parameter fixed, at the first chain's
# last state) against the posterior on the grid `u` of the scaled kappa1:
# loglik(phi) with phi[1] = u, times the Beta(1.1, 1.1) prior in the scaled
# kappa (the default, stretched over the design's range). The 5, 25, 50, 75
# and 95% quantiles within `quantileTol` posterior sd; the KS statistic
# below `ksTol` (NULL: not checked). `col`: kappa1's column of the fit's
# input scaling.
expect_kappa_grid <- function(fit, loglik, u = seq(0, 1, length.out = 101), col = 2L,
                              quantileTol = 0.15, ksTol = 0.06) {
  phi <- fit$state$chains[[1]]$last
  lp <- vapply(u, function(k) {
    phi[1] <- k
    loglik(phi)
  }, numeric(1)) + stats::dbeta(u, 1.1, 1.1, log = TRUE)
  dens <- exp(lp - max(lp))
  lo <- fit$model$scale$xmin[col]
  kappa <- lo + (fit$model$scale$xmax[col] - lo) * u
  probs <- c(0.05, 0.25, 0.5, 0.75, 0.95)
  ref <- grid_quantile(kappa, dens, probs)
  got <- stats::quantile(fit$Phi[, "kappa1"], probs, names = FALSE)
  expect_lt(max(abs(got - ref)) / stats::sd(fit$Phi[, "kappa1"]), quantileTol)
  if (!is.null(ksTol)) {
    ks <- suppressWarnings(stats::ks.test(fit$Phi[, "kappa1"], grid_cdf(kappa, dens))$statistic)
    expect_lt(ks, ksTol)
  }
}

# The draws of the walked parameters `vars` of a one-chain fit (every other
# parameter fixed) against their posterior on a grid of the walk's scales
# (npts points a side, +-5 sd of the draws): the compiled log-likelihood
# times the priors, its marginals' means and sds by the trapezoid rule; the
# draws' means within 0.1 sd, their sds within 8%.
expect_draws_match_grid <- function(fit, vars, npts) {
  k <- length(vars)
  cols <- match(vars, fit$model$spec$vars)
  W <- log(FBC:::sampler_draws(fit)[, cols, drop = FALSE])
  tab <- fit$model$spec$table
  phi <- fit$state$chains[[1]]$last
  dat <- fit$model$data
  g <- lapply(seq_len(k), function(i) seq(mean(W[, i]) - 5 * sd(W[, i]),
                                          mean(W[, i]) + 5 * sd(W[, i]), length.out = npts))
  lp <- apply(as.matrix(expand.grid(g)), 1, function(w) {
    x <- exp(w)
    phi[cols] <- x
    FBC:::.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, model = fit$model$spec$model) +
      sum(vapply(seq_len(k), function(i) FBC:::log_prior_row(tab, cols[i], x[i]), numeric(1))) +
      sum(w)
  })
  dens <- array(exp(lp - max(lp)), rep(npts, k))
  for (i in seq_len(k)) {
    marg <- apply(dens, i, sum)
    marg <- marg / sum(marg)
    mu <- sum(g[[i]] * marg)
    s <- sqrt(sum((g[[i]] - mu)^2 * marg))
    expect_lt(abs(mean(W[, i]) - mu) / s, 0.1)
    expect_lt(abs(sd(W[, i]) / s - 1), 0.08)
  }
}
