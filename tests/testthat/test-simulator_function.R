# The simulator as an R function (R/simulator_function.R, src/function.cpp).

# RobustCalibration's documented example (rcalibration(), simul_type = 1):
# the model sin(theta x) + x; here the field is drawn from the model itself
# at theta = 1.2 (so that "none" is the right model), noise sd 0.3.
fn_model <- function(x, kappa) sin(kappa[["theta"]] * x$x) + x$x
fn_field <- function(n = 15, seed = 1, theta = 1.2, sd = 0.3) {
  set.seed(seed)
  x <- seq(0, 5, length.out = n)
  data.frame(y = sin(theta * x) + x + stats::rnorm(n, 0, sd), x = x)
}
fn_kappa <- list(kappaDist = "uniform", kappaP1 = c(theta = 0), kappaP2 = c(theta = 3))

test_that("discrepancy none, sigma2E fixed: theta's draws match the grid posterior computed from f", {
  field <- fn_field()
  s2 <- 0.3^2
  # the response is standardised by the field response's sd (?calibrate,
  # "The simulator as a function"), so the fixed noise variance is given
  # on that scale
  hyp <- set_hyperPriors(sigma2EDist = "fixed", sigma2EInit = s2 / stats::sd(field$y)^2)
  set.seed(3)
  fit <- do.call(calibrate, c(list(fn_model, field, discrepancy = "none", hypers = hyp,
                                   nMCMC = 3000, nBurn = 500, nChains = 2), fn_kappa))
  expect_identical(colnames(fit$Phi), c("kappa1", "sigma2E"))
  expect_equal(fit$model$scale$ysd, stats::sd(field$y))
  # plain R: uniform prior on [0, 3], Gaussian likelihood of y - f(x, theta)
  th <- seq(0, 3, length.out = 6001)
  ll <- vapply(th, function(t) sum(stats::dnorm(field$y, fn_model(field, c(theta = t)), 0.3, log = TRUE)),
               numeric(1))
  dens <- exp(ll - max(ll))
  probs <- c(0.05, 0.25, 0.5, 0.75, 0.95)
  ref <- grid_quantile(th, dens, probs)
  got <- stats::quantile(fit$Phi[, "kappa1"], probs, names = FALSE)
  sdRef <- sqrt(sum(th^2 * dens) / sum(dens) - (sum(th * dens) / sum(dens))^2)
  expect_lt(max(abs(got - ref)) / sdRef, 0.15)
  ks <- suppressWarnings(stats::ks.test(fit$Phi[, "kappa1"], grid_cdf(th, dens))$statistic)
  expect_lt(ks, 0.06)
})

# RobustCalibration's own documented example (?rcalibration, simul_type =
# 1): reality x cos(1.5 x) + x, 15 points, noise sd 0.1, set.seed(1); the
# model sin(theta x) + x, theta in [0, 3]. With no discrepancy theta's
# posterior is bimodal: a main mode near 1.87 and a small one near 0.27.
rc_example <- function() {
  set.seed(1)
  x <- seq(0, 5, 5 / 14)
  data.frame(y = x * cos(3 / 2 * x) + x + stats::rnorm(15, 0, 0.1), x = x)
}

