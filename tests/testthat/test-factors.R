# Categorical inputs, several outputs and several field data sets
# (R/factors.R): the categorical correlation against its plain-R formula,
# the likelihood with per-group measurement error against the dense one
# (dense and Kronecker algebras), kappa's grid posterior with two outputs,
# recovery from two outputs, refusals.

test_that("a categorical input's level correlation is the plain-R one from its partial correlations", {
  set.seed(2)
  sim <- data.frame(y = rnorm(30), mat = rep(c("a", "b", "c"), 10), x = runif(30), t = runif(30))
  field <- data.frame(y = rnorm(6), mat = rep(c("a", "b", "c"), 2), x = runif(6))
  fac <- FBC:::read_factors(sim, field)
  expect_identical(names(fac$sim), c("y", "mat[a]", "mat[b]", "mat[c]", "x", "t"))
  expect_identical(fac$factors$mat$levels, c("a", "b", "c"))
  expect_identical(unname(as.matrix(fac$sim[1:3, 2:4])), diag(3))
  # two levels: one indicator, and the correlation is the one rho itself
  two <- FBC:::read_factors(sim[sim$mat != "c", ], field[field$mat != "c", ])
  expect_identical(two$factors$mat$columns, "mat[b]")
  expect_equal(FBC:::.level_corr(2L, -0.6)[[1]], matrix(c(1, -0.6, -0.6, 1), 2), tolerance = 1e-15)
  # three levels, closed form: C12 = z1, C13 = z2,
  # C23 = z1 z2 + z3 sqrt((1 - z1^2)(1 - z2^2))
  z <- c(0.5, -0.3, 0.8)
  C <- FBC:::.level_corr(3L, z)[[1]]
  expect_equal(C[2, 3], 0.5 * -0.3 + 0.8 * sqrt((1 - 0.25) * (1 - 0.09)), tolerance = 1e-14)
  # 2 to 6 levels against the C-vine recursion (helper-dense.R), each
  # positive definite with a unit diagonal; two inputs at once
  for (L in 2:6) {
    z <- runif(L * (L - 1) / 2, -0.95, 0.95)
    C <- FBC:::.level_corr(L, z)[[1]]
    expect_equal(C, level_corr_plain(L, z), tolerance = 1e-12)
    expect_gt(min(eigen(C, symmetric = TRUE, only.values = TRUE)$values), 0)
    expect_identical(diag(C), rep(1, L))
  }
  z <- runif(1 + 6, -0.9, 0.9)
  both <- FBC:::.level_corr(c(2L, 4L), z)
  expect_equal(both[[2]], level_corr_plain(4, z[-1]), tolerance = 1e-12)
  expect_error(FBC:::.level_corr(3L, c(0.1, 0.2)), "the levels need 3")
  # level_correlation() of a fit with rhoS fixed is that matrix; the
  # indicators' theta and alpha are held (0 and 2) and are not in Phi
  hyp <- set_hyperPriors(rhoSDist = "fixed", rhoSInit = c(0.5, -0.3, 0.8))
  # (the power exponential: the layout below has the smoothness columns)
  fit <- suppressWarnings(calibrate(sim, field, nMCMC = 20, nBurn = 10, nChains = 1, hypers = hyp,
                                    kernelS = "powexp", kernelB = "powexp"))
  expect_equal(unname(level_correlation(fit, "mat")), level_corr_plain(3, c(0.5, -0.3, 0.8)),
               tolerance = 1e-12)
  expect_identical(rownames(level_correlation(fit, "mat")), c("a", "b", "c"))
  expect_output(print(fit), "level correlation rhoS1 \\(b~a\\), rhoS2 \\(c~a\\), rhoS3 \\(c~b \\| a\\)")
  # each input's partial correlations among the class's: 1 for two levels,
  # 3 for three, 6 for four, in the inputs' order
  two3 <- list(list(levels = c("a", "b")), list(levels = c("a", "b", "c")),
               list(levels = c("a", "b", "c", "d")))
  expect_identical(FBC:::level_positions(two3), list(1L, 2:4, 5:10))
  expect_identical(colnames(fit$Phi), c("kappa1", "thetaS4", "thetaS5", "alphaS4", "alphaS5",
                                        "rhoS1", "rhoS2", "rhoS3", "thetaB4", "alphaB4",
                                        "rhoB1", "rhoB2", "rhoB3", "sigma2S", "sigma2B",
                                        "sigma2E", "muB"))
  held <- FBC:::sampler_draws(fit)[, FBC:::indicator_positions(fit$model$spec$model)]
  expect_true(all(held == rep(c(0, 2, 0, 2), each = 3 * nrow(fit$Phi))))
  expect_true(all(abs(fit$Phi[, "rhoB2"]) < 1))
})

