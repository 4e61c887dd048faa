# The model of a fit (R/model-object.R): built once, validated, fitted later
# with the draws calibrate() makes in one call.

test_that("calibrate(fit = FALSE) returns the model, and fitting it gives calibrate()'s draws", {
  set.seed(1)
  direct <- calibrate(ballSim, ballField, nMCMC = 200, nBurn = 100, nChains = 2)
  set.seed(1)
  model <- calibrate(ballSim, ballField, fit = FALSE)
  expect_s3_class(model, "fbc_model")
  # building the model draws nothing from the RNG: the fit starts where
  # calibrate() would
  fit <- calibrate(model, nMCMC = 200, nBurn = 100, nChains = 2)
  expect_identical(fit$Phi, direct$Phi)
  expect_identical(fit$logPost, direct$logPost)
  expect_identical(fit$call, direct$call)
  # the design facts, once: ballSim has 100 runs of (h, g), ballField 63
  # rows at 21 heights (3 replicates each)
  d <- model$dims
  expect_identical(d[c("p", "q", "m", "n", "noise")], list(p = 1L, q = 1L, m = 100L, n = 63L, noise = 1L))
  expect_identical(max(model$spec$model$fieldRows), length(unique(ballField[, "h"])))
  expect_identical(model$classes$length[model$classes$class == "thetaS"], 2L)
  expect_identical(sum(model$classes$length), d$d)
  expect_identical(model$algebra$name, "dense")
  expect_identical(model$priors$kappa$dist, "beta")
})

test_that("a model fits under another seed and with the run's settings only", {
  model <- calibrate(ballSim, ballField, discrepancy = "none", kernelS = "matern52", fit = FALSE)
  expect_identical(model$moves$params, model$spec$vars)
  set.seed(2)
  fit <- calibrate(model, nMCMC = 60, nBurn = 20, nChains = 1)
  set.seed(2)
  direct <- calibrate(ballSim, ballField, discrepancy = "none", kernelS = "matern52",
                      nMCMC = 60, nBurn = 20, nChains = 1)
  expect_identical(fit$Phi, direct$Phi)
  expect_identical(colnames(fit$Phi), c("kappa1", "thetaS1", "thetaS2", "sigma2S", "sigma2E"))
  expect_snapshot(error = TRUE, calibrate(model, kernelS = "gaussian"))
  expect_snapshot(error = TRUE, calibrate(model, nMCMC = 10, nBurn = 10))
})

test_that("print() describes the model", {
  model <- calibrate(ballSim, ballField, fit = FALSE)
  # the projected cost depends on the BLAS (choose_algebra())
  expect_snapshot(print(model), transform = function(x) gsub("about [0-9.e-]+ s", "about <cost> s", x))
})

test_that("the validator names what is wrong", {
  model <- calibrate(ballSim, ballField, fit = FALSE)
  bad <- model
  bad$dims$m <- 99L
  expect_snapshot(error = TRUE, FBC:::validate_fbc_model(bad))
  bad <- model
  bad$classes$length[2] <- 3L
  bad$discrepancy <- "S-GaSP"
  expect_snapshot(error = TRUE, FBC:::validate_fbc_model(bad))
  bad <- model
  bad$classes$length[2] <- 3L
  expect_snapshot(error = TRUE, FBC:::validate_fbc_model(bad))
  bad <- model
  bad$moves <- NULL
  expect_snapshot(error = TRUE, FBC:::validate_fbc_model(bad))
  expect_snapshot(error = TRUE, calibrate(bad))
})

