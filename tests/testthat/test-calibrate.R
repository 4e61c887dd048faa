# The exact-posterior checks (kappa vs a grid posterior) are in
# test-exact-posterior.R.

test_that("calibrate() recovers a known calibration parameter", {
  skip_if_not_slow()
  # exact simulator eta(x, t) = t x^2 + sin(3x); field at t = 1.3 plus noise
  eta <- function(x, t) t * x^2 + sin(3 * x)
  set.seed(7)
  xs <- runif(40); ts <- runif(40, 0.5, 2)
  sim <- cbind(y = eta(xs, ts), x = xs, t = ts)
  xf <- seq(0.02, 0.98, length.out = 25)
  field <- cbind(y = eta(xf, 1.3) + rnorm(25, sd = 0.03), x = xf)
  fit <- calibrate(sim, field, nMCMC = 4000, nBurn = 1000, thinning = 3)
  ci <- quantile(fit$Phi[, "kappa1"], c(0.025, 0.975))
  expect_gt(1.3, ci[[1]])
  expect_lt(1.3, ci[[2]])
  # the data sharpen the Beta(1.1, 1.1) prior on [0.5, 2] (sd 1.5 * 0.279 = 0.42)
  expect_lt(sd(fit$Phi[, "kappa1"]), 0.8 * 1.5 * sqrt(1.1^2 / (2.2^2 * 3.2)))
  expect_equal(colnames(fit$Phi)[1:3], c("kappa1", "thetaS1", "thetaS2"))
  # measurement error variance recovered on the standardised scale
  expect_equal(median(fit$Phi[, "sigma2E"]), (0.03 / sd(sim[, 1]))^2, tolerance = 2)
})

test_that("the default ball calibration covers g = 9.81", {
  skip_if_not_slow()
  set.seed(2024)
  fit <- calibrate(ballSim, ballField)
  ci <- quantile(fit$Phi[, "kappa1"], c(0.025, 0.975))
  expect_gt(9.81, ci[[1]])
  expect_lt(9.81, ci[[2]])
  expect_true(all(fit$Phi[, "kappa1"] >= 6 & fit$Phi[, "kappa1"] <= 14))
  acc <- fit$acceptance
  expect_identical(acc[["muB"]], 1)  # drawn exactly from its full conditional
  acc <- acc[names(acc) != "muB"]
  expect_true(all(acc > 0.15 & acc < 0.75))
  expect_s3_class(fit, "fbc")
  expect_named(fit, c("Phi", "chain", "estimates", "logPost", "priors", "acceptance", "vars",
                      "indices", "priorFns", "proposalSD", "call", "settings",
                      "logLik", "state", "model", "version"))
  expect_equal(rownames(fit$estimates), fit$vars)
  expect_equal(fit$estimates["kappa1", "median"], median(fit$Phi[, "kappa1"]))
  expect_equal(fit$estimates["kappa1", "lwr80"], unname(quantile(fit$Phi[, "kappa1"], 0.1)))
  # the stretched Beta(1.1, 1.1) log density in the units of g
  lo <- min(ballSim[, "g"]); rng <- diff(range(ballSim[, "g"]))
  expect_equal(fit$priorFns$kappa1(10), dbeta((10 - lo) / rng, 1.1, 1.1, log = TRUE) - log(rng))
  expect_output(print(fit), "kappa1")
})

test_that("set.seed() reproduces a run and the inputs are not modified", {
  skip_if_not_slow()
  sim <- as.data.frame(ballSim)
  field <- ballField
  sim0 <- sim; field0 <- field
  set.seed(5); a <- calibrate(sim, field, nMCMC = 300, nBurn = 100, thinning = 1)
  set.seed(5); b <- calibrate(sim, field, nMCMC = 300, nBurn = 100, thinning = 1)
  expect_identical(a$Phi, b$Phi)
  expect_identical(a$logPost, b$logPost)
  expect_identical(sim, sim0)
  expect_identical(field, field0)
  set.seed(6); d <- calibrate(sim, field, nMCMC = 300, nBurn = 100, thinning = 1)
  expect_false(identical(a$Phi, d$Phi))
})