# Scaled data with a numeric experimental input x, a 3-level categorical
# input (indicators in columns 2-4) and one calibration input; the levels
# as compiled_model() takes them. `product`: every (x, level) at every t.
level_data <- function(seed, product = FALSE) {
  set.seed(seed)
  lev <- list(col = 2L, ncol = 3L, L = 3L)
  if (product) {
    g <- expand.grid(x = seq(0, 1, length.out = 4), l = 1:3, t = seq(0, 1, length.out = 5))
    Xs <- cbind(g$x, diag(3)[g$l, ], g$t)
  } else {
    Xs <- cbind(runif(24), diag(3)[rep(1:3, 8), ], runif(24))
  }
  Xf <- cbind(runif(7), diag(3)[c(1, 2, 3, 1, 2, 3, 2), ])
  list(Xf = Xf, yf = rnorm(7), Xs = Xs, ys = rnorm(nrow(Xs)), lev = lev)
}

test_that("with categorical inputs the likelihood, moves and predictions equal the plain-R ones", {
  for (disc in c("gp", "sgasp", "none")) for (product in c(FALSE, TRUE)) {
    d <- level_data(30 + product, product)
    p <- 4; q <- 1
    kron <- FBC:::compiled_model(p, q, discrepancy = disc, levels = d$lev)
    dense <- FBC:::compiled_model(p, q, algebra = 1L, discrepancy = disc, levels = d$lev)
    # the product design the compiled core finds (Kronecker) or none (dense)
    expect_identical(length(FBC:::.sim_algebra(d$Xs, p, kron$algebra)), if (product) 2L else 0L)
    idx <- FBC:::param_indices(p, q, disc, 1L, 3L)
    phis <- t(replicate(2, random_phi(p, q, disc, nLev = 3L)))
    # the indicators' theta as calibrate() holds them (0), or not: on the
    # product design the Kronecker algebra splits Rx into the level tuples'
    # and the numeric settings' factors, exact for any theta (separability)
    if (!product) {
      phis[, idx$thetaS[2:4]] <- 0
      if (disc != "none") phis[, idx$thetaB[2:4]] <- 0
    }
    # moves of the levels' partial correlations alone (the caches they touch)
    step <- phis[c(2, 2), ]
    step[1, idx$rhoS] <- c(-0.7, 0.2, 0.5)
    if (disc != "none") step[2, idx$rhoB] <- c(0.6, -0.4, -0.1)
    phis <- rbind(phis, step)
    ref <- apply(phis, 1, function(phi) {
      dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6, discrepancy = disc, levels = d$lev)
    })
    for (model in list(kron, dense)) {
      expect_equal(apply(phis, 1, function(phi) {
        .fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6, model = model)
      }), ref, tolerance = 1e-8)
      expect_equal(.loglik_path(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, decoys = TRUE, model = model),
                   ref, tolerance = 1e-8)
      Xn <- cbind(c(0.2, 0.7, 0.4), diag(3)[c(3, 1, 2), ])
      for (type in 1:4) {
        got <- .fbc_predict(d$Xf, d$yf, d$Xs, d$ys, phis[1:2, ], Xn, type, 1e-6, 2L, model = model)
        for (i in 1:2) {
          want <- dense_predict(d$Xf, d$yf, d$Xs, d$ys, phis[i, ], Xn,
                                c("field", "mean", "simulator", "bias")[type],
                                discrepancy = disc, levels = d$lev)
          expect_equal(got$mean[, i], want$mean, tolerance = 1e-8)
          expect_equal(got$var[, i], want$var, tolerance = 1e-8)
        }
      }
    }
  }
  # the Vecchia algebra with every run a neighbour is exact
  d <- level_data(33)
  des <- FBC:::vecchia_design(d$Xs, d$ys, 1L, nrow(d$Xs), nrow(d$Xs))
  vec <- FBC:::compiled_model(4, 1, algebra = 2L, vecchia = des, levels = d$lev)
  phi <- random_phi(4, 1, nLev = 3L)
  expect_equal(.fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6, model = vec),
               dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6, levels = d$lev), tolerance = 1e-8)
  Xn <- cbind(c(0.2, 0.7), diag(3)[c(3, 1), ])
  got <- .fbc_predict(d$Xf, d$yf, d$Xs, d$ys, rbind(phi), Xn, 2L, 1e-6, 2L, model = vec)
  want <- dense_predict(d$Xf, d$yf, d$Xs, d$ys, phi, Xn, "mean", levels = d$lev)
  expect_equal(got$mean[, 1], want$mean, tolerance = 1e-8)
  expect_equal(got$var[, 1], want$var, tolerance = 1e-8)
})

