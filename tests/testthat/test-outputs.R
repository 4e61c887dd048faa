# How several outputs are modelled (R/outputs.R, src/outputs.cpp):
# independent outputs' likelihood, moves and predictions against the sum of
# each output's plain-R dense one (dense and Kronecker algebras), kappa's
# grid posterior with two independent outputs, known-truth pooling of two
# outputs of different shapes, refusals, print() and the fit-format step.

# With independent outputs (the output's indicator in column `col` of the
# experimental inputs, one noise group per output: group o = output o) the
# log-likelihood is the sum over the outputs of the one-output KOH
# log-likelihood of that output's rows at (kappa, that output's copy of
# every other class): each output's parameters cut out of phi with the
# single-output layout.
output_phi <- function(phi, o, p, q, discrepancy, K = 2L) {
  one <- FBC:::param_indices(p, q, discrepancy)
  all <- FBC:::param_indices(p, q, discrepancy, noise = K, outputs = K)
  out <- numeric(sum(lengths(one)))
  for (cls in names(one)) {
    n <- length(one[[cls]])
    if (!n) next
    out[one[[cls]]] <- if (cls == "kappa") phi[all$kappa] else if (cls == "sigma2E") phi[all$sigma2E[o]]
                       else phi[all[[cls]][(o - 1L) * n + seq_len(n)]]
  }
  out
}
outputs_loglik_dense <- function(Xf, yf, Xs, ys, phi, col, discrepancy = "gp",
                                 kern = "matern52", nugget = 1e-6) {
  p <- ncol(Xf); q <- ncol(Xs) - p
  sum(vapply(1:2, function(o) {
    rf <- Xf[, col] == o - 1; rs <- Xs[, col] == o - 1
    dense_loglik(Xf[rf, , drop = FALSE], yf[rf], Xs[rs, , drop = FALSE], ys[rs],
                 output_phi(phi, o, p, q, discrepancy), nugget, kern, kern, discrepancy)
  }, numeric(1)))
}
# A phi of two independent outputs inside every domain.
outputs_random_phi <- function(p, q, discrepancy) {
  idx <- FBC:::param_indices(p, q, discrepancy, noise = 2L, outputs = 2L)
  one <- lapply(1:2, function(o) random_phi(p, q, discrepancy))
  one1 <- FBC:::param_indices(p, q, discrepancy)
  phi <- numeric(sum(lengths(idx)))
  for (cls in names(idx)) {
    if (!length(idx[[cls]])) next
    phi[idx[[cls]]] <- if (cls == "kappa") one[[1]][one1$kappa] else
      unlist(lapply(one, function(v) v[one1[[cls]]]))
  }
  phi
}

