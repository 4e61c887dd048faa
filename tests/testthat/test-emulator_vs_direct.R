# emulator_vs_direct(): kappa's posterior from an emulator of runs against the
# one from the simulator function itself (R/emulator_vs_direct.R).

test_that("an emulator of a dense design of f gives the function's posterior; a shift is measured", {
  f <- function(x, kappa) 5 * exp(-kappa[["u"]] * x$t)
  field <- as.data.frame(kineticField)
  # a dense product design of the same f: the 10 field times x 12 rates
  g <- expand.grid(t = unique(field$t), u = seq(0.5, 3, length.out = 12))
  runs <- data.frame(y = 5 * exp(-g$u * g$t), t = g$t, u = g$u)
  set.seed(11)
  direct <- calibrate(f, field, kappaDist = "uniform", kappaP1 = c(u = 0.5), kappaP2 = c(u = 3),
                      discrepancy = "none", nMCMC = 1500, nBurn = 300, nChains = 2)
  set.seed(12)
  emulated <- calibrate(runs, field, kappaDist = "uniform", kappaP1 = 0.5, kappaP2 = 3,
                        discrepancy = "none", nMCMC = 1500, nBurn = 300, nChains = 2)
  chk <- emulator_vs_direct(emulated, direct)
  expect_s3_class(chk, "fbc_emulator_vs_direct")
  # the same posterior up to Monte Carlo error (bulk ESS of kappa > 400 in
  # each fit: quantiles within ~0.1 sd) and the emulator's error, which a
  # 120-run grid of a smooth f keeps far below it
  expect_lt(chk$distance, 0.2)
  expect_lt(abs(chk$shift), 0.2)
  expect_lt(abs(log(chk$widthRatio)), log(1.25))
  expect_false(chk$moved)
  # a posterior moved by one sd (the function's draws' quantiles + sd): a
  # Wasserstein-1 distance and a shift of 1
  s <- stats::sd(direct$Phi[, 1])
  moved <- emulated
  moved$Phi[, 1] <- stats::quantile(direct$Phi[, 1], stats::ppoints(nrow(moved$Phi)), names = FALSE) + s
  chk2 <- emulator_vs_direct(moved, direct)
  expect_equal(chk2$distance, 1, tolerance = 0.02)
  expect_equal(chk2$shift, 1, tolerance = 0.02)
  expect_true(chk2$moved)
  expect_output(print(chk2), "moves u by more than 0.2 sd")
  expect_s3_class(plot(chk), "ggplot")
  expect_error(emulator_vs_direct(direct, emulated), "must be a fit of runs")
})
