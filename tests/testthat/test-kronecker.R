# The Kronecker algebra (src/kronecker.cpp) on product designs against the
# plain-R dense likelihood and GP conditional of helper-dense.R and
# helper-predict.R (one dense Cholesky / solve of the full covariance), and
# against the compiled dense algebra; the dense algebra's on-the-fly path
# against its cached path.

# A product design: every combination of I experimental settings (p
# inputs) and J calibration settings (q inputs), rows shuffled, with a
# random response and n field points off the grid.
product_data <- function(I, J, p, q, n, seed) {
  set.seed(seed)
  Xg <- matrix(runif(I * p), I, p)
  Tg <- matrix(runif(J * q), J, q)
  g <- expand.grid(i = seq_len(I), j = seq_len(J))
  g <- g[sample(nrow(g)), ]
  Xs <- cbind(Xg[g$i, , drop = FALSE], Tg[g$j, , drop = FALSE])
  list(Xf = matrix(runif(n * p), n, p), yf = rnorm(n), Xs = unname(Xs), ys = rnorm(nrow(Xs)))
}

designs <- list(c(I = 6, J = 5, p = 1, q = 1), c(I = 5, J = 7, p = 2, q = 1),
                c(I = 7, J = 5, p = 1, q = 2), c(I = 5, J = 6, p = 2, q = 2))

test_that("product designs are recognised in any row order, and only they", {
  d <- product_data(6, 5, 2, 2, 4, seed = 1)
  expect_identical(.sim_algebra(d$Xs, 2L), c(6L, 5L))
  expect_identical(.sim_algebra(d$Xs[rev(seq_len(30)), ], 2L), c(6L, 5L))
  expect_identical(.sim_algebra(d$Xs, 2L, 1L), integer(0))  # algebra = "dense"
  # one run missing: a missing cell; one input nudged: a 7th setting of
  # one run, 5 cells missing (test-kronecker-missing.R); one run twice: no
  # product
  expect_identical(.sim_algebra(d$Xs[-7, ], 2L), structure(c(6L, 5L), missing = 1L))
  expect_identical(.sim_algebra(d$Xs[c(1:29, 1), ], 2L), integer(0))
  nudged <- d$Xs
  nudged[3, 1] <- nudged[3, 1] + 1e-12
  expect_identical(.sim_algebra(nudged, 2L), structure(c(7L, 5L), missing = 5L))
  # the split between experimental and calibration columns matters: the
  # first three columns do not take 6 values against 5 of the last
  expect_identical(.sim_algebra(d$Xs, 3L), integer(0))
  # too small to pay (3 x 3: two eigendecompositions cost more than one
  # Cholesky factor of the 9 x 9 block), and a scattered design
  e <- product_data(3, 3, 1, 1, 4, seed = 2)
  expect_identical(.sim_algebra(e$Xs, 1L), integer(0))
  r <- random_koh_data(5, 30, 1, 1, seed = 3)
  expect_identical(.sim_algebra(r$Xs, 1L), integer(0))
})

test_that("the Kronecker log-likelihood equals the dense one (p, q = 1, 2)", {
  for (s in designs) {
    p <- s[["p"]]; q <- s[["q"]]
    d <- product_data(s[["I"]], s[["J"]], p, q, n = 6, seed = sum(s))
    expect_identical(.sim_algebra(d$Xs, p), unname(as.integer(s[c("I", "J")])))
    for (r in 1:5) {
      phi <- random_phi(p, q)
      kron <- .fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6)
      dense <- dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6)
      expect_equal(kron, dense, tolerance = 1e-8)
      expect_equal(kron, .fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6, algebra = 1L),
                   tolerance = 1e-8)
    }
  }
})

