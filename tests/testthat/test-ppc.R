# References: dense_predict() (helper-predict.R), the GP conditional of a new
# field observation written with the dense joint covariance and base R's
# solve(); replicates, p-values and intervals written out in plain R.

test_that("with fixed parameters the check is the dense predictive at the field inputs", {
  set.seed(3)
  phi <- random_phi(2, 1)
  fit <- fixed_fit(phi)
  sc <- fit$model$scale
  d <- fit$model$data
  ref <- dense_predict(d$Xf, d$yf, d$Xs, d$ys, phi, d$Xf, "field")
  mu <- sc$ymean + sc$ysd * ref$mean
  s <- sc$ysd * sqrt(ref$var)
  y <- sc$ymean + sc$ysd * d$yf
  n <- length(y)
  set.seed(9)
  pp <- ppc_field(fit, ndraws = 5)
  set.seed(9)
  eps <- matrix(rnorm(5 * n), 5, n)
  expect_equal(pp$y, y)
  expect_equal(pp$ndraws, 5L)
  # one replicated data set per row: y_rep = m + s * eps
  expect_equal(pp$yrep, sweep(sweep(eps, 2, s, "*"), 2, mu, "+"), tolerance = 1e-8)
  expect_equal(pp$obs$mean, mu, tolerance = 1e-8)
  expect_equal(pp$obs$sd, s, tolerance = 1e-8)
  expect_equal(pp$obs$median, mu, tolerance = 1e-8)
  expect_equal(pp$obs$lower90, mu - qnorm(0.95) * s, tolerance = 1e-8)
  expect_equal(pp$obs$upper50, mu + qnorm(0.75) * s, tolerance = 1e-8)
  expect_equal(pp$obs$p, pnorm((mu - y) / s), tolerance = 1e-8)
  expect_equal(unname(pp$outside), sapply(c(0.5, 0.9, 0.95), function(l) {
    mean(y < mu - qnorm((1 + l) / 2) * s | y > mu + qnorm((1 + l) / 2) * s)
  }))
  expect_equal(pp$x, FBC:::unscale_inputs(d$Xf, sc, 1:2), ignore_attr = TRUE)
  expect_equal(colnames(pp$x), c("x1", "x2"))
})

test_that("a Matern fit: the check is the dense predictive in its families", {
  set.seed(4)
  phi <- random_phi(2, 1)
  fit <- fixed_fit(phi, kernelS = "matern32", kernelB = "matern52")
  sc <- fit$model$scale
  d <- fit$model$data
  ref <- dense_predict(d$Xf, d$yf, d$Xs, d$ys, phi, d$Xf, "field", kernS = "matern32",
                       kernB = "matern52")
  pp <- ppc_field(fit, ndraws = 3)
  expect_equal(pp$obs$mean, sc$ymean + sc$ysd * ref$mean, tolerance = 1e-8)
  expect_equal(pp$obs$sd, sc$ysd * sqrt(ref$var), tolerance = 1e-8)
})

test_that("several draws: the numbers come from the mixture of the draws' predictives", {
  set.seed(3)
  phi <- random_phi(2, 1)
  fit <- fixed_fit(phi)
  sc <- fit$model$scale
  d <- fit$model$data
  set.seed(8)
  phis <- rbind(phi, t(replicate(2, random_phi(2, 1))))
  Phi <- phis
  Phi[, 1] <- sc$xmin[3] + phis[, 1] * (sc$xmax[3] - sc$xmin[3])
  colnames(Phi) <- colnames(fit$Phi)
  fit <- fit_with_draws(fit, Phi, logPost = rep_len(fit$logPost, 3))
  refs <- lapply(1:3, function(i) dense_predict(d$Xf, d$yf, d$Xs, d$ys, phis[i, ], d$Xf, "field"))
  m <- sc$ymean + sc$ysd * sapply(refs, `[[`, "mean")
  s <- sc$ysd * sqrt(sapply(refs, `[[`, "var"))
  y <- sc$ymean + sc$ysd * d$yf
  pp <- ppc_field(fit)
  expect_equal(dim(pp$yrep), c(3L, length(y)))
  expect_equal(pp$obs$mean, rowMeans(m), tolerance = 1e-8)
  expect_equal(pp$obs$p, rowMeans(1 - pnorm((y - m) / s)), tolerance = 1e-8)
  # the interval bounds solve mean_d Phi((b - m_d) / s_d) = 0.05, 0.95
  expect_equal(rowMeans(pnorm((pp$obs$lower90 - m) / s)), rep(0.05, length(y)), tolerance = 1e-7)
  expect_equal(rowMeans(pnorm((pp$obs$upper90 - m) / s)), rep(0.95, length(y)), tolerance = 1e-7)
})

test_that("a model that overstates the noise, or misplaces the mean, is caught", {
  set.seed(3)
  phi <- random_phi(2, 1)
  # phi: kappa, thetaS (3), alphaS (3), thetaB (2), alphaB (2), sigma2S, sigma2B, sigma2E, muB
  noisy <- replace(phi, 14, 50)  # sigma2E, where the standardised data have sd about 1
  pp <- ppc_field(fixed_fit(noisy), ndraws = 8)
  expect_lt(pp$outside[["50%"]], 0.2)
  expect_match(capture.output(print(pp)), "overstates the noise", all = FALSE)
  # The cause is named where it is seen: sigma2E (scaled space,
  # times the response's variance) against the observations' mean squared
  # residual
  fit <- fixed_fit(noisy)
  expect_equal(pp$noise$sigma2E, 50 * fit$model$scale$ysd^2)
  expect_equal(pp$noise$residual, mean((pp$y - pp$obs$mean)^2))
  expect_gt(pp$noise$ratio, 4)
  expect_snapshot(print(pp))
  shifted <- replace(phi, 15, 50)  # muB
  pp <- ppc_field(fixed_fit(shifted), ndraws = 8)
  expect_equal(pp$outside[["90%"]], 1)
  expect_match(capture.output(print(pp)), "misses part of", all = FALSE)
})

test_that("print, plot and argument checks", {
  set.seed(3)
  fit <- fixed_fit(random_phi(2, 1))
  set.seed(1)
  pp <- ppc_field(fit, ndraws = 4)
  expect_snapshot(print(pp))
  p <- plot(pp)
  expect_s3_class(p, "ggplot")
  expect_equal(levels(p$data$input), c("x1", "x2"))
  expect_equal(nrow(p$data), 2 * length(pp$y))
  expect_no_error(ggplot2::ggplot_build(p))
  pd <- plot(pp, type = "density", nOverlay = 2)
  expect_equal(nrow(pd$layers[[1]]$data), 2 * length(pp$y))
  expect_no_error(ggplot2::ggplot_build(pd))
  expect_snapshot(error = TRUE, ppc_field(fit, ndraws = 0))
  expect_snapshot(error = TRUE, plot(pp, type = "qq"))
})

test_that("pp_check() hands the replicates to bayesplot", {
  skip_if_not_installed("bayesplot")
  set.seed(3)
  fit <- fixed_fit(random_phi(2, 1))
  set.seed(1)
  p <- bayesplot::pp_check(fit, ndraws = 4)
  expect_s3_class(p, "ggplot")
  expect_s3_class(bayesplot::pp_check(fit, type = "intervals", ndraws = 4), "ggplot")
  expect_snapshot(error = TRUE, bayesplot::pp_check(fit, type = "nonsense"))
})