test_that("with per-group measurement error the likelihood and its moves equal the dense one", {
  for (s in list(c(p = 2, q = 1), c(p = 3, q = 2))) {
    p <- s[["p"]]; q <- s[["q"]]
    d <- random_koh_data(9, 20, p, q, seed = 60 + p)
    d$Xs[, 1] <- rep(0:1, 10)   # an indicator input
    d$Xf[, 1] <- rep(0:1, length.out = 9)
    noise <- c(1L, 2L, 3L, 1L, 2L, 3L, 1L, 2L, 3L)
    model <- FBC:::compiled_model(p, q, noise = noise)
    expect_identical(unname(model$length[["sigma2E"]]), 3L)
    phis <- rbind(random_phi(p, q, G = 3L), random_phi(p, q, G = 3L))
    dense <- function(phi) dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6, noise = noise)
    for (i in 1:2) {
      expect_equal(.fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phis[i, ], 1e-6, model = model),
                   dense(phis[i, ]), tolerance = 1e-8)
    }
    path <- .loglik_path(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, decoys = TRUE, model = model)
    expect_equal(path, apply(phis, 1, dense), tolerance = 1e-8)
    # the scale move multiplies every sigma2E with sigma2S and sigma2B
    expect_joint_moves_dense(d, phis, p, q, noise = noise)
    # field predictions add the new point's group's sigma2E
    Xn <- d$Xf[1:3, , drop = FALSE]
    got <- .fbc_predict(d$Xf, d$yf, d$Xs, d$ys, phis, Xn, 1L, 1e-6, 2L, model = model,
                        noise = c(3L, 1L, 2L))
    for (i in 1:2) {
      ref <- dense_predict(d$Xf, d$yf, d$Xs, d$ys, phis[i, ], Xn, "field", noise = noise,
                           noiseNew = c(3L, 1L, 2L))
      expect_equal(got$mean[, i], ref$mean, tolerance = 1e-8)
      expect_equal(got$var[, i], ref$var, tolerance = 1e-8)
    }
  }
})

test_that("outputs on a product design: the Kronecker likelihood equals the dense one", {
  # every run gives both outputs at the same 6 x values: (x, output) x t
  set.seed(7)
  xg <- seq(0, 1, length.out = 6); tg <- seq(0, 1, length.out = 7)
  grid <- expand.grid(x = xg, o = 0:1, t = tg)
  Xs <- as.matrix(grid)
  ys <- rnorm(nrow(Xs))
  Xf <- cbind(x = runif(6), o = rep(0:1, 3))
  yf <- rnorm(6)
  noise <- rep(1:2, 3)
  kron <- FBC:::compiled_model(2, 1, noise = noise)
  dense <- FBC:::compiled_model(2, 1, algebra = 1L, noise = noise)
  expect_length(FBC:::.sim_algebra(Xs, 2, kron$algebra), 2L)  # a product design: Kronecker
  for (r in 1:3) {
    phi <- random_phi(2, 1, G = 2L)
    ref <- dense_loglik(Xf, yf, Xs, ys, phi, 1e-6, noise = noise)
    expect_equal(.fbc_loglik(Xf, yf, Xs, ys, phi, 1e-6, model = kron), ref, tolerance = 1e-8)
    expect_equal(.fbc_loglik(Xf, yf, Xs, ys, phi, 1e-6, model = dense), ref, tolerance = 1e-8)
  }
})

