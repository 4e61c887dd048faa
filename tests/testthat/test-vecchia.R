# The nearest-neighbour (Vecchia) algebra (src/vecchia.cpp, R/vecchia.R).
# With every node conditioned on all its predecessors (neighbours >= m) the
# graph is the chain rule of the joint Gaussian, so the log-likelihood,
# predictions and held-out predictions must equal the dense plain-R ones
# (helper-dense.R, helper-predict.R); with fewer neighbours the sampler must
# target the approximate posterior itself (its own grid).

# The model description of the Vecchia algebra with k neighbours among the
# runs and kf among the field latents, unscaled distances.
vecchia_model <- function(d, p, q, k, kf = k, discrepancy = "gp", w = rep(1, p + q)) {
  ord <- FBC:::.vecchia_order(d$Xs, w)
  FBC:::compiled_model(p, q, algebra = 2L, discrepancy = discrepancy,
                       vecchia = list(k = as.integer(k), kf = as.integer(kf), order = ord,
                                      neighbours = FBC:::.vecchia_neighbours(d$Xs, ord, w, as.integer(k)),
                                      scaling = w))
}

vsizes <- list(c(n = 6, m = 14, p = 1, q = 1), c(n = 7, m = 18, p = 2, q = 1),
               c(n = 6, m = 16, p = 1, q = 2), c(n = 8, m = 20, p = 2, q = 2))

test_that("the maximin order and the ordered neighbours are those of a plain-R search", {
  set.seed(1)
  X <- matrix(runif(60), 30, 2)
  w <- c(2, 0.5)
  Z <- sweep(X, 2, w, "*")
  D <- as.matrix(dist(Z))
  ord <- FBC:::.vecchia_order(X, w)
  expect_setequal(ord, 1:30)
  # first: nearest the centre; then each the farthest from those taken
  expect_identical(ord[1], which.min(colSums((t(Z) - colMeans(Z))^2)))
  for (t in 2:30) {
    mind <- apply(D[ord[1:(t - 1)], -ord[1:(t - 1)], drop = FALSE], 2, min)
    expect_equal(min(D[ord[1:(t - 1)], ord[t]]), max(mind))
  }
  nb <- FBC:::.vecchia_neighbours(X, ord, w, 4L)
  for (i in 2:30) {
    prev <- ord[1:(i - 1)]
    want <- prev[order(D[ord[i], prev])][seq_len(min(4, i - 1))]
    expect_identical(nb[i, seq_along(want)], want)
  }
  expect_identical(nb[1, ], rep(0L, 4))
})

test_that("with every predecessor as neighbour the log-likelihood and its moves are the dense ones", {
  for (disc in c("gp", "sgasp", "none")) {
    for (s in vsizes) {
      p <- s[["p"]]; q <- s[["q"]]; m <- s[["m"]]
      d <- random_koh_data(s[["n"]], m, p, q, seed = 200 + sum(s))
      d$Xf <- d$Xf[c(seq_len(s[["n"]]), 2, 1), , drop = FALSE]  # replicated inputs
      d$yf <- c(d$yf, rnorm(2))
      model <- vecchia_model(d, p, q, k = m, kf = s[["n"]], discrepancy = disc)
      dense <- function(phi) dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6, discrepancy = disc)
      phis <- rbind(random_phi(p, q, disc), random_phi(p, q, disc))
      for (i in 1:2) {
        expect_equal(.fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phis[i, ], 1e-6, model = model),
                     dense(phis[i, ]), tolerance = 1e-8)
      }
      # cached moves with rejected decoys, then the joint and scale moves
      path <- .loglik_path(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, decoys = TRUE, model = model)
      expect_equal(path, apply(phis, 1, dense), tolerance = 1e-8)
    }
  }
})

test_that("with every predecessor as neighbour predictions and held-out runs are the dense ones", {
  for (disc in c("gp", "sgasp")) {
    p <- 2; q <- 1
    d <- random_koh_data(7, 18, p, q, seed = 41)
    model <- vecchia_model(d, p, q, k = 18, kf = 7, discrepancy = disc)
    phis <- rbind(random_phi(p, q, disc), random_phi(p, q, disc))
    Xn <- rbind(matrix(runif(3 * p), 3, p), d$Xf[4, ])
    for (t in 1:4) {
      type <- c("field", "mean", "simulator", "bias")[t]
      got <- .fbc_predict(d$Xf, d$yf, d$Xs, d$ys, phis, Xn, t, 1e-6, 2L, model = model)
      for (i in 1:2) {
        ref <- dense_predict(d$Xf, d$yf, d$Xs, d$ys, phis[i, ], Xn, type, discrepancy = disc)
        expect_equal(got$mean[, i], ref$mean, tolerance = 1e-8)
        expect_equal(got$var[, i], ref$var, tolerance = 1e-8)
      }
    }
    dense <- FBC:::compiled_model(p, q, algebra = 1L, discrepancy = disc)
    for (fold in list(seq_len(18), rep(1:6, 3))) {
      expect_equal(FBC:::.fbc_heldout(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, fold, model = model),
                   FBC:::.fbc_heldout(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, fold, model = dense),
                   tolerance = 1e-8)
    }
  }
})

