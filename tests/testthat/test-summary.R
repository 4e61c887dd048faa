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

test_that("coef() gives posterior means, medians or modes of every column of Phi", {
  set.seed(5)
  fit <- calibrate(ballSim, ballField, nMCMC = 150, nBurn = 50, thinning = 2)
  # reference: column summaries of the draws in base R (and pmode())
  expect_equal(coef(fit), colMeans(fit$Phi))
  expect_equal(coef(fit, stat = "median"), apply(fit$Phi, 2, median))
  expect_equal(coef(fit, stat = "mode"), apply(fit$Phi, 2, pmode))
  expect_snapshot(error = TRUE, coef(fit, stat = "MAP"))
})

test_that("as.matrix(), fitted() and residuals() are the draws and the calibrated fits", {
  skip_if_not_slow()
  set.seed(5)
  fit <- calibrate(ballSim, ballField, nMCMC = 150, nBurn = 50, thinning = 2)
  expect_identical(as.matrix(fit), fit$Phi)
  expect_identical(dim(as.matrix(fit)), c(200L, 8L))  # 4 chains x (150 - 50) / 2 draws, 8 parameters (Matérn: no smoothness)
  # reference: predict() at the field inputs, as plot(type = "fits") shows
  map <- predict(fit, ballField[, "h"], method = "MAP")$pred
  expect_equal(fitted(fit, method = "MAP"), map)
  expect_equal(residuals(fit, method = "MAP"), unname(ballField[, "t"]) - map)
  bayes <- predict(fit, ballField[, "h"])$pred
  expect_equal(fitted(fit), bayes)
  expect_equal(resid(fit), unname(ballField[, "t"]) - bayes)
  # a calibrated model fits the ball data to about its noise (sd ~0.1 s)
  expect_lt(sd(residuals(fit)), 0.2)
  expect_length(fitted(fit), nrow(ballField))
  expect_snapshot(error = TRUE, {
    fitted(fit, type = "simulator")
    residuals(fit, method = "mode")
    as.matrix(fit, chain = 1)
  })
})

test_that("summary() and coef() refuse unknown arguments; print() of the summary warns", {
  set.seed(5)
  fit <- calibrate(ballSim, ballField, nMCMC = 150, nBurn = 50, thinning = 2)
  expect_snapshot(error = TRUE, summary(fit, digits = 2))
  expect_snapshot(error = TRUE, coef(fit, stats = "median"))
  expect_snapshot(x <- capture.output(print(summary(fit), right = FALSE)))
})

test_that("print() of the summary says which sigma2E is whose output", {
  # two outputs (helper-outputs.R), each its own measurement error
  po <- two_outputs(m = 16)
  set.seed(1)
  fit <- calibrate(po$sim, po$field, output = "out", discrepancy = "none", nMCMC = 200,
                   nBurn = 100, nChains = 1, showProgress = FALSE)
  out <- capture.output(print(summary(fit)))
  expect_equal(out[length(out)], "measurement error: sigma2E1 = conc, sigma2E2 = rate")
  expect_true(any(grepl("^sigma2E2 ", out)))
  # one group: no such line
  set.seed(5)
  fit1 <- calibrate(ballSim, ballField, nMCMC = 150, nBurn = 50, thinning = 2)
  expect_false(any(grepl("measurement error", capture.output(print(summary(fit1))))))
})