test_that("the bimodal example: the default run's theta matches the grid posterior, small mode included", {
  field <- rc_example()
  # plain R: theta uniform on [0, 3]; on the scaled response (divided by
  # sd(y), ?calibrate) the noise sd s is half-Cauchy(0, 1) (sigma2E's
  # default halft_sd(1, 1)), integrated out on a grid of log s
  ysd <- stats::sd(field$y)
  th <- seq(0, 3, length.out = 3001)
  ls <- seq(log(1e-3), log(10), length.out = 2001)
  lps <- log(2 / pi) - log1p(exp(2 * ls)) + ls  # log density of log s
  lpost <- vapply(th, function(t) {
    ss <- sum(((field$y - fn_model(field, c(theta = t))) / ysd)^2)
    l <- -nrow(field) * ls - ss / (2 * exp(2 * ls)) + lps
    max(l) + log(sum(exp(l - max(l))))
  }, numeric(1))
  dens <- exp(lpost - max(lpost))
  small <- sum(dens[th < 1]) / sum(dens)  # 0.179: the small mode's mass
  expect_gt(small, 0.15)
  set.seed(2)  # the seed whose run missed the small mode before the jump move
  fit <- do.call(calibrate, c(list(fn_model, field, discrepancy = "none", showProgress = FALSE),
                              fn_kappa))
  expect_true(fit$settings$converge$converged)
  draws <- fit$Phi[, "kappa1"]
  # the small mode's mass within 4 Monte Carlo standard errors (the
  # indicator's ESS over the chains)
  ind <- matrix(as.numeric(draws < 1), ncol = fit$settings$nChains)
  mcse <- sqrt(small * (1 - small) / posterior::ess_basic(ind))
  expect_lt(abs(mean(draws < 1) - small), 4 * mcse)
  probs <- c(0.05, 0.25, 0.5, 0.75, 0.95)
  got <- stats::quantile(draws, probs, names = FALSE)
  expect_lt(max(abs(got - grid_quantile(th, dens, probs))), 0.1)
  ks <- suppressWarnings(stats::ks.test(draws, grid_cdf(th, dens))$statistic)
  expect_lt(ks, 0.06)
  # the jump move is reported by name; set.seed() reproduces a run
  mv <- FBC:::move_report(fit)
  jump <- mv[mv$move == "kappa1 jump", ]
  expect_identical(jump$kind, "jump")
  expect_true(jump$acceptance > 0.02 && jump$acceptance < 0.5)
  short <- function() {
    set.seed(5)
    do.call(calibrate, c(list(fn_model, field, discrepancy = "none", nMCMC = 300, nBurn = 100,
                              nChains = 2, showProgress = FALSE), fn_kappa))$Phi
  }
  expect_identical(short(), short())
})

# The log-likelihood of the function model in plain R: yf - muB - fs ~
# N(0, sigma2B Rb + sigma2E I) on the scaled space (Rb: matern52 over the
# scaled inputs; S-GaSP: its discretized kernel; none: sigma2E I).
fn_dense_loglik <- function(model, phi, f) {
  d <- model$data
  sc <- model$scale
  G <- max(model$design$noise, 1L)
  th <- lapply(FBC:::param_indices(sc$p, sc$q, model$discrepancy, G, emulator = FALSE),
               function(i) phi[i])
  theta <- sc$xmin[2] + (sc$xmax[2] - sc$xmin[2]) * th$kappa
  fs <- (f(model$simulator$x, c(theta = theta)) - sc$ymean) / sc$ysd
  n <- length(d$yf)
  S <- diag(th$sigma2E[model$design$noise %||% rep(1L, n)], n)
  if (model$discrepancy != "none") {
    S <- S + th$sigma2B * bias_corr_dense(d$Xf, th, "matern52", model$discrepancy)
  }
  r <- d$yf - fs - if (model$discrepancy == "gp") th$muB else 0
  L <- chol(S)
  a <- backsolve(L, r, transpose = TRUE)
  -0.5 * (n * log(2 * pi) + 2 * sum(log(diag(L))) + sum(a^2))
}

test_that("the log-likelihood and every move's update equal a dense plain-R one (1e-8)", {
  field <- fn_field(n = 12, seed = 2)
  field <- rbind(field, field[3, ])  # a replicate shares its bias
  for (disc in c("gp", "sgasp", "none")) {
    model <- do.call(calibrate, c(list(fn_model, field, discrepancy = disc, fit = FALSE), fn_kappa))
    d <- model$data
    vars <- model$spec$vars
    expect_false(any(c("thetaS1", "sigma2S") %in% vars))
    set.seed(4)
    base <- model$spec$init
    phis <- t(replicate(6, {
      x <- base
      x[vars == "kappa1"] <- stats::runif(1, 0.1, 0.9)
      x[vars == "sigma2E"] <- stats::runif(1, 0.05, 0.5)
      if (disc != "none") {
        x[vars == "thetaB1"] <- stats::runif(1, 0.5, 8)
        x[vars == "sigma2B"] <- stats::runif(1, 0.2, 2)
      }
      if (disc == "gp") x[vars == "muB"] <- stats::rnorm(1)
      if (disc == "sgasp") x[vars == "lambdaZ"] <- stats::runif(1, 5, 50)
      x
    }))
    # the last row: the variances scaled by one factor (the scale move)
    last <- phis[6, ]
    sc <- vars %in% c("sigma2B", "sigma2E")
    last[sc] <- last[sc] * 1.7
    phis <- rbind(phis, last)
    ref <- unname(apply(phis, 1, function(phi) fn_dense_loglik(model, phi, fn_model)))
    one <- sapply(seq_len(nrow(phis)), function(i) { phi <- phis[i, ]
      FBC:::.fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6, model = model$spec$model)
    })
    expect_equal(one, ref, tolerance = 1e-8)
    # moves from row to row (one parameter at a time, rejected decoys, the
    # scale move): the cached updates
    path <- FBC:::.loglik_path(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, decoys = TRUE, scale = TRUE,
                               model = model$spec$model)
    expect_equal(path, ref, tolerance = 1e-8)
  }
})

