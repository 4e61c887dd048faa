# The grid posterior of kappa1 against the sampler's draws: the reference
# that test-exact-posterior.R, test-kronecker.R, test-vecchia.R and
# test-factors.R each check their algebra against.

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
