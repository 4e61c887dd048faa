# The old names of emulator_cv() and emulator_vs_direct() (R/deprecated.R).

test_that("validate_emulator() and emulator_check() still work and name their replacements", {
  set.seed(1)
  fit <- suppressWarnings(calibrate(ballSim[1:30, ], ballField[1:10, ], nMCMC = 300, nBurn = 150,
                                    nChains = 1, showProgress = FALSE))
  expect_warning(old <- validate_emulator(fit, method = "MAP"), "emulator_cv")
  expect_identical(old, emulator_cv(fit, method = "MAP"))
  # the arguments reach the replacement (its own error for a non-fit)
  expect_warning(expect_error(emulator_check(1, fit), "`emulated` must be"), "emulator_vs_direct")
})