test_that("f is called once per kappa proposal, with every field row", {
  field <- fn_field()
  calls <- 0L
  rows <- integer()
  f <- function(x, kappa) {
    calls <<- calls + 1L
    rows <<- c(rows, nrow(x))
    sin(kappa[["theta"]] * x$x) + x$x
  }
  set.seed(1)
  fit <- do.call(calibrate, c(list(f, field, discrepancy = "gp", nMCMC = 200, nBurn = 100,
                                   nChains = 1, thinning = 1), fn_kappa))
  expect_true(all(rows == nrow(field)))
  # kappa's walk moves three times a sweep and its jump once
  # (sampler_moves(jump = TRUE)); the other moves reuse f's value: 200
  # sweeps x 4 proposals, plus the start's and the scaling's calls
  tries <- 200 * 4
  expect_gte(calls, tries)
  expect_lte(calls, tries + 5L)
})

test_that("f sees a named kappa of length q on every call: sampler and predict()", {
  field <- fn_field(n = 8)
  for (q in 1:2) {
    kn <- c("theta", "b")[seq_len(q)]
    seen <- list()
    f <- function(x, kappa) {
      seen[[length(seen) + 1L]] <<- kappa
      b <- if (q == 2) kappa[["b"]] else 0
      sin(kappa[["theta"]] * x$x) + x$x + b
    }
    k <- list(kappaDist = "uniform", kappaP1 = stats::setNames(c(0, -1)[seq_len(q)], kn),
              kappaP2 = stats::setNames(c(3, 1)[seq_len(q)], kn))
    set.seed(4)
    fit <- do.call(calibrate, c(list(f, field, discrepancy = "gp", nMCMC = 60, nBurn = 20,
                                     nChains = 1, thinning = 1), k))
    nSampler <- length(seen)
    pr <- predict(fit, data.frame(x = c(0.5, 2)))
    expect_gt(length(seen), nSampler)
    expect_gt(nSampler, 60)
    lens <- vapply(seen, length, integer(1))
    expect_identical(unique(lens), q)
    expect_true(all(vapply(seen, function(v) identical(names(v), kn), logical(1))))
    expect_true(all(vapply(seen, function(v) all(is.finite(v)), logical(1))))
    # each value inside the prior's range
    lo <- k$kappaP1; hi <- k$kappaP2
    expect_true(all(vapply(seen, function(v) all(v >= lo & v <= hi), logical(1))))
  }
})

test_that("errors from f name the kappa that caused them", {
  field <- fn_field(n = 5)
  k <- list(kappaDist = "uniform", kappaP1 = c(theta = 0), kappaP2 = c(theta = 3))
  short <- function(x, kappa) sin(kappa[["theta"]] * x$x)[-1]
  failing <- function(x, kappa) stop("the solver diverged")
  nan <- function(x, kappa) rep(NaN, nrow(x))
  expect_snapshot(error = TRUE, do.call(calibrate, c(list(short, field, fit = FALSE), k)))
  expect_snapshot(error = TRUE, do.call(calibrate, c(list(failing, field, fit = FALSE), k)))
  expect_snapshot(error = TRUE, do.call(calibrate, c(list(nan, field, fit = FALSE), k)))
  # during sampling: f fails beyond theta = 1.5 (the centre works)
  late <- function(x, kappa) {
    if (kappa[["theta"]] > 1.6) stop("no convergence") else sin(kappa[["theta"]] * x$x) + x$x
  }
  set.seed(1)
  err <- expect_error(do.call(calibrate, c(list(late, field, nMCMC = 200, nBurn = 100, nChains = 1,
                                                 discrepancy = "none"), k)),
                      "failed at theta = ")
  expect_gt(as.numeric(sub(".*theta = ([0-9]+[.]?[0-9]*).*", "\\1", conditionMessage(err))), 1.6)
})