test_that("with few neighbours the kappa draws match the approximation's own grid posterior", {
  skip_if_not_slow()
  # the ball data, every hyperparameter fixed, 5 neighbours: the reference is
  # the compiled approximate log-likelihood of the fit's own design on a grid
  # of kappa, times the Beta(1.1, 1.1) prior
  hyp <- set_hyperPriors(thetaSDist = "fixed", thetaSInit = c(1.5, 0.2), thetaBDist = "fixed",
                         thetaBInit = 2, sigma2SDist = "fixed", sigma2SInit = 3.5,
                         sigma2BDist = "fixed", sigma2BInit = 0.9, sigma2EDist = "fixed",
                         sigma2EInit = 0.15, muBDist = "fixed", muBInit = 0.2)
  set.seed(16)
  fit <- calibrate(ballSim, ballField, nMCMC = 9000, nBurn = 1000, thinning = 4, nChains = 1,
                   hypers = hyp, kernelS = "matern52", algebra = "vecchia", neighbours = 5)
  expect_identical(fit$model$algebra$name, "vecchia")
  expect_identical(fit$model$spec$model$vecchia$k, 5L)
  d <- fit$model$data
  expect_kappa_grid(fit, function(phi) {
    .fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6, model = fit$model$spec$model)
  }, u = seq(0, 1, length.out = 501))
})

test_that("a Vecchia run resumes from its checkpoint to the same draws, and update() continues it", {
  skip_if_not_slow()
  args <- list(ballSim, ballField, nMCMC = 400, nBurn = 200, nChains = 2, kernelS = "matern52",
               algebra = "vecchia", neighbours = 10)
  set.seed(21)
  ref <- do.call(calibrate, args)
  expect_output(print(ref), "Vecchia nearest-neighbour approximation, k = 10")
  dir <- tempfile("vk-")
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  old <- options(FBC.sampler = interrupt_at_call(5))
  set.seed(21)
  expect_warning(part <- do.call(calibrate, c(args, checkpoint = dir)), "Resume it with the same")
  options(old)
  expect_message(fit <- do.call(calibrate, c(args, checkpoint = dir)), "Resuming")
  expect_same_draws(fit, ref)
  # another number of neighbours is another run
  expect_error(do.call(calibrate, c(modifyList(args, list(neighbours = 12)), checkpoint = dir)),
               "holds another run")
  set.seed(3)
  up <- update(fit, nMCMC = 100)
  expect_identical(up$Phi[up$chain == 1, ][1:100, ], fit$Phi[fit$chain == 1, ])
  expect_identical(up$model$spec$model$vecchia, fit$model$spec$model$vecchia)
  # the last draw's stored log-likelihood is the approximation's, from scratch
  last <- nrow(up$Phi)
  expect_equal(up$logLik[last],
               .fbc_loglik(up$model$data$Xf, up$model$data$yf, up$model$data$Xs, up$model$data$ys,
                           FBC:::sampler_draws(up, last)[1, ], 1e-6, model = up$model$spec$model),
               tolerance = 1e-8)
})

test_that("bad neighbours and algebras are refused (auto's choice: test-algebra.R)", {
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, algebra = "vecchia", neighbours = 0))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, algebra = "vecchia", neighbours = 2.5))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, algebra = "nn"))
})

test_that("the runs' cached distance values give the on-the-fly log-likelihoods to the bit", {
  # src/vecchia.cpp caches each run's conditioning set's per-dimension
  # distance values unless they exceed the option FBC.vecchia_cache_mb (0:
  # never): both paths must give the same numbers, with a categorical input
  # (rhoS) and the power exponential (alphaS: the cached value is log d) as
  # well as Matern 5/2, along the sampler's cached moves
  set.seed(52)
  m <- 40
  lev <- list(col = 2L, ncol = 3L, L = 3L)
  Xs <- cbind(runif(m), diag(3)[rep(1:3, length.out = m), ], runif(m))
  d <- list(Xf = cbind(runif(7), diag(3)[c(1, 2, 3, 1, 2, 3, 2), ]), yf = rnorm(7), Xs = Xs,
            ys = sin(4 * Xs[, 1]) + Xs[, 5] + rnorm(m, 0, 0.1))
  for (kern in c(1L, 4L)) {
    des <- FBC:::vecchia_design(d$Xs, d$ys, kern, 6L, 3L)
    model <- FBC:::compiled_model(4, 1, kernS = kern, algebra = 2L, vecchia = des, levels = lev)
    phis <- t(replicate(3, random_phi(4, 1, nLev = 3L)))
    path <- function(mb) {
      old <- options(FBC.vecchia_cache_mb = mb)
      on.exit(options(old))
      .loglik_path(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, decoys = TRUE, model = model)
    }
    cached <- path(NULL)
    expect_true(all(is.finite(cached)))
    expect_identical(path(0), cached)
    expect_identical(path(1e-4), cached)  # 100 bytes: below this problem's cache
  }
  old <- options(FBC.vecchia_cache_mb = "a lot")
  on.exit(options(old))
  expect_error(.fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phis[1, ], 1e-6, model = model),
               "FBC.vecchia_cache_mb must be one number")
})