test_that("the default discrepancy model gives the draws it gave before the choice existed", {
  # reference: the same call with FBC at commit 62c9243 (before
  # `discrepancy`; with its kernel and noise prior, defaults_010): its
  # Phi[100, ] and sum(Phi), to 12 significant digits; without kappa's jump
  # move, which that version did not have (no_jump(), helper-fit.R)
  set.seed(7)
  fit <- calibrate(no_jump(do.call(calibrate, c(list(ballSim, ballField, fit = FALSE), defaults_010))),
                   nMCMC = 300, nBurn = 100, nChains = 1)
  expect_identical(fit$model$discrepancy, "gp")
  expect_equal(unname(fit$Phi[100, ]),
               c(7.79832811351, 3.14605375608, 0.362741566864, 1.99967461794, 1.99987846678,
                 0.588393759571, 1.57226685352, 3.95411184451, 0.596029356555, 0.153550863944,
                 0.73174816915), tolerance = 1e-11)
  expect_equal(sum(fit$Phi), 2526.33110293876, tolerance = 1e-13)
  set.seed(7)
  m <- no_jump(do.call(calibrate, c(list(ballSim, ballField, discrepancy = "gp", fit = FALSE),
                                    defaults_010)))
  expect_identical(calibrate(m, nMCMC = 300, nBurn = 100, nChains = 1)$Phi, fit$Phi)
})

test_that("discrepancy = \"none\": no bias parameters anywhere, and every path follows", {
  set.seed(32)
  fit <- calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, thinning = 2, nChains = 2,
                   discrepancy = "none")
  keep <- c("kappa1", "thetaS1", "thetaS2", "sigma2S", "sigma2E")
  expect_identical(colnames(fit$Phi), keep)
  # the sampler's vector keeps the smoothness slots, held (the Matérn has none)
  expect_identical(fit$model$spec$vars, c("kappa1", "thetaS1", "thetaS2", "alphaS1", "alphaS2", "sigma2S",
                                    "sigma2E"))
  expect_identical(rownames(fit$estimates), keep)
  expect_identical(names(fit$proposalSD), keep)
  for (cls in c("thetaB", "alphaB", "sigma2B", "muB")) expect_identical(fit$indices[[cls]], integer(0))
  expect_identical(fit$model$discrepancy, "none")
  expect_identical(fit$model$spec$model$discrepancy, 1L)
  # no bias moves; kappa's jump; the scale move multiplies sigma2S and sigma2E
  mv <- FBC:::move_report(fit)
  expect_identical(mv$move, c("kappa1", "sim", "sigma2E", "kappa1 jump", "scale"))
  expect_false(fit$model$moves$gibbsMuB)
  # the retained log-likelihoods are the plain-R ones without a bias block
  i <- 7
  ll <- dense_loglik(fit$model$data$Xf, fit$model$data$yf, fit$model$data$Xs, fit$model$data$ys,
                     FBC:::sampler_draws(fit, i)[1, ], kernS = "matern52", discrepancy = "none")
  expect_equal(fit$logLik[i], ll, tolerance = 1e-8)
  # print, plots, checks
  expect_output(print(fit), "no discrepancy: y_f = eta\\(x, kappa\\) \\+ eps")
  expect_output(print(fit), "kernels: simulator matern52\n")
  expect_s3_class(plot(fit, "sigma2E"), "ggplot")
  expect_s3_class(plot(fit, type = "fits"), "ggplot")
  expect_snapshot(error = TRUE, plot(fit, "sigma2B"))
  expect_type(convergence_messages(fit), "character")
  expect_s3_class(FBC:::prior_conflicts(fit), "data.frame")
  expect_s3_class(ppc_field(fit), "fbc_ppc")
  expect_s3_class(emulator_cv(fit, method = "MAP"), "fbc_emulator_cv")
  # update() continues the chains with the same columns and model
  up <- update(fit, nMCMC = 40)
  expect_identical(colnames(up$Phi), keep)
  expect_identical(up$model$discrepancy, "none")
  expect_identical(up$Phi[up$chain == 1, ][seq_len(sum(fit$chain == 1)), ],
                   fit$Phi[fit$chain == 1, ])
  last <- nrow(up$Phi)
  expect_equal(up$logLik[last],
               dense_loglik(up$model$data$Xf, up$model$data$yf, up$model$data$Xs, up$model$data$ys,
                            FBC:::sampler_draws(up, last)[1, ], kernS = "matern52",
                            discrepancy = "none"),
               tolerance = 1e-8)
})