test_that("Kronecker moves (single, joint, scale, rejected decoys) keep the dense log-likelihood", {
  for (s in designs) {
    p <- s[["p"]]; q <- s[["q"]]
    d <- product_data(s[["I"]], s[["J"]], p, q, n = 5, seed = 40 + sum(s))
    d$Xf <- d$Xf[c(1:5, 2, 4), , drop = FALSE]  # replicated field inputs
    d$yf <- c(d$yf, rnorm(2))
    phis <- one_move_path(random_phi(p, q), p, q)
    dense <- apply(phis, 1, function(phi) dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6))
    path <- .loglik_path(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, decoys = TRUE)
    expect_equal(path, dense, tolerance = 1e-8)
    expect_equal(path[nrow(phis)], path[1], tolerance = 1e-10)
    expect_joint_moves_dense(d, phis, p, q)
  }
})

test_that("without a discrepancy: Kronecker log-likelihoods, moves and predictions equal the dense ones", {
  for (s in designs) {
    p <- s[["p"]]; q <- s[["q"]]
    none <- FBC:::compiled_model(p, q, discrepancy = "none")
    noneDense <- FBC:::compiled_model(p, q, algebra = 1L, discrepancy = "none")
    d <- product_data(s[["I"]], s[["J"]], p, q, n = 5, seed = 90 + sum(s))
    d$Xf <- d$Xf[c(1:5, 2), , drop = FALSE]  # a replicated field input
    d$yf <- c(d$yf, rnorm(1))
    dense_none <- function(phi) dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6, discrepancy = "none")
    for (r in 1:3) {
      phi <- random_phi(p, q, "none")
      expect_equal(.fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6, model = none), dense_none(phi),
                   tolerance = 1e-8)
    }
    phis <- one_move_path(random_phi(p, q, "none"), p, q, "none")
    path <- .loglik_path(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, decoys = TRUE, model = none)
    expect_equal(path, apply(phis, 1, dense_none), tolerance = 1e-8)
    expect_joint_moves_dense(d, phis, p, q, discrepancy = "none")
    Xn <- matrix(runif(4 * p), 4, p)
    for (t in 1:4) {
      type <- c("field", "mean", "simulator", "bias")[t]
      kron <- .fbc_predict(d$Xf, d$yf, d$Xs, d$ys, phis[1:2, ], Xn, t, 1e-6, 2L, model = none)
      for (i in 1:2) {
        ref <- dense_predict(d$Xf, d$yf, d$Xs, d$ys, phis[i, ], Xn, type, discrepancy = "none")
        expect_equal(kron$mean[, i], ref$mean, tolerance = 1e-8)
        expect_equal(kron$var[, i], ref$var, tolerance = 1e-8)
      }
      expect_equal(kron, .fbc_predict(d$Xf, d$yf, d$Xs, d$ys, phis[1:2, ], Xn, t, 1e-6, 500L,
                                      model = noneDense), tolerance = 1e-8)
    }
  }
})

test_that("under the S-GaSP: Kronecker log-likelihoods, moves and predictions equal the dense ones", {
  for (s in designs) {
    p <- s[["p"]]; q <- s[["q"]]
    sg <- FBC:::compiled_model(p, q, discrepancy = "sgasp")
    sgDense <- FBC:::compiled_model(p, q, algebra = 1L, discrepancy = "sgasp")
    d <- product_data(s[["I"]], s[["J"]], p, q, n = 5, seed = 120 + sum(s))
    d$Xf <- d$Xf[c(1:5, 3), , drop = FALSE]  # a replicated field input
    d$yf <- c(d$yf, rnorm(1))
    dense_sg <- function(phi) dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6, discrepancy = "sgasp")
    phis <- one_move_path(random_phi(p, q, "sgasp"), p, q, "sgasp")
    expect_equal(.fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phis[1, ], 1e-6, model = sg), dense_sg(phis[1, ]),
                 tolerance = 1e-8)
    path <- .loglik_path(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, decoys = TRUE, model = sg)
    expect_equal(path, apply(phis, 1, dense_sg), tolerance = 1e-8)
    expect_joint_moves_dense(d, phis, p, q, discrepancy = "sgasp")
    Xn <- rbind(matrix(runif(3 * p), 3, p), d$Xf[2, ])  # one new point on a field input
    for (t in 1:4) {
      type <- c("field", "mean", "simulator", "bias")[t]
      kron <- .fbc_predict(d$Xf, d$yf, d$Xs, d$ys, phis[1:2, ], Xn, t, 1e-6, 2L, model = sg)
      for (i in 1:2) {
        ref <- dense_predict(d$Xf, d$yf, d$Xs, d$ys, phis[i, ], Xn, type, discrepancy = "sgasp")
        expect_equal(kron$mean[, i], ref$mean, tolerance = 1e-8)
        expect_equal(kron$var[, i], ref$var, tolerance = 1e-8)
      }
      expect_equal(kron, .fbc_predict(d$Xf, d$yf, d$Xs, d$ys, phis[1:2, ], Xn, t, 1e-6, 500L,
                                      model = sgDense), tolerance = 1e-8)
    }
  }
})