test_that("independent outputs: likelihood, moves and predictions are each output's dense ones summed", {
  # every run gives both outputs at the same 6 x values: (x, output) x t, a
  # product design per output (Kronecker) or forced dense
  set.seed(31)
  grid <- expand.grid(x = seq(0, 1, length.out = 6), o = 0:1, t = seq(0, 1, length.out = 7))
  Xs <- as.matrix(grid)
  ys <- sin(3 * Xs[, 1] * (1 + Xs[, 3])) + Xs[, 2] * Xs[, 1]^2 + rnorm(nrow(Xs), 0, 0.01)
  Xf <- cbind(x = runif(8), o = rep(0:1, 4))
  yf <- rnorm(8)
  noise <- rep(1:2, 4)
  outs <- list(col = 2L, ncol = 1L, L = 2L)
  for (disc in c("gp", "none")) {
    for (alg in c(0L, 1L)) {
      model <- FBC:::compiled_model(2, 1, kernS = 4L, kernB = 4L, algebra = alg,
                                    discrepancy = disc, noise = noise, outputs = outs)
      phis <- rbind(outputs_random_phi(2, 1, disc), outputs_random_phi(2, 1, disc))
      ref <- apply(phis, 1, function(phi) outputs_loglik_dense(Xf, yf, Xs, ys, phi, 2L, disc))
      for (i in 1:2) {
        expect_equal(.fbc_loglik(Xf, yf, Xs, ys, phis[i, ], 1e-6, model = model), ref[i],
                     tolerance = 1e-8)
      }
      # moves of one output's simulator block, of kappa, and the scale move
      idx <- FBC:::param_indices(2, 1, disc, noise = 2L, outputs = 2L)
      groups <- integer(ncol(phis))
      groups[c(idx$thetaS[1:3], idx$sigma2S[1])] <- 1L
      groups[c(idx$thetaS[4:6], idx$sigma2S[2])] <- 2L
      path <- .loglik_path(Xf, yf, Xs, ys, phis, 1e-6, groups = groups, decoys = TRUE,
                           model = model)
      expect_equal(path, ref, tolerance = 1e-8)
      sc <- c(idx$sigma2S, idx$sigma2B, idx$sigma2E)
      up <- phis[c(2, 2), ]
      up[2, sc] <- up[2, sc] * 1.7
      expect_equal(.loglik_path(Xf, yf, Xs, ys, up, 1e-6, decoys = TRUE, scale = TRUE, model = model)[2],
                   outputs_loglik_dense(Xf, yf, Xs, ys, up[2, ], 2L, disc), tolerance = 1e-8)
      # predictions: each new point by its own output's block
      Xn <- cbind(x = c(0.3, 0.7, 0.5), o = c(1, 0, 1))
      got <- .fbc_predict(Xf, yf, Xs, ys, phis, Xn, 1L, 1e-6, 2L, model = model,
                          noise = c(2L, 1L, 2L))
      for (i in 1:2) for (r in 1:3) {
        o <- Xn[r, 2] + 1
        rf <- Xf[, 2] == o - 1; rs <- Xs[, 2] == o - 1
        want <- dense_predict(Xf[rf, ], yf[rf], Xs[rs, ], ys[rs], output_phi(phis[i, ], o, 2, 1, disc),
                              Xn[r, , drop = FALSE], "field", kernS = "matern52",
                              kernB = "matern52", discrepancy = disc)
        expect_equal(got$mean[r, i], unname(want$mean), tolerance = 1e-8)
        expect_equal(got$var[r, i], unname(want$var), tolerance = 1e-8)
      }
    }
  }
})

test_that("two independent outputs: kappa draws match the grid posterior", {
  skip_if_not_slow()
  # every hyperparameter fixed (each output the same values); the reference
  # is the sum of each output's dense_loglik() times the Beta(1.1, 1.1)
  # prior on the scaled kappa
  pr <- two_outputs()
  hyp <- set_hyperPriors(thetaSDist = "fixed", thetaSInit = c(0.7, 10, 0.4),
                         thetaBDist = "fixed", thetaBInit = c(1, 5), sigma2SDist = "fixed",
                         sigma2SInit = 3.5, sigma2BDist = "fixed", sigma2BInit = 0.5,
                         sigma2EDist = "fixed", sigma2EInit = 0.05, muBDist = "fixed", muBInit = 0)
  set.seed(9)
  fit <- calibrate(pr$sim, pr$field, output = "out", outputs = "independent", nMCMC = 9000,
                   nBurn = 1000, thinning = 4, nChains = 1, hypers = hyp)
  d <- fit$model$data
  expect_identical(fit$model$spec$vars[fit$model$spec$classes == "sigma2S"], c("sigma2S[conc]", "sigma2S[rate]"))
  expect_kappa_grid(fit, function(phi) outputs_loglik_dense(d$Xf, d$yf, d$Xs, d$ys, phi, 2L),
                    u = seq(0, 1, length.out = 401), col = 3L, ksTol = NULL)
})