test_that("nonFinite = \"reject\" turns non-finite values into rejected proposals", {
  field <- fn_field()
  f <- function(x, kappa) if (kappa[["theta"]] > 1.25) rep(NA_real_, nrow(x)) else fn_model(x, kappa)
  set.seed(2)
  # the scaling needs f finite at the prior's centre, or at kappaInit
  expect_error(do.call(calibrate, c(list(f, field, fit = FALSE, nonFinite = "reject"), fn_kappa)),
               "finite at the prior's centre or `kappaInit` \\(theta = 1.5\\)")
  fit <- do.call(calibrate, c(list(f, field, discrepancy = "none", nMCMC = 600, nBurn = 200,
                                   nChains = 2, nonFinite = "reject", kappaInit = 1), fn_kappa))
  expect_lte(max(fit$Phi[, "kappa1"]), 1.25)
  expect_gt(max(fit$Phi[, "kappa1"]), 1.15)
})

test_that("what cannot define the calibration inputs is refused", {
  field <- fn_field(n = 5)
  expect_snapshot(error = TRUE, calibrate(fn_model, field, fit = FALSE))
  expect_snapshot(error = TRUE, calibrate(function(x) x, field, kappaDist = "uniform",
                                          kappaP1 = 0, kappaP2 = 1, fit = FALSE))
  expect_snapshot(error = TRUE, calibrate(fn_model, field, kappaDist = "uniform",
                                          kappaP1 = c(x = 0), kappaP2 = 3, fit = FALSE))
  expect_snapshot(error = TRUE, calibrate(fn_model, cbind(field, s = "a"), kappaDist = "uniform",
                                          kappaP1 = c(theta = 0), kappaP2 = 3, fit = FALSE))
  # two calibration inputs, named by kappaP1
  f2 <- function(x, kappa) kappa[["a"]] * x$x + kappa[["b"]]
  model <- calibrate(f2, field, kappaDist = "uniform", kappaP1 = c(a = 0, b = -1),
                     kappaP2 = c(2, 1), fit = FALSE)
  expect_identical(model$scale$names$calibration, c("a", "b"))
  expect_identical(model$scale$xmin[2:3], c(0, -1))
  expect_identical(model$scale$xmax[2:3], c(2, 1))
})

test_that("predict(): f at the new inputs plus the bias, against plain R at one draw", {
  field <- fn_field(n = 10, seed = 5)
  set.seed(6)
  fit <- do.call(calibrate, c(list(fn_model, field, nMCMC = 400, nBurn = 200, nChains = 2),
                              fn_kappa))
  new <- data.frame(x = c(0.7, 2.2, 4.9))
  sim <- predict(fit, new, type = "simulator", method = "MAP")
  map <- fit$Phi[which.max(fit$logPost), ]
  # the simulator is known: f at the MAP theta, no uncertainty
  expect_equal(sim$pred, fn_model(new, c(theta = map[["kappa1"]])), tolerance = 1e-12)
  expect_equal(sim$se, rep(0, 3))
  # the mean: f plus the bias GP's conditional mean given the field
  # residual yf - f(xf), in plain R on the scaled space (matern52 bias)
  sc <- fit$model$scale
  Xf <- fit$model$data$Xf
  Xn <- (new$x - sc$xmin[1]) / (sc$xmax[1] - sc$xmin[1])
  fs <- (fn_model(field, c(theta = map[["kappa1"]])) - sc$ymean) / sc$ysd
  S <- map[["sigma2B"]] * dense_corr(Xf, Xf, map[["thetaB1"]], NA, "matern52") +
    map[["sigma2E"]] * diag(nrow(field))
  K <- map[["sigma2B"]] * dense_corr(Xn, Xf, map[["thetaB1"]], NA, "matern52")
  r <- fit$model$data$yf - map[["muB"]] - fs
  biasMean <- map[["muB"]] + K %*% solve(S, r)
  biasVar <- map[["sigma2B"]] - rowSums((K %*% solve(S)) * K)
  mean <- predict(fit, new, type = "mean", method = "MAP")
  expect_equal(mean$pred, sim$pred + sc$ysd * c(biasMean), tolerance = 1e-8)
  expect_equal(mean$se, sc$ysd * sqrt(biasVar), tolerance = 1e-8)
  obs <- predict(fit, new, type = "field", method = "MAP")
  expect_equal(obs$se^2, mean$se^2 + sc$ysd^2 * map[["sigma2E"]], tolerance = 1e-8)
  bias <- predict(fit, new, type = "bias", method = "MAP")
  expect_equal(bias$pred, sc$ysd * c(biasMean), tolerance = 1e-8)
  # Bayesian: the draws' mixture; the simulator's spread is theta's
  expect_gt(predict(fit, new, type = "simulator")$se[3], 0)
})