test_that("the sampler on a product design retains dense log-likelihoods", {
  # accept and reject paths of every move of both samplers
  p <- 1; q <- 2
  d <- product_data(6, 5, p, q, n = 6, seed = 9)
  sp <- FBC:::build_priors(list(dist = rep("beta", q), init = rep(NA, q), p1 = rep(1.1, q),
                                p2 = rep(1.1, q)),
                           set_hyperPriors(),
                           list(xmin = rep(0, p + q), xmax = rep(1, p + q), p = p, q = q), p, q)
  sp$model <- FBC:::compiled_model(p, q)
  for (sampler in c("single", "blocks")) {
    set.seed(3)
    res <- run_sampler(d, sp, sampler, 200L, 150L, 5L)
    acc <- res$acceptance[!is.na(res$acceptance)]
    expect_true(any(acc > 0 & acc < 1))
    dense <- apply(res$draws, 1, function(phi) dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6))
    expect_equal(res$logLik, dense, tolerance = 1e-8)
  }
})

test_that("Kronecker predictions equal the dense GP conditional (every type)", {
  for (s in designs[c(2, 4)]) {
    p <- s[["p"]]; q <- s[["q"]]
    d <- product_data(s[["I"]], s[["J"]], p, q, n = 6, seed = 70 + sum(s))
    d$Xf <- d$Xf[c(1:6, 3), , drop = FALSE]
    d$yf <- c(d$yf, rnorm(1))
    phis <- rbind(random_phi(p, q), random_phi(p, q))
    Xn <- matrix(runif(5 * p), 5, p)
    for (type in c("field", "mean", "simulator", "bias")) {
      t <- match(type, c("field", "mean", "simulator", "bias"))
      kron <- .fbc_predict(d$Xf, d$yf, d$Xs, d$ys, phis, Xn, t, 1e-6, 2L)
      dense <- .fbc_predict(d$Xf, d$yf, d$Xs, d$ys, phis, Xn, t, 1e-6, 500L, algebra = 1L)
      for (i in 1:2) {
        ref <- dense_predict(d$Xf, d$yf, d$Xs, d$ys, phis[i, ], Xn, type)
        expect_equal(kron$mean[, i], ref$mean, tolerance = 1e-8)
        expect_equal(kron$var[, i], ref$var, tolerance = 1e-8)
      }
      expect_equal(kron, dense, tolerance = 1e-8)
    }
  }
})

