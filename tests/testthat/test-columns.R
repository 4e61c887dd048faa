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

# short_fit() with other kappa priors
short_fit_prior <- function(..., seed = 1) {
  set.seed(seed)
  withCallingHandlers(
    calibrate(ballSim, ballField, nMCMC = 120, nBurn = 60, thinning = 2, nChains = 1, ...),
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
  expect_identical(b$model$data, a$model$data)
  # sim with the calibration input first and the response last: same model
  e <- short_fit(sim = ballSim[, c("g", "h", "t")])
  expect_identical(e$Phi, a$Phi)
  expect_identical(e$model$scale$names, list(response = "t", inputs = "h", calibration = "g"))
  expect_true(e$model$scale$named)
  expect_output(print(e), "response: t; experimental input: h", fixed = TRUE)
})

test_that("a sim stored as inputs then output calibrates as in the documented order", {
  # p = 2: sim (x1, x2, t, y), field (y, x1, x2): y is sim's last column and
  # field's first, x1 (sim's first) is not field's last
  d <- random_koh_data(n = 7, m = 12, p = 2, q = 1, seed = 11)
  sim <- cbind(y = d$ys, x1 = d$Xs[, 1], x2 = d$Xs[, 2], t = d$Xs[, 3])
  field <- cbind(y = d$yf, x1 = d$Xf[, 1], x2 = d$Xf[, 2])
  fit2 <- function(s, f) suppressWarnings(short_fit(s, f), classes = "fbc_extrapolation")
  a <- fit2(sim, field)
  b <- fit2(sim[, c("x1", "x2", "t", "y")], field)
  expect_identical(b$Phi, a$Phi)
  # inputs in another order (x2 first: thetaS1 is x2's), as a data frame
  f2 <- field[, c("y", "x2", "x1")]
  expect_identical(fit2(as.data.frame(sim[, c("x2", "x1", "t", "y")]), f2)$Phi,
                   fit2(sim[, c("y", "x2", "x1", "t")], f2)$Phi)
  expect_identical(b$model$scale$names, list(response = "y", inputs = c("x1", "x2"), calibration = "t"))
})

test_that("a response the names cannot identify is refused, naming both candidates", {
  # (h, g, t) with (t, h) and its mirror (t, g, h) with (h, t): either of
  # the shared columns could be the response
  expect_snapshot(error = TRUE, {
    calibrate(ballSim[, c("h", "g", "t")], ballField)
    calibrate(ballSim[, c("t", "g", "h")], ballField[, c("h", "t")])
    calibrate(ballSim[, c("g", "h", "t")], ballField[, c("h", "t")])
    calibrate(cbind(ballSim, x = 1:100)[, c("t", "h", "x", "g")], data.frame(h = 1:3, x = 1:3))
  })
})

