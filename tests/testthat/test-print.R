test_that("print() shows the header and the table and returns the fit invisibly", {
  set.seed(5)
  fit <- calibrate(ballSim, ballField, nMCMC = 150, nBurn = 50, thinning = 2, nChains = 1)
  out <- capture.output(res <- withVisible(print(fit)))
  expect_false(res$visible)
  expect_identical(res$value, fit)
  expect_match(out[2], "n = 63 field, m = 100 simulator runs; p = 1, q = 1", fixed = TRUE)
  expect_match(out[3], "kappa1 = g", fixed = TRUE)
  expect_match(out[4], "150 iterations, 50 burn-in, thinning 2 -> 50 draws", fixed = TRUE)
  acc <- range(fit$acceptance, na.rm = TRUE)
  expect_match(out[5], sprintf("acceptance: %.2f to %.2f", acc[1], acc[2]), fixed = TRUE)
  expect_true(all(vapply(fit$vars, function(v) any(startsWith(out, paste0(v, " "))), logical(1))))
})

test_that("print() copes with extra estimate columns and several chains", {
  set.seed(5)
  fit <- calibrate(ballSim, ballField, nMCMC = 150, nBurn = 50, thinning = 2)
  fit$estimates$nChains <- 2L
  fit$chain <- rep(1:2, length.out = nrow(fit$Phi))
  out <- capture.output(print(fit))
  expect_match(out[4], "from 2 chains", fixed = TRUE)
  expect_true(any(grepl("nChains", out)))
})
