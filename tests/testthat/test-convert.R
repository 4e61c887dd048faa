test_that("as_draws_df() keeps every draw, chain and the log posterior", {
  fit <- small_fit(nChains = 2)
  d <- posterior::as_draws_df(fit)
  expect_s3_class(d, "draws_df")
  expect_equal(posterior::nchains(d), 2)
  expect_equal(posterior::niterations(d), 100)
  expect_equal(posterior::variables(d), c(fit$vars, "lp__"))
  expect_equal(unname(as.matrix(as.data.frame(d)[, fit$vars])), unname(fit$Phi))
  expect_equal(d$lp__, fit$logPost)
  expect_equal(d$.chain, fit$chain)
  # posterior's own diagnostics on the converted draws agree with ours
  s <- posterior::summarise_draws(d, "rhat", "ess_bulk")
  expect_equal(s$rhat[1:length(fit$vars)], fit$estimates$rhat, ignore_attr = TRUE)
  expect_s3_class(posterior::as_draws(fit), "draws_df")
})

test_that("as.mcmc.list() gives one mcmc per chain with the sweep numbers", {
  skip_if_not_installed("coda")
  fit <- small_fit(nChains = 2)
  m <- coda::as.mcmc.list(fit)
  expect_s3_class(m, "mcmc.list")
  expect_equal(coda::nchain(m), 2)
  expect_equal(coda::niter(m), 100)
  expect_equal(coda::varnames(m), fit$vars)
  expect_equal(unname(as.matrix(m[[2]])), unname(fit$Phi[fit$chain == 2, ]))
  # burn-in 100, thinning 2: the first kept sweep is 102, the last 300
  expect_equal(coda::mcpar(m[[1]]), c(102, 300, 2))
})

test_that("the conversions warn about arguments they do not use", {
  fit <- small_fit(nChains = 2)
  expect_snapshot(d <- posterior::as_draws_df(fit, chains = 1))
  expect_equal(posterior::nchains(d), 2)  # the argument changed nothing
  skip_if_not_installed("coda")
  expect_snapshot(m <- coda::as.mcmc.list(fit, thin = 5))
})