test_that("print(), plot(), update(), loo(), ppc_field() and checkpoints work; emulator_cv() refuses", {
  field <- fn_field(n = 10, seed = 5)
  dir <- withr::local_tempdir()
  args <- c(list(fn_model, field, discrepancy = "none", nMCMC = 300, nBurn = 100, nChains = 2,
                 checkpoint = dir), fn_kappa)
  set.seed(7)
  fit <- do.call(calibrate, args)
  out <- capture.output(print(fit))
  expect_match(out[2], "the simulator a function")
  expect_true(any(grepl("theta (prior 0 to 3)", out, fixed = TRUE)))
  expect_true(any(grepl("simulator: the simulator is a function", out, fixed = TRUE)))
  expect_s3_class(plot(fit), "ggplot")
  expect_s3_class(plot(fit, type = "fits"), "ggplot")
  # the same call returns the finished run from its checkpoint
  again <- suppressMessages(do.call(calibrate, args))
  expect_identical(again$Phi, fit$Phi)
  # another function is another run
  other <- function(x, kappa) sin(kappa[["theta"]] * x$x) + x$x + 0
  expect_error(suppressMessages(do.call(calibrate, c(list(other), args[-1]))), "checkpoint")
  up <- update(fit, nMCMC = 100)
  expect_identical(nrow(up$Phi), nrow(fit$Phi) + 100L)
  lo <- loo::loo(fit)
  expect_identical(dim(lo$pointwise)[1], nrow(field))
  pp <- ppc_field(fit, ndraws = 100)
  expect_s3_class(pp, "fbc_ppc")
  expect_snapshot(error = TRUE, emulator_cv(fit))
})

test_that("a matrix field gives f a matrix; converge runs until its rule; output needs a data frame", {
  field <- as.matrix(fn_field(n = 8))
  seen <- NULL
  f <- function(x, kappa) {
    seen <<- x
    sin(kappa[["theta"]] * x[, "x"]) + x[, "x"]
  }
  set.seed(8)
  fit <- do.call(calibrate, c(list(f, field, discrepancy = "none", nChains = 2,
                                   converge = until_converged(rhat = 1.05, ess = 100)), fn_kappa))
  expect_true(is.matrix(seen))
  expect_identical(colnames(seen), "x")
  cv <- fit$settings$converge
  expect_true(cv$converged)
  expect_true(all(fit$estimates[, "rhat"] < 1.05))
  expect_true(all(fit$estimates[, "ess"] >= 100))
  # predict() hands f the new inputs the same way
  pr <- predict(fit, c(1, 2), type = "simulator", method = "MAP")
  expect_identical(dim(seen), c(2L, 1L))
  expect_snapshot(error = TRUE, do.call(calibrate, c(list(f, field, output = "o", discrepancy = "none",
                                                          fit = FALSE), fn_kappa)))
})

test_that("several outputs (output, no discrepancy): f sees the output column; log-likelihood, predict() against plain R", {
  # two outputs of one theta in long format, each with its own noise sd
  set.seed(11)
  x <- rep(seq(0, 5, length.out = 8), 2)
  o <- factor(rep(c("level", "slope"), each = 8))
  g <- function(x, theta, o) ifelse(o == "level", sin(theta * x) + x, 2 * cos(theta * x))
  field <- data.frame(y = g(x, 1.2, o) + stats::rnorm(16, 0, ifelse(o == "level", 0.2, 0.4)),
                      x = x, out = o)
  seen <- NULL
  f <- function(x, kappa) {
    seen <<- x
    ifelse(x$out == "level", sin(kappa[["theta"]] * x$x) + x$x, 2 * cos(kappa[["theta"]] * x$x))
  }
  model <- do.call(calibrate, c(list(f, field, output = "out", discrepancy = "none", fit = FALSE),
                                fn_kappa))
  expect_identical(names(seen), c("x", "out"))
  expect_identical(seen$out, o)
  expect_identical(model$spec$vars, c("kappa1", "sigma2E1", "sigma2E2"))
  expect_identical(model$scale$noiseLabels, c("level", "slope"))
  # plain R: each output standardised on its own, by the mean of f at the
  # prior's centre (theta = 1.5) and the sd of its field response; a noise
  # variance each; phi = (theta / 3, sigma2E1, sigma2E2)
  ym <- tapply(g(x, 1.5, o), o, mean)
  ys <- tapply(field$y, o, stats::sd)
  ref_ll <- function(phi) {
    sum(stats::dnorm((field$y - ym[o]) / ys[o], (g(x, 3 * phi[1], o) - ym[o]) / ys[o],
                     sqrt(phi[2:3][o]), log = TRUE))
  }
  phis <- cbind(c(0.2, 0.4, 0.7), c(0.3, 0.1, 1), c(0.5, 2, 0.05))
  d <- model$data
  got <- apply(phis, 1, function(phi) FBC:::.fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6,
                                                         model = model$spec$model))
  expect_equal(got, apply(phis, 1, ref_ll), tolerance = 1e-8)
  set.seed(12)
  fit <- do.call(calibrate, c(list(f, field, output = "out", discrepancy = "none", nChains = 2,
                                   nMCMC = 600, nBurn = 200, showProgress = FALSE), fn_kappa))
  expect_lt(abs(stats::median(fit$Phi[, "kappa1"]) - 1.2), 0.1)
  # type = "simulator" is f itself (no emulator), per output in native units
  new <- data.frame(x = c(0.5, 2.5, 4), out = c("slope", "level", "slope"))
  pr <- predict(fit, new, type = "simulator", method = "MAP")
  th <- fit$Phi[which.max(fit$logPost), "kappa1"]
  expect_equal(pr$pred, g(new$x, th, new$out), tolerance = 1e-10)
  expect_identical(as.character(seen$out), new$out)
  expect_snapshot(error = TRUE, do.call(calibrate, c(list(f, field, output = "out", fit = FALSE),
                                                     fn_kappa)))
})

