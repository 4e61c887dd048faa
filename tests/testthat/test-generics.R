# The rstantools generics (R/generics.R): posterior_predict(),
# posterior_epred(), log_lik(), nobs(), prior_summary(), against predict(),
# loo() and the model's priors, and through tidybayes where it is installed.

# a fit whose every draw is one fixed phi (helper-predict.R), repeated
# `n` times: each draw's predictive distribution is then predict()'s MAP one
repeated_fit <- function(n, seed = 12) {
  set.seed(seed)
  fit <- fixed_fit(random_phi(2, 1))
  fit_with_draws(fit, fit$Phi[rep(1L, n), , drop = FALSE])
}

test_that("posterior_epred() is predict(type = \"mean\")'s draws, draw by draw", {
  set.seed(3)
  fit <- calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, nChains = 2,
                   converge = FALSE, showProgress = FALSE)
  new <- c(0.3, 1.1, 2.2)
  mu <- posterior_epred(fit, newdata = new)
  pr <- predict(fit, new, type = "mean", draws = TRUE, ndraws = NULL)
  expect_identical(dim(mu), c(nrow(fit$Phi), 3L))
  expect_equal(mu, t(pr$draws), tolerance = 1e-12, ignore_attr = TRUE)
  expect_equal(colMeans(mu), pr$pred, tolerance = 1e-12)
  # evenly spaced draws, as predict()'s
  mu10 <- posterior_epred(fit, newdata = new, ndraws = 10)
  expect_identical(nrow(mu10), 10L)
  expect_equal(mu10, mu[attr(mu10, "draw_rows"), ], ignore_attr = TRUE, tolerance = 1e-12)
  # without newdata: the field inputs
  muF <- posterior_epred(fit, ndraws = 5)
  expect_identical(dim(muF), c(5L, nrow(ballField)))
  expect_equal(muF, posterior_epred(fit, newdata = ballField[, "h"], ndraws = 5),
               tolerance = 1e-10, ignore_attr = TRUE)
})

test_that("posterior_predict() draws each point from its Gaussian predictive", {
  fit <- repeated_fit(4000)
  X <- data.frame(x1 = c(1, 4, 8), x2 = c(-4.8, -4.5, -4.2))
  map <- suppressWarnings(predict(fit, X, method = "MAP", type = "field"))
  set.seed(5)
  yrep <- suppressWarnings(posterior_predict(fit, newdata = X))
  expect_identical(dim(yrep), c(4000L, 3L))
  # mean within 4 Monte Carlo sd, sd within 10% (its own sd is about 1.1%)
  expect_true(all(abs(colMeans(yrep) - map$pred) < 4 * map$se / sqrt(4000)))
  expect_equal(apply(yrep, 2, stats::sd), map$se, tolerance = 0.1)
  # points independent given the draw (documented)
  r <- stats::cor(yrep)[upper.tri(diag(3))]
  expect_true(all(abs(r) < 4 / sqrt(4000)))
  # the expected value is the field mean without the noise
  mu <- suppressWarnings(posterior_epred(fit, newdata = X, ndraws = 1))
  expect_equal(drop(mu), map$pred, tolerance = 1e-10, ignore_attr = TRUE)
  # set.seed() reproduces the draws
  set.seed(5)
  expect_identical(suppressWarnings(posterior_predict(fit, newdata = X)), yrep)
})

test_that("log_lik() gives the leave-one-out densities loo() uses", {
  skip_if_not_installed("loo")
  set.seed(8)
  fit <- fixed_fit(random_phi(2, 1))
  ll <- log_lik(fit)
  expect_identical(dim(ll), c(nrow(fit$Phi), length(fit$model$data$yf)))
  # every draw is phi: loo()'s pointwise elpd is each draw's log density
  res <- suppressWarnings(loo::loo(fit, unit = "observation"))
  for (i in seq_len(nrow(ll))) {
    expect_equal(ll[i, ], res$pointwise[, "elpd_loo"], tolerance = 1e-8, ignore_attr = TRUE)
  }
  expect_identical(ncol(log_lik(fit, unit = "input")), length(unique(fit$model$data$Xf[, 1])))
  expect_error(log_lik(fit, unit = "row"), class = "rlang_error")
  expect_error(posterior_predict(fit, ndraws = 0), "ndraws")
})

test_that("nobs() counts the field rows and prior_summary() lists every parameter's prior", {
  set.seed(9)
  phi <- random_phi(2, 1)
  fit <- fixed_fit(phi)
  expect_identical(nobs(fit), 7L)
  ps <- prior_summary(fit)
  expect_identical(ps$parameter, fit$model$spec$vars)
  expect_true(all(ps$fixed))
  th <- unpack_phi(phi, 2, 1)
  expect_equal(ps$init[ps$class == "thetaS"], th$thetaS)
  expect_equal(ps$init[ps$class == "sigma2E"], th$sigma2E)
  set.seed(1)
  ball <- calibrate(ballSim, ballField, nMCMC = 200, nBurn = 100, nChains = 2,
                    converge = FALSE, showProgress = FALSE)
  expect_identical(nobs(ball), nrow(ballField))
  ps <- prior_summary(ball)
  expect_identical(ps$family[ps$parameter == "kappa1"], "beta")
  expect_identical(ps$p1[ps$parameter == "kappa1"], 1.1)
  expect_match(ps$prior[ps$parameter == "kappa1"], "^beta\\(")
  expect_error(nobs(ball, 1), "not used")
})

test_that("tidybayes' add_predicted_draws() and add_epred_draws() work on a fit", {
  skip_if_not_installed("tidybayes")
  set.seed(4)
  fit <- calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, nChains = 2,
                   converge = FALSE, showProgress = FALSE)
  new <- data.frame(h = c(2.2, 2.4))
  pd <- tidybayes::add_predicted_draws(new, fit, ndraws = 10)
  expect_identical(nrow(pd), 20L)
  expect_true(all(c(".row", ".draw", ".prediction") %in% names(pd)))
  expect_true(all(is.finite(pd$.prediction)))
  ed <- tidybayes::add_epred_draws(new, fit, ndraws = 10)
  expect_identical(nrow(ed), 20L)
  mu <- posterior_epred(fit, newdata = new, ndraws = 10)
  expect_equal(sort(ed$.epred), sort(c(mu)), tolerance = 1e-10)
})
