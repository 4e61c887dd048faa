# Categorical inputs, several outputs and several field data sets
# (R/factors.R): the categorical correlation against its plain-R formula,
# the likelihood with per-group measurement error against the dense one
# (dense and Kronecker algebras), kappa's grid posterior with two outputs,
# recovery from two outputs, refusals.

# A two-output simulator sharing a rate t: a decay and a linear response.
two_outputs <- function(seed = 1, m = 40, noise = 0.05) {
  set.seed(seed)
  x <- runif(m); t <- runif(m, 0.5, 3)
  f1 <- function(x, t) 5 * exp(-t * x)
  f2 <- function(x, t) 2 * t * x
  sim <- rbind(data.frame(y = f1(x, t), x = x, out = "conc", t = t),
               data.frame(y = f2(x, t), x = x, out = "rate", t = t))
  xf <- seq(0.05, 0.95, length.out = 10)
  field <- rbind(data.frame(y = f1(xf, 1.7) + rnorm(10, 0, noise), x = xf, out = "conc"),
                 data.frame(y = f2(xf, 1.7) + rnorm(10, 0, noise), x = xf, out = "rate"))
  list(sim = sim, field = field, truth = 1.7)
}

test_that("a categorical input's correlation between levels is the plain-R product of per-level factors", {
  # three levels: indicator columns [a], [b], [c]; two levels a != b are
  # correlated by r(1; theta_a) r(1; theta_b) (r of the family, ?correlation)
  set.seed(2)
  sim <- data.frame(y = rnorm(30), mat = rep(c("a", "b", "c"), 10), x = runif(30), t = runif(30))
  field <- data.frame(y = rnorm(6), mat = rep(c("a", "b", "c"), 2), x = runif(6))
  fac <- FBC:::read_factors(sim, field)
  expect_identical(names(fac$sim), c("y", "mat[a]", "mat[b]", "mat[c]", "x", "t"))
  expect_identical(fac$factors$mat$levels, c("a", "b", "c"))
  expect_identical(unname(as.matrix(fac$sim[1:3, 2:4])), diag(3))
  ind <- diag(3)
  th <- c(0.3, 1.1, 2.0)
  r1 <- list(gaussian = function(t) exp(-t), powexp = function(t) exp(-t),
             matern32 = function(t) (1 + sqrt(3 * t)) * exp(-sqrt(3 * t)),
             matern52 = function(t) (1 + sqrt(5 * t) + 5 * t / 3) * exp(-sqrt(5 * t)))
  for (k in names(r1)) {
    R <- FBC:::.corr_matrix(ind, ind, th, rep(2, 3), kernel_code(k))
    ref <- outer(r1[[k]](th), r1[[k]](th))
    diag(ref) <- 1
    expect_equal(R, ref, tolerance = 1e-12)
  }
  # two levels: one indicator, one exchangeable correlation r(1; theta)
  two <- FBC:::read_factors(sim[sim$mat != "c", ], field[field$mat != "c", ])
  expect_identical(two$factors$mat$columns, "mat[b]")
  # level_correlation() of a fit with every parameter fixed is that matrix
  hyp <- set_hyperPriors(thetaSDist = "fixed", thetaSInit = c(th, 1, 1), thetaBDist = "fixed",
                         thetaBInit = c(1, 1, 1, 1), sigma2SDist = "fixed", sigma2SInit = 1,
                         sigma2BDist = "fixed", sigma2BInit = 0.1, sigma2EDist = "fixed",
                         sigma2EInit = 0.1, muBDist = "fixed", muBInit = 0)
  fit <- suppressWarnings(calibrate(sim, field, nMCMC = 20, nBurn = 10, nChains = 1,
                                    hypers = hyp, kernelS = "matern52", kernelB = "matern52"))
  ref <- outer(r1$matern52(th), r1$matern52(th)); diag(ref) <- 1
  expect_equal(unname(level_correlation(fit, "mat")), ref, tolerance = 1e-12)
  expect_identical(rownames(level_correlation(fit, "mat")), c("a", "b", "c"))
  # indicator smoothness is not sampled (alpha means nothing on {0, 1})
  fit <- suppressWarnings(calibrate(sim, field, nMCMC = 20, nBurn = 10, nChains = 1))
  expect_true(all(fit$Phi[, c("alphaS1", "alphaS2", "alphaS3", "alphaB1", "alphaB2", "alphaB3")] == 2))
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
  expect_identical(FBC:::sim_algebra_info(list(Xs = Xs), 2, kron)$name, "Kronecker")
  for (r in 1:3) {
    phi <- random_phi(2, 1, G = 2L)
    ref <- dense_loglik(Xf, yf, Xs, ys, phi, 1e-6, noise = noise)
    expect_equal(.fbc_loglik(Xf, yf, Xs, ys, phi, 1e-6, model = kron), ref, tolerance = 1e-8)
    expect_equal(.fbc_loglik(Xf, yf, Xs, ys, phi, 1e-6, model = dense), ref, tolerance = 1e-8)
  }
})

test_that("two outputs: kappa draws match the grid posterior", {
  # every hyperparameter fixed; the reference is dense_loglik() with the two
  # outputs' noise groups times the Beta(1.1, 1.1) prior on the scaled kappa
  pr <- two_outputs()
  hyp <- set_hyperPriors(thetaSDist = "fixed", thetaSInit = c(0.7, 10, 0.4),
                         thetaBDist = "fixed", thetaBInit = c(1, 5), sigma2SDist = "fixed",
                         sigma2SInit = 3.5, sigma2BDist = "fixed", sigma2BInit = 0.5,
                         sigma2EDist = "fixed", sigma2EInit = 0.05, muBDist = "fixed", muBInit = 0)
  set.seed(9)
  fit <- calibrate(pr$sim, pr$field, output = "out", nMCMC = 9000, nBurn = 1000, thinning = 4,
                   nChains = 1, hypers = hyp, kernelS = "matern52", kernelB = "matern52")
  expect_identical(colnames(fit$Phi)[grepl("sigma2E", colnames(fit$Phi))], c("sigma2E1", "sigma2E2"))
  d <- fit$data
  # kappa1 is the third scaled input (x, the output's indicator, t)
  expect_kappa_grid(fit, function(phi) {
    dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6, "matern52", "matern52",
                 noise = fit$spec$model$noise)
  }, u = seq(0, 1, length.out = 401), col = 3L, ksTol = NULL)
})

test_that("two outputs recover kappa with an interval narrower than either output alone", {
  pr <- two_outputs()
  args <- list(nMCMC = 2500, nBurn = 1000, nChains = 2, kernelS = "matern52",
               kernelB = "matern52")
  set.seed(10)
  both <- do.call(calibrate, c(list(pr$sim, pr$field, output = "out"), args))
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
  fit <- calibrate(pr$sim, field, output = "out", source = "lab", nMCMC = 300, nBurn = 150,
                   nChains = 1, kernelS = "matern52", kernelB = "matern52")
  expect_identical(fit$scale$noiseLabels, c("conc:A", "conc:B", "rate:A"))
  expect_identical(fit$spec$model$noise, c(rep(1L, 10), rep(3L, 10), rep(2L, 10)))
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