test_that("the model's sizes and classes are its own, and the compiled description holds them", {
  # two outputs, independent; two laboratories, B with its own bias
  set.seed(5)
  x <- runif(12); t <- runif(12, 0.5, 3)
  sim <- rbind(data.frame(y = 5 * exp(-t * x), x = x, out = "conc", t = t),
               data.frame(y = 2 * t * x, x = x, out = "rate", t = t))
  xf <- seq(0.1, 0.9, length.out = 4)
  field <- rbind(data.frame(y = 5 * exp(-1.7 * xf), x = xf, out = "conc", lab = "A"),
                 data.frame(y = 3.4 * xf, x = xf, out = "rate", lab = "A"),
                 data.frame(y = 5 * exp(-1.7 * xf) + 0.3, x = xf, out = "conc", lab = "B"))
  q <- function(e) suppressWarnings(suppressMessages(e))
  indep <- q(calibrate(sim, field[field$lab == "A", 1:3], output = "out", outputs = "independent",
                       fit = FALSE))
  own <- q(calibrate(sim, field, output = "out", outputs = "shared", source = "lab",
                     sourceBias = "own", fit = FALSE))
  ball <- calibrate(ballSim, ballField, fit = FALSE)
  expect_identical(indep$dims[c("noise", "levels", "sources", "outputs")],
                   list(noise = 2L, levels = 0L, sources = 0L, outputs = 2L))
  # (the output's level correlation rhoS; conc:A, rate:A, conc:B measured apart;
  # one correlation between the laboratories' biases)
  expect_identical(own$dims[c("noise", "levels", "sources", "outputs")],
                   list(noise = 3L, levels = 1L, sources = 1L, outputs = 1L))
  for (m in list(indep, own, ball)) {
    cl <- m$classes
    expect_identical(sum(cl$length), m$dims$d)
    expect_identical(cl$offset, c(0L, cumsum(cl$length)[-nrow(cl)]))
    # each class's parameters are the spec's, in that order
    expect_identical(rep(cl$class, cl$length), m$spec$classes)
    expect_identical(m$spec$model$offset, stats::setNames(cl$offset, cl$class))
    expect_identical(m$spec$model$length, stats::setNames(cl$length, cl$class))
  }
  # a compiled description that holds another layout is refused
  bad <- ball
  bad$spec$model$offset[["muB"]] <- 0L
  expect_error(FBC:::validate_fbc_model(bad), "`spec\\$model` must hold the layout of phi")
})

test_that("distinct_rows() groups equal rows, by group when given", {
  X <- cbind(c(1, 2, 1, 2, 1), c(0, 0, 0, 1, 0))
  expect_identical(FBC:::distinct_rows(X), c(1L, 2L, 1L, 3L, 1L))
  expect_identical(FBC:::distinct_rows(X, c(1L, 1L, 2L, 1L, 1L)), c(1L, 2L, 3L, 4L, 1L))
  # exactly: rows that differ in the 16th significant digit (one unit in
  # the last place) stay apart, whatever their order
  a <- 0.1 + 0.2
  b <- 0.3
  expect_false(a == b)
  expect_identical(format(a, digits = 15), format(b, digits = 15))
  expect_identical(FBC:::distinct_rows(cbind(c(a, b, a, b), 1)), c(1L, 2L, 1L, 2L))
  expect_identical(FBC:::distinct_rows(cbind(c(b, a, b), c(2, 2, 2))), c(1L, 2L, 1L))
  # the compiled core takes the grouping as given and refuses one that
  # joins rows that differ; its own grouping (none handed over) is the same
  # one
  Xf <- cbind(c(a, b, a, 0.7))
  yf <- c(0.2, -0.1, 0.3, 0.5)
  set.seed(3)
  Xs <- cbind(runif(8), runif(8))
  ys <- sin(3 * Xs[, 1] + Xs[, 2])
  mc <- FBC:::compiled_model(1, 1, algebra = 1L)
  phi <- c(0.4, 2, 1, 1.5, 1.5, 1.2, 1.5, 0.8, 0.3, 0.05, 0)
  grouped <- FBC:::.fbc_loglik_c(Xf, yf, Xs, ys, phi, 1e-6, c(mc, list(fieldRows = c(1L, 2L, 1L, 3L))))
  alone <- FBC:::.fbc_loglik_c(Xf, yf, Xs, ys, phi, 1e-6, mc)
  expect_true(is.finite(grouped))
  expect_identical(grouped, alone)
  expect_error(FBC:::.fbc_loglik_c(Xf, yf, Xs, ys, phi, 1e-6, c(mc, list(fieldRows = c(1L, 1L, 1L, 2L)))),
               "group equal rows")
})

