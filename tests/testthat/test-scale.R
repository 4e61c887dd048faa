# Scaling (R/scale.R): the checks on the simulator response.

test_that("a nearly constant simulator response is said, a varying one is not", {
  # sd 5.9e-14 of the level: standardising magnifies the last digits
  ys <- 1e9 + (1:20) * 1e-5
  expect_warning(spread <- FBC:::warn_nearly_constant(ys), "nearly constant")
  expect_equal(spread, stats::sd(ys) / max(abs(ys)))
  expect_no_warning(FBC:::warn_nearly_constant(ballSim[, "t"]))
  s <- ballSim
  s[, "t"] <- 1e9 + s[, "t"] * 1e-3
  expect_snapshot(invisible(FBC:::fbc_scale(s, 1L)))
})

test_that("the scaling maps the design to [0, 1] and standardises by the simulator", {
  sc <- FBC:::fbc_scale(ballSim, 1L)
  d <- FBC:::scale_data(ballSim, ballField, sc)
  expect_equal(apply(d$Xs, 2, range), matrix(c(0, 1), 2, 2))
  expect_equal(c(mean(d$ys), sd(d$ys)), c(0, 1))
  # the field uses the simulator's scaling (plain-R arithmetic)
  expect_equal(d$yf, (ballField[, "t"] - mean(ballSim[, "t"])) / sd(ballSim[, "t"]))
})
