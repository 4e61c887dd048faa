# Columns matched by name (R/columns.R), and what calibrate() and predict()
# say about the data: inputs outside the designs, duplicated runs.

# posterior's "ESS has been capped" is expected on these very short runs
short_fit <- function(sim = ballSim, field = ballField, seed = 1) {
  set.seed(seed)
  withCallingHandlers(
    calibrate(sim, field, nMCMC = 120, nBurn = 60, thinning = 2, nChains = 1),
    warning = function(w) {
      if (grepl("ESS has been capped", conditionMessage(w))) invokeRestart("muffleWarning")
    })
}

test_that("field columns in another order calibrate exactly as in the documented order", {
  a <- short_fit()
  # (h, t) instead of (t, h), as a matrix and as a data frame
  b <- short_fit(field = ballField[, c("h", "t")])
  d <- short_fit(field = as.data.frame(ballField[, c("h", "t")]))
  expect_identical(b$Phi, a$Phi)
  expect_identical(d$Phi, a$Phi)
  expect_identical(b$data, a$data)
  # sim with the calibration input before the experimental one: same model
  e <- short_fit(sim = ballSim[, c("t", "g", "h")], field = ballField[, c("h", "t")])
  expect_identical(e$Phi, a$Phi)
  expect_identical(e$scale$names, list(response = "t", inputs = "h", calibration = "g"))
  expect_true(e$scale$named)
})

test_that("the default ball fit gives the same g posterior from a (h, t) field", {
  skip_on_cran()
  set.seed(2024)
  a <- calibrate(ballSim, ballField, nMCMC = 1000, nBurn = 400)
  set.seed(2024)
  b <- calibrate(ballSim, ballField[, c("h", "t")], nMCMC = 1000, nBurn = 400)
  expect_identical(b$Phi[, "kappa1"], a$Phi[, "kappa1"])
  # and g is where free fall puts it, not at the 10.2 of h read as the response
  expect_gt(mean(a$Phi[, "kappa1"]), 8.5)
})

test_that("unnamed matrices keep the positional contract", {
  a <- short_fit()
  b <- short_fit(sim = unname(ballSim), field = unname(ballField))
  expect_identical(unname(b$Phi), unname(a$Phi))
  expect_false(b$scale$named)
  expect_identical(b$scale$names, list(response = "y", inputs = "x1", calibration = "t1"))
  # one side named, the other not: by position
  d <- short_fit(field = unname(ballField))
  expect_identical(d$Phi, a$Phi)
  expect_false(d$scale$named)
})

test_that("names that disagree, are missing or repeated are refused with the names", {
  expect_snapshot(error = TRUE, {
    calibrate(ballSim, data.frame(time = 1:3, h = 1:3))
    calibrate(ballSim, data.frame(t = 1:3, height = 1:3))
    calibrate(ballSim, data.frame(h = 1:3, g = 1:3))
    calibrate(ballSim[, c("t", "h", "h")], ballField)
  })
})

test_that("a sim without a calibration input says so", {
  expect_snapshot(error = TRUE, {
    calibrate(ballSim[, c("t", "h")], ballField)
    calibrate(unname(ballSim[, 1:2]), ballField)
    calibrate(ballSim, cbind(t = ballField[, 1], h = ballField[, 2], g = 1))
  })
})

test_that("predict() matches named newdata columns by name", {
  set.seed(3)
  fit <- fixed_fit(random_phi(2, 1))  # columns y, x1, x2, t
  X <- cbind(x1 = c(1, 5, 9), x2 = c(-4.5, -4.9, -4.1))
  ref <- predict(fit, unname(X), draws = TRUE)
  shuffled <- data.frame(x2 = X[, 2], y = 0, x1 = X[, 1])  # other order, an extra column
  expect_identical(predict(fit, shuffled, draws = TRUE), ref)
  expect_identical(predict(fit, X[, 2:1], draws = TRUE), ref)
  # a non-numeric extra column is not needed and not looked at
  expect_identical(predict(fit, data.frame(shuffled, site = "a"))$pred, ref$pred)
  # taken by position, the swapped columns are far outside the designs (and
  # the answer differs): the swap matters
  expect_warning(swapped <- predict(fit, unname(X[, 2:1])), class = "fbc_extrapolation")
  expect_false(isTRUE(all.equal(swapped$pred, ref$pred)))
  expect_snapshot(error = TRUE, {
    predict(fit, data.frame(x1 = 1, z = 2))
    predict(fit, as.data.frame(unname(X)))
  })
})

test_that("field inputs beyond the simulator design warn, naming the input and both ranges", {
  f <- ballField
  f[1:2, "h"] <- c(-1, 9)
  expect_snapshot(x <- short_fit(field = f))
  # the ball data's own 1% overhang is not worth a warning
  expect_no_warning(short_fit())
})

test_that("predict() far outside both designs warns, naming the input and the range", {
  fit <- short_fit()
  expect_snapshot(p <- predict(fit, c(2, 12, 20)))
  expect_no_warning(predict(fit, c(0.1, 4.3)))
})

test_that("duplicated simulator runs get a message", {
  s2 <- rbind(ballSim, ballSim[c(4, 9), ])
  expect_snapshot(x <- short_fit(sim = s2))
  s3 <- rbind(ballSim, ballSim[4, ] + c(0.01, 0, 0))
  expect_snapshot(x <- short_fit(sim = s3))
})

test_that("nothing the user passed in is modified", {
  sim <- as.data.frame(ballSim[, c("g", "h", "t")])[, c(3, 2, 1)]
  field <- ballField[, c("h", "t")]
  hyp <- set_hyperPriors()
  sim0 <- sim; field0 <- field; hyp0 <- hyp
  fit <- short_fit(sim, field)
  fit0 <- fit
  nd <- data.frame(h = c(1, 2), t = 0)
  nd0 <- nd
  predict(fit, nd)
  plot(fit)
  summary(fit)
  expect_identical(sim, sim0)
  expect_identical(field, field0)
  expect_identical(hyp, hyp0)
  expect_identical(nd, nd0)
  expect_identical(fit, fit0)
})