test_that("the discrepancy model is checked, and bias priors without a bias are flagged", {
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, discrepancy = "S-GaSP"))
  set.seed(1)
  expect_snapshot(
    fit <- calibrate(ballSim, ballField, nMCMC = 20, nBurn = 10, nChains = 1,
                     discrepancy = "none", hypers = set_hyperPriors(sigma2BDist = "fixed",
                                                                    sigma2BInit = 1e-6))
  )
  expect_false("sigma2B" %in% colnames(fit$Phi))
  expect_snapshot(
    fit <- calibrate(ballSim, ballField, nMCMC = 20, nBurn = 10, nChains = 1,
                     discrepancy = "none", kernelB = "matern32")
  )
  expect_identical(fit$indices$alphaB, integer(0))
  # the S-GaSP has no bias mean, the KOH bias no S-GaSP scale
  expect_snapshot(
    fit <- calibrate(ballSim, ballField, nMCMC = 20, nBurn = 10, nChains = 1,
                     discrepancy = "sgasp", hypers = set_hyperPriors(muBInit = 0.5))
  )
  expect_identical(fit$indices$muB, integer(0))
  expect_identical(colnames(fit$Phi)[fit$indices$lambdaZ], "lambdaZ")
  expect_snapshot(
    fit <- calibrate(ballSim, ballField, nMCMC = 20, nBurn = 10, nChains = 1,
                     hypers = set_hyperPriors(lambdaZDist = "fixed", lambdaZInit = 5))
  )
  expect_identical(fit$indices$lambdaZ, integer(0))
  expect_snapshot(error = TRUE, plot(fit, "lambdaZ"))
})

test_that("logPost is the log-likelihood plus the log priors of the draw", {
  set.seed(9)
  fit <- calibrate(ballSim, ballField, nMCMC = 200, nBurn = 100, thinning = 10)
  i <- 3
  phi <- fit$Phi[i, ]
  lp <- sum(vapply(fit$vars, function(v) fit$priorFns[[v]](phi[[v]]), 0))
  # the sampler's scale: g mapped to [0, 1] over the design range (and the
  # smoothness slots the Matérn holds, which Phi leaves out)
  u <- FBC:::sampler_draws(fit, i)[1, ]
  lo <- min(ballSim[, "g"]); rng <- diff(range(ballSim[, "g"]))
  expect_equal(u[[1]], (phi[[1]] - lo) / rng)
  ll <- dense_loglik(fit$model$data$Xf, fit$model$data$yf, fit$model$data$Xs, fit$model$data$ys, unname(u),
                     kernS = "matern52", kernB = "matern52")
  expect_equal(fit$logLik[i], ll, tolerance = 1e-8)
  expect_equal(fit$logPost[i], ll + lp, tolerance = 1e-8)
})

test_that("calibrate() explains bad input", {
  bad_na <- ballField; bad_na[3, 1] <- NA
  bad_inf <- ballSim; bad_inf[5, 3] <- Inf
  const <- ballSim; const[, "g"] <- 9.8
  df_chr <- data.frame(t = ballField[, 1], h = as.character(ballField[, 2]))
  expect_snapshot(error = TRUE, calibrate(letters, ballField))
  expect_snapshot(error = TRUE, calibrate(ballSim, df_chr))
  expect_snapshot(error = TRUE, calibrate(ballSim, bad_na))
  expect_snapshot(error = TRUE, calibrate(bad_inf, ballField))
  expect_snapshot(error = TRUE, calibrate(ballSim[, 1:2], ballField))
  expect_snapshot(error = TRUE, calibrate(ballSim, cbind(ballField, ballField[, 2])))
  expect_snapshot(error = TRUE, calibrate(const, ballField))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, nMCMC = 100, nBurn = 100))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, thinning = 0))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, nMCMC = 10.5))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, kappaDist = "cauchy"))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, kappaDist = "uniform", kappaP1 = 14, kappaP2 = 6))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, kappaDist = c("beta", "beta")))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, kappaInit = 20))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, hypers = set_hyperPriors(thetaSInit = c(1, 2, 3))))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, hypers = list()))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, showProgress = "yes"))
})