test_that("calibrate() uses the Kronecker algebra on a product design and says so", {
  set.seed(12)
  x <- seq(0, 1, length.out = 6)
  t1 <- seq(1, 3, length.out = 5)
  g <- expand.grid(x = x, t1 = t1)
  sim <- cbind(y = g$t1 * exp(-g$x), g)[sample(30), ]
  field <- cbind(y = 2 * exp(-c(0.1, 0.35, 0.6, 0.9)) + rnorm(4, 0, 0.01),
                 x = c(0.1, 0.35, 0.6, 0.9))
  set.seed(13)
  fit <- calibrate(sim, field, nMCMC = 60, nBurn = 20, nChains = 1)
  expect_identical(fit$model$options$algebra, "auto")
  expect_identical(fit$model$algebra[c("name", "dims")], list(name = "kronecker", dims = c(6L, 5L)))
  out <- capture.output(print(fit))
  expect_true(any(out == "  algebra: Kronecker, 6 x 5 (experimental x calibration settings): exact; the runs are a product design, so no m x m matrix is formed"))
  # the dense algebra on request: the same chain (the same posterior, the
  # same random numbers) up to rounding
  set.seed(13)
  dense <- calibrate(sim, field, nMCMC = 60, nBurn = 20, nChains = 1, algebra = "dense")
  expect_identical(dense$model$algebra$name, "dense")
  expect_true(any(startsWith(capture.output(print(dense)), "  algebra: dense: as asked (`algebra = \"dense\"`)")))
  expect_equal(dense$Phi, fit$Phi, tolerance = 1e-6)
  # prediction goes through the fit's algebra
  expect_equal(predict(dense, c(0.2, 0.5))$pred, predict(fit, c(0.2, 0.5))$pred, tolerance = 1e-6)
  # a near-product design (one run missing): Kronecker with a missing cell
  set.seed(13)
  near <- calibrate(sim[-4, ], field, nMCMC = 60, nBurn = 20, nChains = 1)
  expect_identical(near$model$algebra[c("name", "missing")], list(name = "kronecker", missing = 1L))
})

test_that("kappa draws on a product design match the grid posterior", {
  # data drawn from the model (dense_cov) at kappa = 0.35 on an 8 x 6
  # product design; every hyperparameter fixed at the truth; the reference
  # is the plain-R dense likelihood on a grid of kappa times the
  # Beta(1.1, 1.1) prior (stretched over the design's kappa range, so plain
  # Beta on the sampler's [0, 1] scale)
  set.seed(31)
  Xg <- seq(0, 1, length.out = 8)
  Tg <- seq(0, 1, length.out = 6)
  g <- expand.grid(i = 1:8, j = 1:6)[sample(48), ]
  Xs <- cbind(Xg[g$i], Tg[g$j])
  Xf <- matrix(c(0.05, 0.2, 0.33, 0.5, 0.71, 0.9), ncol = 1)
  truth <- c(0.35, 2, 3, 1.9, 1.9, 2, 1.9, 1, 0.05, 0.01, 0)
  y <- drop(t(chol(dense_cov(Xf, Xs, truth))) %*% stats::rnorm(6 + 48))
  sim <- cbind(y = y[6 + 1:48], x = Xs[, 1], t = Xs[, 2])
  field <- cbind(y = y[1:6], x = Xf[, 1])
  hyp <- set_hyperPriors(
    thetaSDist = "fixed", thetaSInit = c(2, 3), alphaSDist = "fixed", alphaSInit = 1.9,
    thetaBDist = "fixed", thetaBInit = 2, alphaBDist = "fixed", alphaBInit = 1.9,
    sigma2SDist = "fixed", sigma2SInit = 1, sigma2BDist = "fixed", sigma2BInit = 0.05,
    sigma2EDist = "fixed", sigma2EInit = 0.01, muBDist = "fixed", muBInit = 0
  )
  # (the power exponential: the data are drawn from it, dense_cov())
  fit <- calibrate(sim, field, nMCMC = 8000, nBurn = 1000, thinning = 2, nChains = 2,
                   hypers = hyp, kernelS = "powexp", kernelB = "powexp")
  expect_identical(fit$model$algebra$name, "kronecker")
  d <- fit$model$data
  # 7000 draws of kappa (ESS a few thousand): quantile errors ~0.03 sd
  expect_kappa_grid(fit, function(phi) dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6),
                    u = seq(0, 1, length.out = 201), quantileTol = 0.12, ksTol = 0.05)
})

