test_that("summary() returns the estimates table, classed, extra columns kept", {
  set.seed(5)
  fit <- calibrate(ballSim, ballField, nMCMC = 150, nBurn = 50, thinning = 2)
  s <- summary(fit)
  expect_s3_class(s, "summary.fbc")
  expect_equal(as.data.frame(unclass(s)), fit$estimates, ignore_attr = TRUE)
  expect_identical(rownames(s), fit$vars)
  # a later column (e.g. R-hat) passes through and is printed
  fit$estimates$Rhat <- seq_len(nrow(fit$estimates)) / 100 + 1
  s <- summary(fit)
  expect_true("Rhat" %in% names(s))
  out <- capture.output(print(s))
  expect_match(out[1], "Rhat")
  expect_true(any(grepl("^kappa1 ", out)))
})

test_that("coef() gives posterior means or medians of every column of Phi", {
  set.seed(5)
  fit <- calibrate(ballSim, ballField, nMCMC = 150, nBurn = 50, thinning = 2)
  # reference: column summaries of the draws in base R
  expect_equal(coef(fit), colMeans(fit$Phi))
  expect_equal(coef(fit, stat = "median"), apply(fit$Phi, 2, median))
  expect_snapshot(error = TRUE, coef(fit, stat = "mode"))
})

test_that("summary() and coef() refuse unknown arguments; print() of the summary warns", {
  set.seed(5)
  fit <- calibrate(ballSim, ballField, nMCMC = 150, nBurn = 50, thinning = 2)
  expect_snapshot(error = TRUE, summary(fit, digits = 2))
  expect_snapshot(error = TRUE, coef(fit, stats = "median"))
  expect_snapshot(x <- capture.output(print(summary(fit), right = FALSE)))
})