test_that("the default ball fit gives the same g posterior from a (h, t) field", {
  skip_if_not_slow()
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
  expect_false(b$model$scale$named)
  expect_identical(b$model$scale$names, list(response = "y", inputs = "x1", calibration = "t1"))
  # one side named, the other not: by position
  d <- short_fit(field = unname(ballField))
  expect_identical(d$Phi, a$Phi)
  expect_false(d$model$scale$named)
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
  # responses that differ: simNoise = "none" keeps the runs as they are
  # (the default models the simulator's noise: test-sim_noise.R)
  s3 <- rbind(ballSim, ballSim[4, ] + c(0.01, 0, 0))
  expect_snapshot(x <- calibrate(s3, ballField, simNoise = "none", fit = FALSE))
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

test_that("newdata columns named like a calibration input are refused, saying why", {
  fit <- short_fit()
  expect_snapshot(error = TRUE, {
    predict(fit, data.frame(h = c(1, 2), g = 9.8), type = "simulator")
    predict(fit, ballSim)
  })
  # without the column, the same points predict as before
  expect_identical(predict(fit, data.frame(h = c(1, 2), t = 0)), predict(fit, c(1, 2)))
})

# the design range of g in ballSim, and its 5% margin
g_lo <- min(ballSim[, "g"])
g_hi <- max(ballSim[, "g"])
g_margin <- 0.05 * (g_hi - g_lo)

test_that("a kappa prior reaching beyond the simulator design warns, saying where", {
  expect_snapshot(x <- short_fit_prior(kappaDist = "gaussian", kappaP1 = 9.8, kappaP2 = 3))
  expect_snapshot(x <- short_fit_prior(kappaDist = "uniform", kappaP1 = 5, kappaP2 = 15))
  # the 15% of the warning: the Gaussian's mass beyond the widened range
  beyond <- pnorm(g_lo - g_margin, 9.8, 3) + pnorm(g_hi + g_margin, 9.8, 3, lower.tail = FALSE)
  expect_equal(round(100 * beyond), 15)
  # within the design, or beyond it by a negligible share of the mass: silent
  expect_no_warning(short_fit_prior(kappaDist = "uniform", kappaP1 = 7, kappaP2 = 13))
  expect_no_warning(short_fit_prior(kappaDist = "gaussian", kappaP1 = 10, kappaP2 = 1))
  expect_no_warning(short_fit_prior(kappaDist = "fixed", kappaInit = 9.8))
})

test_that("a kappa prior with no support on the simulator design is refused", {
  expect_snapshot(error = TRUE, {
    calibrate(ballSim, ballField, kappaDist = "uniform", kappaP1 = 15, kappaP2 = 20)
    calibrate(ballSim, ballField, kappaDist = "gaussian", kappaP1 = 100, kappaP2 = 1)
  })
  # a uniform touching the design at its maximum has no mass on it either
  expect_error(calibrate(ballSim, ballField, kappaDist = "uniform", kappaP1 = g_hi, kappaP2 = 20),
               "no support")
})

test_that("a fixed kappa beyond the design is said at the call, in print() and by predict()", {
  expect_snapshot(fit <- short_fit_prior(kappaDist = "fixed", kappaInit = 16))
  msgs <- convergence_messages(fit)
  expect_identical(grep("beyond the simulator design", msgs, value = TRUE), sprintf(
    "g (kappa1) is fixed at 16, beyond the simulator design's %s to %s: the fit and its predictions rest on the emulator's extrapolation. Fix it within the design or extend the simulator design.",
    signif(g_lo, 4), signif(g_hi, 4)))
  expect_output(print(fit), "g (kappa1) is fixed at 16", fixed = TRUE)
  expect_snapshot(p <- predict(fit, c(1, 2), method = "MAP"))
})

test_that("the posterior mass beyond the design is counted from the draws", {
  set.seed(4)
  fit <- suppressWarnings(
    calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, nChains = 2, kappaDist = "gaussian",
              kappaP1 = 9.8, kappaP2 = 3),
    classes = "fbc_extrapolation")
  g <- fit$Phi[, "kappa1"]
  far <- g < g_lo - g_margin | g > g_hi + g_margin
  expect_gt(mean(far), 0.01)  # this run does put mass beyond
  msg <- grep("beyond the simulator design", convergence_messages(fit), value = TRUE)
  expect_identical(msg, sprintf(
    "%.0f%% of the draws of g (kappa1) lie beyond the simulator design's %s to %s (the draws range from %s to %s): there the posterior rests on the emulator's extrapolation. Narrow the prior to the design's range or extend the simulator design.",
    100 * mean(far), signif(g_lo, 4), signif(g_hi, 4), signif(min(g), 4), signif(max(g), 4)))
  # predict() counts the draws it uses: all of them here
  w <- tryCatch(predict(fit, 1, ndraws = NULL), warning = function(w) w)
  expect_s3_class(w, "fbc_extrapolation")
  expect_match(conditionMessage(w), sprintf("%.0f%% of the draws used", 100 * mean(far)), fixed = TRUE)
  # the default beta prior stays within the design: nothing to say
  a <- short_fit()
  expect_length(grep("beyond the simulator design", convergence_messages(a)), 0L)
  expect_no_warning(predict(a, 1))
})

test_that("runs closer than the nugget can carry are reported, distinct designs are not", {
  # rows 1 and 2 differ by 1e-9 in h (range ~ 3.6): 3e-10 of the range
  s <- ballSim
  s[2, c("h", "g")] <- s[1, c("h", "g")] + c(1e-9, 0)
  s[2, "t"] <- s[1, "t"] + 1e-12
  expect_message(FBC:::inform_duplicated_runs(s), "rows 1 and 2", fixed = TRUE)
  # a difference of 1e-3 of the range is a real run
  s[2, "h"] <- s[1, "h"] + 1e-3 * diff(range(s[, "h"]))
  expect_no_message(FBC:::inform_duplicated_runs(s))
  expect_no_message(FBC:::inform_duplicated_runs(ballSim))
})

test_that("near-duplicate runs are found on either side of a grid line", {
  # rounding the scaled inputs to a 1e-7 grid split a pair 1e-8
  # apart that straddled a grid line (0.45e-7 and 0.55e-7 round apart)
  U <- rbind(c(0.45e-7, 0.3), c(0.55e-7, 0.3), c(0.9, 0.9), c(0.2, 0.1), c(0.9 + 5e-8, 0.9),
             c(0.9 + 9e-8, 0.9))
  # rows 1-2 (1e-8 apart), rows 3, 5, 6 linked (5e-8 and 4e-8 apart; 3 and 6 are 9e-8)
  expect_identical(FBC:::near_groups(U, 1e-7), list(1:2, c(3L, 5L, 6L)))
  # identical rows are duplicates, not near ones; 2e-7 apart is two runs
  expect_identical(FBC:::near_groups(rbind(c(0, 0), c(0, 0), c(0.5, 0), c(0.5 + 2e-7, 0)), 1e-7),
                   list())
  # in a design: row 2 moved to 1e-8 of h's range from row 1
  s <- ballSim
  s[2, ] <- s[1, ]
  s[2, "h"] <- s[1, "h"] + 1e-8 * diff(range(s[, "h"]))
  expect_message(FBC:::inform_duplicated_runs(s), "1 group of runs whose inputs differ")
})

test_that("an output given in wide format (a second response column) gets a warning", {
  # y2 = 2 t x is shared with field, so it is read as an
  # experimental input; it varies with the calibration input t, which a
  # design input does not
  set.seed(1)
  x <- runif(40); t <- runif(40, 0.5, 3)
  sim <- data.frame(y1 = 5 * exp(-t * x), x = x, y2 = 2 * t * x, t = t)
  xf <- seq(0.05, 0.95, length.out = 10)
  field <- data.frame(y1 = 5 * exp(-1.7 * xf), x = xf, y2 = 3.4 * xf)
  expect_snapshot(invisible(FBC:::warn_wide_outputs(as.matrix(sim), 2)))
  # the design inputs of the shipped data do not
  expect_false(FBC:::warn_wide_outputs(ballSim, 2))
  expect_false(FBC:::warn_wide_outputs(as.matrix(sim[, c("y1", "x", "t")]), 1))
  expect_warning(short_fit(sim, field), "wide format")
})

test_that("the wide-format check's share grows as the runs get fewer", {
  # the share chance exceeds with probability 0.001 (p = q = 1: 2 regressors
  # added to the intercept): 1 - 0.001^(2 / (m - 3)) at m = 8, 0.5 from 23
  expect_equal(FBC:::wide_share(8, 1, 2), 1 - 0.001^(2 / 5))
  expect_equal(FBC:::wide_share(12, 1, 2), 1 - 0.001^(2 / 9))
  expect_identical(FBC:::wide_share(23, 1, 2), 0.5)
  expect_identical(FBC:::wide_share(200, 5, 6), 0.5)
  # 8-run Latin hypercube designs of (x, t) with an unrelated response: with
  # the fixed 50% about one in six warned; none of 400 now
  set.seed(2)
  warned <- vapply(1:400, function(i) {
    X <- cbind(x = (sample(8) - runif(8)) / 8, t = (sample(8) - runif(8)) / 8)
    FBC:::warn_wide_outputs(cbind(y = rnorm(8), X), 1)
  }, logical(1))
  expect_identical(sum(warned), 0L)
  # a second output among 8 runs is still caught
  t <- (sample(8) - runif(8)) / 8
  sim <- cbind(y1 = rnorm(8), y2 = 2 * t + t^2, t = t)
  expect_warning(FBC:::warn_wide_outputs(sim, 1), "wide format")
})