test_that("two outputs: kappa draws match the grid posterior", {
  skip_if_not_slow()
  # every hyperparameter fixed; the reference is dense_loglik() with the two
  # outputs' noise groups times the Beta(1.1, 1.1) prior on the scaled kappa
  pr <- two_outputs()
  hyp <- set_hyperPriors(thetaSDist = "fixed", thetaSInit = c(0.7, 10, 0.4),
                         thetaBDist = "fixed", thetaBInit = c(1, 5), sigma2SDist = "fixed",
                         sigma2SInit = 3.5, sigma2BDist = "fixed", sigma2BInit = 0.5,
                         sigma2EDist = "fixed", sigma2EInit = 0.05, muBDist = "fixed", muBInit = 0,
                         rhoSDist = "fixed", rhoSInit = -0.3, rhoBDist = "fixed", rhoBInit = 0.2)
  set.seed(9)
  fit <- calibrate(pr$sim, pr$field, output = "out", outputs = "shared", nMCMC = 9000, nBurn = 1000, thinning = 4,
                   nChains = 1, hypers = hyp, kernelS = "matern52", kernelB = "matern52")
  expect_identical(colnames(fit$Phi)[grepl("sigma2E", colnames(fit$Phi))], c("sigma2E1", "sigma2E2"))
  d <- fit$model$data
  # kappa1 is the third scaled input (x, the output's indicator, t)
  expect_kappa_grid(fit, function(phi) {
    dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6, "matern52", "matern52",
                 noise = fit$model$spec$model$noise, levels = fit$model$spec$model$levels)
  }, u = seq(0, 1, length.out = 401), col = 3L, ksTol = NULL)
})

test_that("two outputs recover kappa with an interval narrower than either output alone", {
  skip_if_not_slow()
  pr <- two_outputs()
  args <- list(nMCMC = 2500, nBurn = 1000, nChains = 2, kernelS = "matern52",
               kernelB = "matern52")
  set.seed(10)
  both <- do.call(calibrate, c(list(pr$sim, pr$field, output = "out", outputs = "shared"), args))
  width <- function(f) diff(quantile(f$Phi[, "kappa1"], c(0.05, 0.95), names = FALSE))
  q <- quantile(both$Phi[, "kappa1"], c(0.05, 0.95), names = FALSE)
  expect_true(q[1] < pr$truth && pr$truth < q[2])
  for (o in c("conc", "rate")) {
    set.seed(10)
    one <- do.call(calibrate, c(list(pr$sim[pr$sim$out == o, -3], pr$field[pr$field$out == o, -3]),
                                args))
    expect_lt(width(both), width(one))
  }
  # predictions back in each output's units, near the truth at the field
  nd <- data.frame(x = c(0.5, 0.5), out = c("conc", "rate"))
  pm <- predict(both, nd, type = "mean", method = "MAP")
  expect_equal(pm$pred, c(5 * exp(-1.7 * 0.5), 2 * 1.7 * 0.5), tolerance = 0.05)
})