test_that("showProgress = TRUE runs the same chain", {
  skip_if_not_slow()
  withr_opts <- options(cli.progress_show_after = 0, cli.dynamic = FALSE)
  on.exit(options(withr_opts))
  set.seed(12); a <- calibrate(ballSim, ballField, nMCMC = 400, nBurn = 100, thinning = 1)
  set.seed(12)
  expect_no_error(b <- suppressMessages(calibrate(ballSim, ballField, nMCMC = 400, nBurn = 100,
                                                  thinning = 1, showProgress = TRUE)))
  expect_identical(a$Phi, b$Phi)
})

test_that("run lengths whose draws cannot be stored are refused with the memory they need", {
  withr_opts <- options(FBC.memory_limit = 8e9)  # the same message on every machine
  on.exit(options(withr_opts))
  expect_snapshot(error = TRUE, {
    calibrate(ballSim, ballField, nMCMC = 2^31)
    calibrate(ballSim, ballField, nBurn = 2^31)
    calibrate(ballSim, ballField, nMCMC = 2e9, nBurn = 0, thinning = 1)
    calibrate(ballSim, ballField, nMCMC = 2e8, nChains = 8)
  })
  # 4 chains x 3000 draws x (11 parameters + 2) x 8 bytes, twice (stacking):
  # 2.5 MB, refused under a 1 MB limit and accepted under 3 MB
  expect_equal(FBC:::check_run_size(3000, 11, 4, 8000, "nMCMC"), 2 * 4 * 3000 * 13 * 8)
  options(FBC.memory_limit = 1e6)
  expect_error(calibrate(ballSim, ballField, nMCMC = 8000, nBurn = 2000), "2.5 MB")
  # the default run until converged is checked at its ceiling (maxMCMC =
  # 50000 sweeps, at least 200 of warm-up): 4 x 24,900 draws, 20.7 MB
  expect_error(calibrate(ballSim, ballField), "20.7 MB")
})

test_that("large dense problems move each kappa and the simulator block once a sweep", {
  p <- 2; q <- 2
  sp <- FBC:::build_priors(list(dist = rep("beta", q), init = rep(NA, q), p1 = rep(1.1, q),
                                p2 = rep(1.1, q)), set_hyperPriors(),
                           list(xmin = rep(0, p + q), xmax = rep(1, p + q), p = p, q = q), p, q)
  sp$model <- FBC:::compiled_model(p, q)
  small <- FBC:::sampler_moves("blocks", sp)
  large <- FBC:::sampler_moves("blocks", sp, large = TRUE)
  expect_identical(large$blocks, small$blocks)  # kappa1, kappa2, simulator, bias, kappa's joint walk
  # (beside kappa's joint walk, three a sweep, each kappa walks once)
  expect_identical(small$repeats, c(1L, 1L, 2L, 2L, 3L))
  expect_identical(large$repeats, c(1L, 1L, 1L, 2L, 1L))
  expect_identical(FBC:::sampler_moves("single", sp, large = TRUE)$blocks, list())
  # the schedule follows the size and the algebra (product designs keep it)
  expect_true(FBC:::large_dense(500, list(name = "dense")))
  expect_false(FBC:::large_dense(499, list(name = "dense")))
  expect_false(FBC:::large_dense(4000, list(name = "Kronecker")))
  set.seed(4)
  X <- matrix(runif(500 * 2), 500)
  sim <- cbind(y = sin(3 * X[, 1]) + X[, 2], x = X[, 1], t = X[, 2])
  field <- cbind(y = sin(3 * c(0.2, 0.5, 0.8)) + 0.5, x = c(0.2, 0.5, 0.8))
  fit <- suppressMessages(calibrate(sim, field, nMCMC = 4, nBurn = 2, thinning = 1, nChains = 1))
  expect_identical(fit$model$algebra$name, "dense")
  expect_identical(fit$model$moves$repeats, c(1L, 1L, 2L))
})