test_that("two outputs of different shapes pooled independently: kappa no wider than the better alone", {
  # A = t1 exp(-t2 x), B = 100 (t1 + t2 x^2 / 2): 20 runs x 8
  # x-points, 10 field points per output at the truth (2, 0.7), 1% noise,
  # no discrepancy
  set.seed(311)
  fs <- list(A = function(x, t1, t2) t1 * exp(-t2 * x),
             B = function(x, t1, t2) 100 * (t1 + t2 * x^2 / 2))
  t1 <- runif(20, 1, 3); t2 <- runif(20, 0.2, 1.2); x <- seq(0, 2, length.out = 8)
  sim <- do.call(rbind, lapply(names(fs), function(o) do.call(rbind, lapply(1:20, function(r)
    data.frame(y = fs[[o]](x, t1[r], t2[r]), x = x, output = o, t1 = t1[r], t2 = t2[r])))))
  xf <- seq(0.1, 1.9, length.out = 10)
  field <- do.call(rbind, lapply(names(fs), function(o) {
    y0 <- fs[[o]](xf, 2, 0.7)
    data.frame(y = y0 + rnorm(10, 0, 0.01 * mean(abs(y0))), x = xf, output = o)
  }))
  args <- list(nMCMC = 1500, nBurn = 750, nChains = 2, discrepancy = "none")
  width <- function(f) apply(f$Phi[, 1:2], 2, function(v) diff(quantile(v, c(0.05, 0.95), names = FALSE)))
  set.seed(1)
  both <- do.call(calibrate, c(list(sim, field, output = "output", outputs = "independent"), args))
  alone <- lapply(names(fs), function(o) {
    set.seed(1)
    do.call(calibrate, c(list(sim[sim$output == o, -3], field[field$output == o, -3]), args))
  })
  best <- pmin(width(alone[[1]]), width(alone[[2]]))
  expect_true(all(width(both) <= best))
  q <- apply(both$Phi[, 1:2], 2, quantile, c(0.05, 0.95), names = FALSE)
  expect_true(all(q[1, ] <= c(2, 0.7) & c(2, 0.7) <= q[2, ]))
  # per output: loo groups, held-out runs, predictions in each output's units
  skip_if_not_installed("loo")
  # (loo groups by input: both outputs at an x leave together; 10 x values)
  expect_equal(nrow(suppressWarnings(loo::loo(both, ndraws = 20))$pointwise), 10L)
  expect_equal(nrow(suppressWarnings(loo::loo(both, ndraws = 20, unit = "observation"))$pointwise), 20L)
  nd <- data.frame(x = c(1, 1), output = c("A", "B"))
  pm <- predict(both, nd, type = "mean", method = "MAP")
  expect_equal(pm$pred, c(fs$A(1, 2, 0.7), fs$B(1, 2, 0.7)), tolerance = 0.02)
  expect_output(print(both), "independent: each its own simulator GP")
  # the outputs have no correlation to show: said, with the way to one
  expect_snapshot(error = TRUE, level_correlation(both, "output"))
})

test_that("independent outputs: refusals, and print() says how the outputs are modelled", {
  pr <- two_outputs()
  expect_snapshot(error = TRUE, calibrate(pr$sim, pr$field[pr$field$out == "conc", ],
                                          output = "out", outputs = "independent", fit = FALSE))
  expect_snapshot(error = TRUE, calibrate(pr$sim, pr$field, output = "out", outputs = "independent",
                                          algebra = "vecchia", fit = FALSE))
  expect_snapshot(error = TRUE, calibrate(pr$sim, pr$field, output = "out", outputs = "both"))
  model <- calibrate(pr$sim, pr$field, output = "out", outputs = "independent", fit = FALSE)
  expect_output(print(model), "Outputs: +2 \\(conc, rate\\), independent")
})

test_that("missing field cells (an output absent at some field rows, long format): kappa matches the grid posterior", {
  # the "rate" output is not measured at 4 of the 10 field inputs: those
  # rows are absent; every hyperparameter fixed, the reference is the dense
  # likelihood of the observed cells times kappa's prior
  skip_if_not_slow()
  pr <- two_outputs()
  field <- pr$field[-c(12, 14, 17, 19), ]
  hyp <- set_hyperPriors(thetaSDist = "fixed", thetaSInit = c(0.7, 10, 0.4),
                         thetaBDist = "fixed", thetaBInit = c(1, 5), sigma2SDist = "fixed",
                         sigma2SInit = 3.5, sigma2BDist = "fixed", sigma2BInit = 0.5,
                         sigma2EDist = "fixed", sigma2EInit = 0.05, muBDist = "fixed", muBInit = 0)
  set.seed(10)
  fit <- calibrate(pr$sim, field, output = "out", outputs = "independent", nMCMC = 9000,
                   nBurn = 1000, thinning = 4, nChains = 1, hypers = hyp)
  d <- fit$model$data
  expect_equal(nrow(d$Xf), 16L)
  expect_identical(as.vector(table(fit$model$design$noise)), c(10L, 6L))
  expect_kappa_grid(fit, function(phi) outputs_loglik_dense(d$Xf, d$yf, d$Xs, d$ys, phi, 2L),
                    u = seq(0, 1, length.out = 401), col = 3L, ksTol = NULL)
  # predictions at a missing cell carry that output's noise
  pm <- predict(fit, data.frame(x = field$x[1:2], out = "rate"), method = "MAP")
  expect_true(all(is.finite(pm$pred)))
})