test_that("several field data sets: each its own noise; refusals name the column and level", {
  pr <- two_outputs(seed = 3)
  field <- rbind(cbind(pr$field, lab = "A"),
                 transform(pr$field[pr$field$out == "conc", ], lab = "B"))
  set.seed(11)
  # lab B repeats lab A's conc observations exactly, so the likelihood grows
  # without bound as both noises go to 0, which the default half-Cauchy noise
  # prior allows: this run's noises reach 1e-16, where the field block's
  # covariance is singular but for roundoff. The sampler refuses such
  # proposals (a pivot floor), so every draw it keeps factors from scratch
  # and predicts (before: predict() stopped at draw 54, "not positive
  # definite", and 8 draws' log-likelihoods were -Inf from scratch).
  fit <- calibrate(pr$sim, field, output = "out", outputs = "shared", source = "lab", nMCMC = 300, nBurn = 150,
                   nChains = 1, kernelS = "matern52", kernelB = "matern52")
  ll <- apply(FBC:::sampler_draws(fit), 1, function(x) FBC:::fit_loglik(fit, x))
  expect_true(all(is.finite(ll)))
  # and the sampler's log-likelihoods are the from-scratch ones (they
  # differed by up to 2.5 at the singular draws)
  expect_equal(fit$logLik, ll, tolerance = 1e-6)
  pall <- predict(fit, data.frame(x = 0.3, out = "conc", lab = "A"), type = "field")
  expect_true(all(is.finite(pall$pred)))
  expect_identical(fit$model$scale$noiseLabels, c("conc:A", "conc:B", "rate:A"))
  expect_identical(fit$model$spec$model$noise, c(rep(1L, 10), rep(3L, 10), rep(2L, 10)))
  expect_output(print(fit), "sigma2E1 = conc:A, sigma2E2 = conc:B, sigma2E3 = rate:A")
  expect_s3_class(predict(fit, data.frame(x = 0.3, out = "conc", lab = "B")), "fbc_prediction")
  expect_snapshot(error = TRUE, predict(fit, data.frame(x = 0.3, out = "conc")))
  expect_snapshot(error = TRUE, predict(fit, data.frame(x = 0.3, out = "volume", lab = "A")))
  expect_snapshot(error = TRUE, predict(fit, data.frame(x = 0.3, out = "rate", lab = "B")))
  bad <- pr$field
  bad$out[1] <- "volume"
  expect_snapshot(error = TRUE, calibrate(pr$sim, bad, output = "out"))
  expect_snapshot(error = TRUE, calibrate(pr$sim, pr$field, output = "output"))
  expect_snapshot(error = TRUE, calibrate(pr$sim, pr$field, output = "out", source = "lab"))
  cal <- pr$sim
  cal$t <- as.character(round(cal$t))
  expect_snapshot(error = TRUE, calibrate(cal, pr$field[, c("y", "x", "out")]))
  # nothing the user passed is modified
  f0 <- field
  invisible(predict(fit, data.frame(x = 0.3, out = "conc", lab = "A")))
  expect_identical(field, f0)
})

test_that("a bias per field data set: likelihood, moves and predictions equal the plain-R ones", {
  # three data sets, two of them observed at the same x (distinct for the
  # bias, the same for the simulator); the bias kernel is
  # R(x, x') C_D[s, s'] (helper-dense.R)
  for (disc in c("gp", "sgasp")) for (product in c(FALSE, TRUE)) {
    d <- level_data(40 + product, product)
    src <- list(codes = c(1L, 2L, 3L, 1L, 2L, 3L, 2L), L = 3L)
    d$Xf[2, ] <- d$Xf[1, ]   # the same inputs in data sets 1 and 2
    p <- 4; q <- 1
    idx <- FBC:::param_indices(p, q, disc, 1L, 3L, 3L)
    expect_length(idx$rhoD, 3L)
    phis <- t(replicate(2, random_phi(p, q, disc, nLev = 3L, nSrc = 3L)))
    step <- phis[2, , drop = FALSE]
    step[1, idx$rhoD] <- c(0.7, -0.2, 0.4)   # a move of rhoD alone
    phis <- rbind(phis, step)
    ref <- apply(phis, 1, function(phi) {
      dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6, discrepancy = disc, levels = d$lev,
                   source = src)
    })
    for (alg in c(0L, 1L)) {
      model <- FBC:::compiled_model(p, q, algebra = alg, discrepancy = disc, levels = d$lev,
                                    source = src)
      expect_equal(.loglik_path(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, decoys = TRUE, model = model),
                   ref, tolerance = 1e-8)
      Xn <- cbind(c(0.2, 0.7, 0.4), diag(3)[c(3, 1, 2), ])
      for (type in c(1L, 2L, 4L)) {
        got <- .fbc_predict(d$Xf, d$yf, d$Xs, d$ys, phis[1:2, ], Xn, type, 1e-6, 2L,
                            model = model, source = c(2L, 3L, 1L))
        for (i in 1:2) {
          want <- dense_predict(d$Xf, d$yf, d$Xs, d$ys, phis[i, ], Xn,
                                c("field", "mean", "simulator", "bias")[type], discrepancy = disc,
                                levels = d$lev, source = src, sourceNew = c(2L, 3L, 1L))
          expect_equal(got$mean[, i], want$mean, tolerance = 1e-8)
          expect_equal(got$var[, i], want$var, tolerance = 1e-8)
        }
      }
      expect_error(.fbc_predict(d$Xf, d$yf, d$Xs, d$ys, phis[1:2, ], Xn, 2L, 1e-6, 2L,
                                model = model), "needs its field data set")
    }
  }
  # with rhoD at 1 the biases coincide: the likelihood is the shared bias's
  d <- level_data(42)
  src <- list(codes = c(1L, 2L, 1L, 2L, 1L, 2L, 2L), L = 2L)
  phi <- random_phi(4, 1, nLev = 3L, nSrc = 1L)
  idx <- FBC:::param_indices(4, 1, "gp", 1L, 3L, 1L)
  phi[idx$rhoD] <- 1
  own <- FBC:::compiled_model(4, 1, levels = d$lev, source = src)
  shared <- FBC:::compiled_model(4, 1, levels = d$lev)
  expect_equal(.fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6, model = own),
               .fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phi[-idx$rhoD], 1e-6, model = shared),
               tolerance = 1e-8)
})