test_that("a family without a smoothness: Phi, vars and indices leave alpha out, and every path follows", {
  set.seed(31)
  fit <- calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, thinning = 2, nChains = 2,
                   kernelS = "matern52", kernelB = "matern32")
  keep <- c("kappa1", "thetaS1", "thetaS2", "thetaB1", "sigma2S", "sigma2B", "sigma2E", "muB")
  expect_identical(colnames(fit$Phi), keep)
  expect_identical(fit$vars, keep)
  expect_identical(rownames(fit$estimates), keep)
  expect_identical(names(fit$acceptance), keep)
  expect_identical(names(fit$proposalSD), keep)
  expect_identical(fit$indices$alphaS, integer(0))
  expect_identical(fit$indices$alphaB, integer(0))
  expect_identical(fit$indices$thetaS, 2:3)
  expect_identical(fit$indices$muB, 8L)
  expect_identical(fit$model[c("kernelS", "kernelB")], list(kernelS = "matern52", kernelB = "matern32"))
  # the sampler's vector keeps fixed alpha slots
  expect_length(fit$model$spec$vars, 11)
  full <- FBC:::sampler_draws(fit, 1:3)
  expect_identical(dim(full), c(3L, 11L))
  expect_true(all(full[, c(4, 5, 7)] == 2))
  # the retained log-likelihoods are the plain-R Matern ones (the chains ran
  # with the families asked for), and logPost adds the priors of Phi's columns
  i <- 5
  ll <- dense_loglik(fit$model$data$Xf, fit$model$data$yf, fit$model$data$Xs, fit$model$data$ys,
                     FBC:::sampler_draws(fit, i)[1, ], kernS = "matern52", kernB = "matern32")
  expect_equal(fit$logLik[i], ll, tolerance = 1e-8)
  lp <- sum(vapply(fit$vars, function(v) fit$priorFns[[v]](fit$Phi[i, v]), 0))
  expect_equal(fit$logPost[i], ll + lp, tolerance = 1e-8)
  # conversions, summaries, messages
  expect_identical(names(coef(fit)), keep)
  expect_identical(rownames(summary(fit)), keep)
  d <- posterior::as_draws_df(fit)
  expect_identical(posterior::variables(d), c(keep, "lp__"))
  skip_if_not_installed("coda")
  expect_identical(coda::varnames(coda::as.mcmc.list(fit)), keep)
  expect_type(convergence_messages(fit), "character")
  expect_output(print(fit), "kernels: simulator matern52, bias matern32")
  # update() continues the chains with the same columns
  up <- update(fit, nMCMC = 40)
  expect_identical(colnames(up$Phi), keep)
  expect_identical(nrow(up$Phi), nrow(fit$Phi) + 40L)
  expect_identical(up$Phi[up$chain == 1, ][seq_len(sum(fit$chain == 1)), ],
                   fit$Phi[fit$chain == 1, ])
  ll <- dense_loglik(up$model$data$Xf, up$model$data$yf, up$model$data$Xs, up$model$data$ys,
                     FBC:::sampler_draws(up, nrow(up$Phi))[1, ], kernS = "matern52",
                     kernB = "matern32")
  expect_equal(up$logLik[nrow(up$Phi)], ll, tolerance = 1e-8)
  # plots
  expect_s3_class(plot(fit, "thetaS"), "ggplot")
  expect_s3_class(plot(fit, "thetaB", type = "trace"), "ggplot")
  expect_snapshot(error = TRUE, plot(fit, "alphaS"))
  expect_snapshot(error = TRUE, plot(fit, "alphaB"))
})

test_that("the kernels are checked, and alpha priors with a family without one are flagged", {
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, kernelS = "matern"))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, kernelB = 2))
  set.seed(1)
  expect_snapshot(
    fit <- calibrate(ballSim, ballField, nMCMC = 20, nBurn = 10, nChains = 1,
                     kernelS = "gaussian", kernelB = "powexp",
                     hypers = set_hyperPriors(alphaSDist = "fixed", alphaSInit = 2,
                                              alphaBInit = 1.5))
  )
  # the bias GP keeps its power exponential and the alphaB given
  expect_identical(fit$vars[fit$indices$alphaB], "alphaB1")
  expect_identical(fit$indices$alphaS, integer(0))
})
