test_that("print() shows the header and the table and returns the fit invisibly", {
  set.seed(5)
  fit <- calibrate(ballSim, ballField, nMCMC = 150, nBurn = 50, thinning = 2, nChains = 1)
  out <- capture.output(res <- withVisible(print(fit)))
  expect_false(res$visible)
  expect_identical(res$value, fit)
  expect_match(out[2], "n = 63 field, m = 100 simulator runs; p = 1, q = 1", fixed = TRUE)
  # the response, the experimental and calibration inputs by name; g's
  # design range is that of ballSim's g column
  expect_identical(out[3], "  response: t; experimental input: h")
  expect_identical(out[4], sprintf("  calibration input: kappa1 = g (design %s to %s)",
                                   signif(min(ballSim[, "g"]), 4), signif(max(ballSim[, "g"]), 4)))
  expect_match(out[5], "150 iterations, 50 burn-in, thinning 2 -> 50 draws", fixed = TRUE)
  # every move by name with its acceptance (that of the parameters it moves)
  acc <- fit$acceptance
  line <- paste(out[6:7], collapse = " ")
  expect_match(line, sprintf("acceptance: kappa1 %.2f, sim %.2f, bias %.2f, sigma2E %.2f, muB exact",
                             acc[["kappa1"]], acc[["thetaS1"]], acc[["thetaB1"]], acc[["sigma2E"]]),
               fixed = TRUE)
  expect_match(line, sprintf("scale %.2f", fit$state$chains[[1]]$scaleAcceptance), fixed = TRUE)
  expect_true(all(vapply(fit$vars, function(v) any(startsWith(out, paste0(v, " "))), logical(1))))
})

test_that("print() copes with extra estimate columns and several chains", {
  set.seed(5)
  fit <- calibrate(ballSim, ballField, nMCMC = 150, nBurn = 50, thinning = 2, nChains = 2)
  fit$estimates$nChains <- 2L
  out <- capture.output(print(fit))
  expect_match(out[5], "from 2 chains", fixed = TRUE)
  expect_true(any(grepl("nChains", out)))
})

test_that("print() ends with the convergence warnings, one per problem", {
  set.seed(5)
  fit <- calibrate(ballSim, ballField, nMCMC = 150, nBurn = 50, thinning = 2, nChains = 2)
  msgs <- convergence_messages(fit)
  # 100 draws from 2 short chains cannot reach ESS 400
  expect_true(any(startsWith(msgs, "Bulk ESS below 400")))
  out <- capture.output(print(fit))
  w <- which(out == "Warnings:")
  expect_length(w, 1)
  tail_ <- out[-seq_len(w)]  # after the table: only the messages (wrapped)
  expect_true(all(startsWith(tail_, "! ") | startsWith(tail_, "  ")))
  expect_equal(sum(startsWith(out, "! ")), length(msgs))
  expect_true(any(startsWith(out, "! Bulk ESS below 400")))
})

test_that("print() shows no warning for a converged run", {
  skip_if_not_slow()
  # only kappa sampled (its move is cheap): 4 chains mix well within 1500 sweeps
  hyp <- set_hyperPriors(
    thetaSDist = "fixed", alphaSDist = "fixed", alphaSInit = 1.9, thetaBDist = "fixed",
    alphaBDist = "fixed", sigma2SDist = "fixed", sigma2BDist = "fixed",
    sigma2EDist = "fixed", sigma2EInit = 0.15, muBDist = "fixed"
  )
  set.seed(3)
  fit <- calibrate(ballSim, ballField, nMCMC = 1500, nBurn = 300, thinning = 1, nChains = 4,
                   hypers = hyp, kernelS = "powexp", kernelB = "powexp")
  expect_lt(fit$estimates["kappa1", "rhat"], 1.01)
  expect_gt(fit$estimates["kappa1", "ess"], 400)
  expect_identical(convergence_messages(fit), character())
  out <- capture.output(print(fit))
  expect_false(any(grepl("Warning", out)))
})

test_that("print() warns about arguments it does not use, and still prints", {
  set.seed(5)
  fit <- calibrate(ballSim, ballField, nMCMC = 150, nBurn = 50, thinning = 2, nChains = 1)
  # (`digit =` would be partial matching of `digits`, which R does itself)
  expect_snapshot(out <- capture.output(print(fit, row.names = FALSE)))
  expect_match(out[1], "<fbc>", fixed = TRUE)
  expect_snapshot(out <- capture.output(print(set_hyperPriors(), all = TRUE)))
})

test_that("print() names several experimental inputs and the calibration input's design", {
  set.seed(3)
  fit <- fixed_fit(random_phi(2, 1))  # columns y, x1, x2, t
  out <- capture.output(print(fit))
  expect_identical(out[3], "  response: y; experimental inputs: x1, x2")
  t <- fit$model$scale$xmin[3] + c(0, fit$model$scale$xmax[3] - fit$model$scale$xmin[3])
  expect_identical(out[4], sprintf("  calibration input: kappa1 = t (design %s to %s)",
                                   signif(t[1], 4), signif(t[2], 4)))
})

test_that("print()'s digits is checked, and used", {
  set.seed(5)
  fit <- calibrate(ballSim, ballField, nMCMC = 150, nBurn = 50, thinning = 2, nChains = 1)
  expect_snapshot(error = TRUE, {
    print(fit, digits = "3")
    print(fit, digits = 0)
    print(summary(fit), digits = NA)
  })
  out <- capture.output(print(summary(fit), digits = 5))
  med <- signif(fit$estimates["sigma2E", "median"], 5)
  expect_match(out[grep("^sigma2E", out)], formatC(med, digits = 5, format = "fg", flag = "#"),
               fixed = TRUE, all = FALSE)
})

test_that("print() of independent outputs: the kernel's classes, one measurement-error line, the scale note", {
  pr <- two_outputs()
  set.seed(1)
  fit <- calibrate(pr$sim, pr$field, output = "out", outputs = "independent", nMCMC = 300,
                   nBurn = 150, nChains = 1, discrepancy = "none")
  out <- capture.output(suppressWarnings(print(fit)))
  # Matern 5/2 has no smoothness: no alphaS to name
  expect_true(any(grepl("each its own simulator GP (thetaS, sigma2S); only kappa shared", out, fixed = TRUE)))
  expect_false(any(grepl("alphaS", out)))
  expect_identical(sum(grepl("measurement error: sigma2E1 = conc, sigma2E2 = rate", out, fixed = TRUE)), 1L)
  sds <- vapply(split(pr$sim$y, pr$sim$out), sd, numeric(1))
  expect_true(any(grepl(sprintf("(response / its sd: conc %s, rate %s)", signif(sds[1], 4), signif(sds[2], 4)),
                        out, fixed = TRUE)))
  expect_snapshot(cat(FBC:::scale_note_line(fit$model$scale)))
})