test_that("sourceBias = \"own\": a fit, its predictions and its refusals", {
  pr <- two_outputs(seed = 3)
  field <- rbind(cbind(pr$field, lab = "A"),
                 transform(pr$field[pr$field$out == "conc", ], y = y + 0.3, lab = "B"))
  set.seed(12)
  fit <- calibrate(pr$sim, field, output = "out", outputs = "shared", source = "lab", sourceBias = "own",
                   nMCMC = 300, nBurn = 150, nChains = 1, kernelS = "matern52",
                   kernelB = "matern52")
  expect_true("rhoD1" %in% colnames(fit$Phi))
  expect_true(all(abs(fit$Phi[, "rhoD1"]) < 1))
  expect_identical(fit$model$spec$model$source, c(rep(1L, 20), rep(2L, 10)))
  expect_output(print(fit), "a bias each, correlated by rhoD1 \\(B~A\\)")
  expect_output(print(fit), "categorical input out: levels conc, rate; level correlation rhoS1 \\(rate~conc\\)")
  C <- level_correlation(fit, "lab", "bias")
  expect_equal(C[1, 2], mean(fit$Phi[, "rhoD1"]), tolerance = 1e-12)
  # the same inputs predict differently in the two data sets
  nd <- data.frame(x = c(0.3, 0.3), out = "conc", lab = c("A", "B"))
  pb <- predict(fit, nd, type = "bias")
  expect_false(isTRUE(all.equal(pb$pred[1], pb$pred[2])))
  ps <- predict(fit, nd, type = "simulator")
  expect_equal(ps$pred[1], ps$pred[2])
  expect_silent(predict(fit, data.frame(x = 0.3, out = "conc"), type = "simulator"))
  expect_snapshot(error = TRUE, predict(fit, data.frame(x = 0.3, out = "conc"), type = "mean"))
  expect_snapshot(error = TRUE, calibrate(pr$sim, pr$field, output = "out", sourceBias = "own"))
  expect_snapshot(error = TRUE, calibrate(pr$sim, field, output = "out", source = "lab",
                                          sourceBias = "own", discrepancy = "none"))
  pp <- ppc_field(fit, ndraws = 5)
  expect_equal(dim(pp$yrep), c(5L, 30L))
})

test_that("a missing level in the source, output or a categorical column is refused naming rows", {
  # An NA became a data set "NA" with its own noise, or a level
  # the simulator runs do not have
  pr <- two_outputs(seed = 3)
  field <- cbind(pr$field, lab = rep(c("A", "B"), length.out = nrow(pr$field)))
  bad <- field
  bad$lab[c(2, 5)] <- NA
  expect_snapshot(error = TRUE, calibrate(pr$sim, bad, output = "out", source = "lab"))
  bad <- field
  bad$out[3] <- NA
  expect_snapshot(error = TRUE, calibrate(pr$sim, bad, output = "out", source = "lab"))
  badS <- pr$sim
  badS$out[c(1, 2, 4)] <- ""
  expect_snapshot(error = TRUE, calibrate(badS, pr$field, output = "out"))
  # a factor with an NA in a categorical input that is not the output
  badF <- pr$field
  badF$out <- factor(badF$out)
  badF$out[1:12] <- NA
  expect_snapshot(error = TRUE, calibrate(pr$sim, badF))
})

