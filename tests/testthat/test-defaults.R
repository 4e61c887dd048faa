# Defaults chosen from the session (R/defaults.R).

test_that("showProgress = NULL shows progress in an interactive session, not in scripts or knitr", {
  expect_true(FBC:::default_progress(NULL, interactive = TRUE, knitting = FALSE))
  expect_false(FBC:::default_progress(NULL, interactive = FALSE, knitting = FALSE))
  expect_false(FBC:::default_progress(NULL, interactive = TRUE, knitting = TRUE))
  # given: as given, whatever the session
  expect_true(FBC:::default_progress(TRUE, interactive = FALSE, knitting = TRUE))
  expect_false(FBC:::default_progress(FALSE, interactive = TRUE, knitting = FALSE))
  # knitr's option decides when not given (tests run non-interactively)
  old <- options(knitr.in.progress = TRUE)
  on.exit(options(old), add = TRUE)
  expect_false(FBC:::default_progress(NULL, interactive = TRUE))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, showProgress = "yes"))
})
