# The confounding check (R/confounding.R): fires on the ball data under the
# KOH bias, where the 95% interval of g covers about 90% of the design's
# range [6.04, 13.96] and sigma2B is several times sigma2E; silent under the
# S-GaSP (interval about half the range) and without a discrepancy.

test_that("the confounding check fires under the bias GP and is silent otherwise on the ball data", {
  skip_if_not_slow()
  set.seed(4)
  args <- list(ballSim, ballField, nMCMC = 700, nBurn = 300, nChains = 2, kernelS = "matern52",
               kernelB = "matern52")
  gp <- do.call(calibrate, args)
  b <- FBC:::confounded_kappa(gp)
  expect_identical(nrow(b), 1L)
  expect_gt(b$cover, 0.8)
  expect_gt(b$biasRatio, 1)
  # the numbers it reports are the fit's own
  ci <- quantile(gp$Phi[, "kappa1"], c(0.025, 0.975), names = FALSE)
  expect_equal(c(b$lower, b$upper), ci)
  expect_equal(b$cover, (min(ci[2], 13.96) - max(ci[1], 6.044)) / (13.96 - 6.044), tolerance = 1e-3)
  msg <- grep("barely informed", convergence_messages(gp), value = TRUE)
  expect_length(msg, 1L)
  expect_match(msg, "discrepancy = \"sgasp\"", fixed = TRUE)
  # the other models of the table
  other <- setdiff(FBC:::discrepancy_models$name, "gp")
  expect_match(msg, sprintf("loo::loo_compare(%s)", paste(c("loo::loo(fit)", sprintf("loo::loo(fit_%s)", other)),
                                                        collapse = ", ")), fixed = TRUE)
  sg <- suppressWarnings(do.call(calibrate, c(args, discrepancy = "sgasp")))
  expect_null(FBC:::confounded_kappa(sg))
  none <- suppressWarnings(do.call(calibrate, c(args, discrepancy = "none")))
  expect_null(FBC:::confounded_kappa(none))
  expect_false(any(grepl("barely informed", convergence_messages(none))))
})

test_that("a well-informed calibration parameter is not flagged, however large the bias", {
  # the same gp fit with g's draws squeezed around 8 (as if the data pinned
  # it): the bias still dominates, but the interval is narrow
  set.seed(4)
  gp <- calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, nChains = 2)
  narrow <- gp
  narrow$Phi[, "kappa1"] <- 8 + (gp$Phi[, "kappa1"] - mean(gp$Phi[, "kappa1"])) / 20
  expect_null(FBC:::confounded_kappa(narrow))
  # and a bias smaller than the noise is not "carrying the signal"
  small <- gp
  small$Phi[, "sigma2B"] <- small$Phi[, "sigma2E"] / 2
  expect_null(FBC:::confounded_kappa(small))
})

test_that("with several measurement-error groups the check compares sigma2B with each group's", {
  # with `source =` the noise variances are sigma2E1, sigma2E2 and
  # the check looked for a column sigma2E only. The ball data split into two
  # data sets (alternate rows): the same confounding as the one-group fit
  set.seed(4)
  field <- data.frame(ballField, lab = rep(c("A", "B"), length.out = nrow(ballField)))
  gp <- calibrate(ballSim, field, source = "lab", nMCMC = 700, nBurn = 300, nChains = 2,
                  kernelS = "matern52", kernelB = "matern52")
  b <- FBC:::confounded_kappa(gp)
  expect_identical(nrow(b), 1L)
  # the ratio reported is sigma2B's median over the largest of the groups'
  ratios <- median(gp$Phi[, "sigma2B"]) / apply(gp$Phi[, c("sigma2E1", "sigma2E2")], 2, median)
  expect_equal(b$biasRatio, max(ratios))
  g <- which.max(ratios)
  expect_identical(b$noise, sprintf("sigma2E%d (%s)", g, c("A", "B")[g]))
  msg <- grep("barely informed", convergence_messages(gp), value = TRUE)
  expect_length(msg, 1L)
  expect_match(msg, sprintf("times the measurement error's sigma2E%d (%s)", g, c("A", "B")[g]),
               fixed = TRUE)
  # worded as what the data cannot separate, not as a bias found
  expect_match(msg, "the data cannot separate a change of g (kappa1) from a bias", fixed = TRUE)
  expect_no_match(msg, "carries the signal")
})