test_that("a level correlation at +-1 is explained, and a split one is flagged by level_correlation()", {
  # rhoS piling at +1 was answered with "check that this prior's
  # support is wide enough"; draws split between +1 and -1 were averaged
  pr <- two_outputs(seed = 3)
  set.seed(12)
  fit <- calibrate(pr$sim, pr$field, output = "out", outputs = "shared", nMCMC = 200, nBurn = 100, nChains = 1,
                   kernelS = "matern52", kernelB = "matern52")
  n <- nrow(fit$Phi)
  up <- fit
  up$Phi[, "rhoS1"] <- 0.999
  msgs <- convergence_messages(up)
  expect_snapshot(cat(grep("rhoS1 lie at", msgs, value = TRUE), sep = "\n"))
  down <- fit
  down$Phi[, "rhoB1"] <- -0.999
  expect_snapshot(cat(grep("rhoB1 lie at", convergence_messages(down), value = TRUE), sep = "\n"))
  expect_false(any(grepl("support is wide enough", c(msgs, convergence_messages(down)))))
  # split draws: 40% at +0.95, 60% at -0.95; the average is 0.4 * 0.95 - 0.6 * 0.95
  split <- fit
  split$Phi[, "rhoS1"] <- rep(c(0.95, -0.95), c(round(0.4 * n), n - round(0.4 * n)))
  expect_snapshot(C <- level_correlation(split, "out"))
  expect_equal(C["conc", "rate"], mean(split$Phi[, "rhoS1"]))
  expect_no_warning(level_correlation(fit, "out"))
})

test_that("messages name the output that is constant, and the field data sets' column for what it is", {
  # "constant for an output" did not say which; a field-only
  # column named by `output =`, and the data sets' column under a shared
  # bias in level_correlation() ("no categorical input"), were not explained
  pr <- two_outputs(seed = 3)
  flat <- pr$sim
  flat$y[flat$out == "rate"] <- 2
  expect_snapshot(error = TRUE, calibrate(flat, pr$field, output = "out"))
  near <- pr$sim
  near$y[near$out == "rate"] <- 1e9 + 1e-6 * seq_len(sum(near$out == "rate"))
  expect_snapshot(FBC:::fbc_scale(as.matrix(cbind(y = near$y, x = near$x, t = near$t)), 1,
                                  out = structure(match(near$out, c("conc", "rate")),
                                                  labels = c("conc", "rate")))$ysd > 0)
  field <- cbind(pr$field, lab = rep(c("A", "B"), length.out = nrow(pr$field)))
  expect_snapshot(error = TRUE, calibrate(pr$sim, field, output = "lab"))
  set.seed(1)
  fit <- calibrate(pr$sim, field, output = "out", outputs = "shared", source = "lab", nMCMC = 60, nBurn = 30,
                   nChains = 1)
  expect_snapshot(error = TRUE, level_correlation(fit, "lab", gp = "bias"))
  ball <- data.frame(ballField, lab = rep(c("A", "B"), length.out = nrow(ballField)))
  fit2 <- calibrate(ballSim, ball, source = "lab", nMCMC = 60, nBurn = 30, nChains = 1)
  expect_snapshot(error = TRUE, level_correlation(fit2, "lab", gp = "bias"))
})

test_that("a categorical column of field alone is not called a column of sim", {
  # "... that `sim` has not as categorical" for a column sim lacks
  pr <- two_outputs(seed = 3)
  field <- cbind(pr$field, lab = "A", site = "north")
  expect_snapshot(error = TRUE, calibrate(pr$sim, field, output = "out"))
  expect_snapshot(error = TRUE, calibrate(pr$sim, field, output = "out", source = "lab"))
})