test_that("the dense algebra's on-the-fly correlation gives the cached path's numbers", {
  old <- .fbc_cache_budget()
  on.exit(.fbc_cache_budget(old))
  # beyond the budget the first min(p + q, 4) inputs keep packed
  # log-distances and the others are computed on the fly: p + q = 5 has both
  for (s in list(c(n = 6, m = 15, p = 2, q = 1), c(n = 7, m = 14, p = 1, q = 2),
                 c(n = 5, m = 16, p = 2, q = 3))) {
    p <- s[["p"]]; q <- s[["q"]]
    d <- random_koh_data(s[["n"]], s[["m"]], p, q, seed = 90 + sum(s))
    set.seed(91)
    phis <- one_move_path(random_phi(p, q), p, q)
    cached <- .loglik_path(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, decoys = TRUE)
    .fbc_cache_budget(0)
    fly <- .loglik_path(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, decoys = TRUE)
    .fbc_cache_budget(old)
    expect_equal(fly, cached, tolerance = 1e-12)
    dense <- apply(phis, 1, function(phi) dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6))
    expect_equal(fly, dense, tolerance = 1e-8)
    Xn <- matrix(runif(3 * p), 3, p)
    pc <- .fbc_predict(d$Xf, d$yf, d$Xs, d$ys, phis[2:3, ], Xn, 1L, 1e-6, 500L)
    .fbc_cache_budget(0)
    pf <- .fbc_predict(d$Xf, d$yf, d$Xs, d$ys, phis[2:3, ], Xn, 1L, 1e-6, 500L)
    .fbc_cache_budget(old)
    expect_equal(pf, pc, tolerance = 1e-12)
  }
})

test_that("every correlation family: Kronecker log-likelihoods and moves equal the dense ones", {
  # dense_loglik() with the families of ?correlation written in plain R
  # (helper-dense.R); the dense algebra gives the same numbers
  pairs <- list(c("gaussian", "matern52"), c("matern32", "gaussian"),
                c("matern52", "matern32"), c("matern52", "powexp"))
  for (s in designs[c(2, 3)]) {
    p <- s[["p"]]; q <- s[["q"]]
    d <- product_data(s[["I"]], s[["J"]], p, q, n = 5, seed = 70 + sum(s))
    idx <- FBC:::param_indices(p, q)
    for (kk in pairs) {
      kS <- kernel_code(kk[1]); kB <- kernel_code(kk[2])
      phis <- one_move_path(random_phi(p, q), p, q)
      dense <- apply(phis, 1, function(phi)
        dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6, kk[1], kk[2]))
      expect_equal(.fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phis[1, ], 1e-6, kS, kB), dense[1],
                   tolerance = 1e-8)
      expect_equal(.fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phis[1, ], 1e-6, kS, kB, algebra = 1L),
                   dense[1], tolerance = 1e-8)
      path <- .loglik_path(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, decoys = TRUE,
                           kernS = kS, kernB = kB)
      expect_equal(path, dense, tolerance = 1e-8)
      groups <- integer(ncol(phis))
      groups[c(idx$thetaS, idx$alphaS, idx$sigma2S)] <- 1L
      groups[c(idx$thetaB, idx$alphaB, idx$sigma2B)] <- 2L
      joint <- .loglik_path(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, groups = groups,
                            decoys = TRUE, kernS = kS, kernB = kB)
      expect_equal(joint, dense, tolerance = 1e-8)
      # predictions through the Kronecker factors: the dense GP conditional
      Xn <- matrix(runif(3 * p), 3, p)
      kron <- .fbc_predict(d$Xf, d$yf, d$Xs, d$ys, phis[2, , drop = FALSE], Xn, 1L, 1e-6, 500L,
                           kS, kB)
      ref <- dense_predict(d$Xf, d$yf, d$Xs, d$ys, phis[2, ], Xn, "field", kernS = kk[1],
                           kernB = kk[2])
      expect_equal(drop(kron$mean), ref$mean, tolerance = 1e-8)
      expect_equal(drop(kron$var), ref$var, tolerance = 1e-8)
    }
  }
})
