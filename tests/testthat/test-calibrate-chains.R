test_that("several chains are stacked in Phi with a chain vector", {
  fit <- small_fit(nChains = 3)
  expect_equal(nrow(fit$Phi), 3 * 100)
  expect_equal(fit$chain, rep(1:3, each = 100))
  expect_length(fit$logPost, 300)
  expect_length(fit$logLik, 300)
  expect_equal(fit$settings$nChains, 3)
  expect_length(fit$state$chains, 3)
  expect_false(fit$state$interrupted)
  # the chains start from different places, so their first draws differ
  first <- fit$Phi[match(1:3, fit$chain), "sigma2S"]
  expect_equal(length(unique(first)), 3)
})

test_that("estimates carry posterior's rank-normalised split R-hat and bulk ESS", {
  fit <- small_fit(nChains = 3)
  expect_true(all(c("rhat", "ess") %in% names(fit$estimates)))
  m <- matrix(fit$Phi[, "kappa1"], ncol = 3) # iterations x chains
  expect_equal(fit$estimates["kappa1", "rhat"], posterior::rhat(m))
  expect_equal(fit$estimates["kappa1", "ess"], posterior::ess_bulk(m))
})

test_that("set.seed() reproduces a run, and the plan does not matter", {
  skip_if_not_slow()
  a <- small_fit(nChains = 2, seed = 7)
  b <- small_fit(nChains = 2, seed = 7)
  expect_identical(a$Phi, b$Phi)
  c <- small_fit(nChains = 2, seed = 8)
  expect_false(identical(a$Phi, c$Phi))
  skip_if_not_installed("future")
  old <- future::plan(future::multisession, workers = 2)
  on.exit(future::plan(old), add = TRUE)
  d <- small_fit(nChains = 2, seed = 7)
  expect_identical(a$Phi, d$Phi)
})

test_that("dispersed starts: chain 1 at the inits, the others inside the priors' central 80%", {
  fit <- small_fit(nChains = 1)
  spec <- fit$model$spec
  set.seed(3)
  inits <- dispersed_inits(40, fit$model$data, spec)
  expect_equal(inits[[1]], spec$init)
  x <- do.call(rbind, inits[-1])
  # kappa: Beta(1.1, 1.1) on the sampler's [0, 1] scale
  expect_true(all(x[, 1] >= qbeta(0.1, 1.1, 1.1) & x[, 1] <= qbeta(0.9, 1.1, 1.1)))
  # sigma2E: its sd half-Cauchy(1), so sigma2E's u-quantile is qt((1 + u) / 2, 1)^2
  j <- match("sigma2E", spec$vars)
  expect_true(all(x[, j] >= qt(0.55, 1)^2 & x[, j] <= qt(0.95, 1)^2))
  # thetaS1: Gamma(1.1, rate 0.1)
  j <- match("thetaS1", spec$vars)
  expect_true(all(x[, j] >= qgamma(0.1, 1.1, 0.1) & x[, j] <= qgamma(0.9, 1.1, 0.1)))
  expect_gt(sd(x[, 1]), 0.1)
  # fixed parameters stay at their value
  hyp <- set_hyperPriors(muBDist = "fixed", muBInit = 0.3)
  fit2 <- small_fit(nChains = 2, hypers = hyp)
  expect_true(all(fit2$Phi[, "muB"] == 0.3))
})

test_that("an interrupted run keeps its draws, skips the chains not started, and can be continued", {
  old <- options(FBC.sampler = fake_interrupt_sampler(stopAt = 200, calls = 1))
  on.exit(options(old), add = TRUE)
  set.seed(1)
  expect_warning(
    fit <- calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, thinning = 2, nChains = 3),
    "Interrupted"
  )
  options(old)
  expect_s3_class(fit, "fbc")
  expect_true(fit$state$interrupted)
  expect_equal(nrow(fit$Phi), 50) # (200 - 100) / 2 draws from chain 1 only
  expect_equal(unique(fit$chain), 1L)
  expect_true(all(is.finite(fit$Phi)))
  expect_true(any(grepl("interrupted", convergence_messages(fit))))
  expect_true(any(capture.output(print(fit)) == "  interrupted: chain 1 after 200 iterations"))
  fit2 <- update(fit, nMCMC = 100)
  expect_equal(nrow(fit2$Phi), 100)
  expect_equal(fit2$Phi[1:50, ], fit$Phi)
  expect_false(fit2$state$interrupted)
})

test_that("an interrupt before any draw is an error", {
  old <- options(FBC.sampler = fake_interrupt_sampler(stopAt = 50, calls = 1))
  on.exit(options(old), add = TRUE)
  set.seed(1)
  expect_snapshot(error = TRUE,
    calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, thinning = 2, nChains = 1)
  )
})

test_that("nChains is checked", {
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, nChains = 0))
})

test_that("the progress bar labels waiting chains and says when its ETA is a stretch's", {
  expect_identical(FBC:::progress_status(c(TRUE, TRUE, FALSE), c(FALSE, TRUE, TRUE), c(0.31, NA, NA)),
                   "chains: 0.31 warm-up waiting")
  expect_match(FBC:::progress_format(TRUE), "ETA (this stretch, to the next check)", fixed = TRUE)
  expect_false(grepl("stretch", FBC:::progress_format(FALSE)))
})