test_that("several field data sets (source): a noise variance each, one shared bias", {
  a <- fn_field(n = 8, seed = 1, sd = 0.1)
  b <- fn_field(n = 6, seed = 2, sd = 0.5)
  field <- rbind(cbind(a, lab = "A"), cbind(b, lab = "B"))
  seen <- NULL
  f <- function(x, kappa) {
    seen <<- x
    fn_model(x, kappa)
  }
  model <- do.call(calibrate, c(list(f, field, source = "lab", fit = FALSE), fn_kappa))
  expect_identical(names(seen), "x")  # the data set is not an input of f
  expect_identical(model$design$noise, rep(1:2, c(8L, 6L)))
  expect_true(all(c("sigma2E1", "sigma2E2") %in% model$spec$vars))
  d <- model$data
  vars <- model$spec$vars
  set.seed(5)
  phis <- t(replicate(4, {
    x <- model$spec$init
    x[vars == "kappa1"] <- stats::runif(1, 0.2, 0.8)
    x[vars %in% c("sigma2E1", "sigma2E2")] <- stats::runif(2, 0.01, 0.5)
    x[vars == "thetaB1"] <- stats::runif(1, 0.5, 8)
    x
  }))
  ref <- unname(apply(phis, 1, function(phi) fn_dense_loglik(model, phi, fn_model)))
  path <- FBC:::.loglik_path(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, decoys = TRUE,
                             model = model$spec$model)
  expect_equal(path, ref, tolerance = 1e-8)
  set.seed(10)
  fit <- calibrate(model, nMCMC = 400, nBurn = 200, nChains = 2)
  # a new observation of data set B has B's noise
  pA <- predict(fit, data.frame(x = 2, lab = "A"), type = "field", method = "MAP")
  pB <- predict(fit, data.frame(x = 2, lab = "B"), type = "field", method = "MAP")
  map <- fit$Phi[which.max(fit$logPost), ]
  expect_equal(pB$se^2 - pA$se^2, fit$model$scale$ysd^2 * (map[["sigma2E2"]] - map[["sigma2E1"]]),
               tolerance = 1e-8)
  expect_snapshot(error = TRUE, calibrate(f, field, source = "lab", sourceBias = "own",
                                          kappaDist = "uniform", kappaP1 = c(theta = 0),
                                          kappaP2 = 3, fit = FALSE))
})

test_that("chains on parallel workers call f there and give the sequential draws", {
  skip_on_cran()
  f <- function(x, kappa) 5 * exp(-kappa[["u"]] * x$t)
  args <- list(f, as.data.frame(kineticField), kappaDist = "uniform", kappaP1 = c(u = 0.5),
               kappaP2 = c(u = 3), nMCMC = 400, nBurn = 200, nChains = 2, discrepancy = "none")
  set.seed(9)
  a <- do.call(calibrate, args)
  old <- future::plan(future::multisession, workers = 2)
  on.exit(future::plan(old), add = TRUE)
  set.seed(9)
  b <- do.call(calibrate, args)
  expect_identical(b$Phi, a$Phi)
})