test_that("every walk of the model description maps to its scale and back", {
  # the walks of src/transforms.cpp: identity, log, logit of x - 1, atanh
  x <- c(identity = -0.7, log = 2.5, logit12 = 1.3, atanh = -0.4)
  w <- c(-0.7, log(2.5), log(0.3 / 0.7), 0.5 * log(0.6 / 1.4))
  codes <- FBC:::walk_codes[names(x)]
  expect_equal(unname(mapply(FBC:::to_walk, x, codes)), w, tolerance = 1e-14)
  expect_equal(unname(mapply(FBC:::from_walk, w, codes)), unname(x), tolerance = 1e-14)
  expect_setequal(unique(FBC:::model_classes$walk), names(FBC:::walk_maps))
  expect_error(FBC:::to_walk(1, 7L), "unknown walk code 7")
})

test_that("prior_conflicts() checks a correlation whose posterior sits in its prior's outer 1%", {
  # two outputs (decay and linear) sharing a rate: rhoS1 is the outputs'
  # correlation under its uniform(-1, 1) prior; its draws are replaced by
  # a spread around 0.985 (prior CDF 0.9925) and the likelihood by one
  # rising in rhoS1, so the conflict check walks rhoS1 on the atanh scale
  # (before the atanh walk existed in R, it failed with "replacement has
  # length zero")
  set.seed(1)
  x <- runif(40)
  t <- runif(40, 0.5, 3)
  xf <- seq(0.05, 0.95, length.out = 10)
  sim <- rbind(data.frame(y = 5 * exp(-t * x), x = x, out = "conc", t = t),
               data.frame(y = 2 * t * x, x = x, out = "rate", t = t))
  field <- rbind(data.frame(y = 5 * exp(-1.7 * xf) + rnorm(10, 0, 0.05), x = xf, out = "conc"),
                 data.frame(y = 2 * 1.7 * xf + rnorm(10, 0, 0.05), x = xf, out = "rate"))
  fit <- calibrate(sim, field, output = "out", outputs = "shared", nMCMC = 60, nBurn = 20, nChains = 1)
  Phi <- fit$Phi[rep(seq_len(nrow(fit$Phi)), length.out = 400), ]
  Phi[, "rhoS1"] <- 0.985 + 0.004 * qnorm(ppoints(400))
  fit <- fit_with_draws(fit, Phi, rep(1:4, each = 100), -abs(seq_len(400) - 200.5))
  fit$estimates <- FBC:::estimate_table(Phi, fit$chain)
  col <- FBC:::phi_columns(fit$model$spec)[match("rhoS1", colnames(Phi))]
  out <- FBC:::prior_conflicts(fit, loglik = function(fit, phi) 200 * phi[col])
  expect_identical(out$var, "rhoS1")
  # uniform(-1, 1): the CDF at the median 0.985 is 1.985 / 2
  expect_equal(out$cdf, 1.985 / 2)
  expect_true(out$atBound)
})

test_that("the package's code tables are the compiled core's, and a difference is refused", {
  expect_true(FBC:::check_model_codes())
  codes <- FBC:::.model_codes()
  # the classes the compiled core computes with, all of them R's
  expect_true(all(c("kappa", "thetaS", "sigma2E", "lambdaZ") %in% codes$class))
  expect_true(all(codes$class %in% FBC:::model_classes$class))
  expect_identical(codes$kernelAlpha, "powexp")
  bad <- codes
  bad$kernel[["matern52"]] <- 7L
  bad$class <- c(bad$class, "zeta")  # a class R's table does not have
  expect_snapshot(error = TRUE, FBC:::check_model_codes(bad))
})

test_that("a model fits with checkpoints, as calibrate() does", {
  dir1 <- tempfile("fbc-model-")
  dir2 <- tempfile("fbc-model-")
  on.exit(unlink(c(dir1, dir2), recursive = TRUE))
  set.seed(4)
  direct <- calibrate(ballSim, ballField, nMCMC = 100, nBurn = 50, nChains = 1,
                      checkpoint = file.path(dir1, "run"))
  set.seed(4)
  model <- calibrate(ballSim, ballField, fit = FALSE)
  fit <- calibrate(model, nMCMC = 100, nBurn = 50, nChains = 1, checkpoint = file.path(dir2, "run"))
  expect_identical(fit$Phi, direct$Phi)
  # the run's identity is the same: the model's checkpoint resumes from calibrate()'s
  again <- suppressMessages(
    calibrate(model, nMCMC = 100, nBurn = 50, nChains = 1, checkpoint = file.path(dir1, "run")))
  expect_identical(again$Phi, direct$Phi)
})
