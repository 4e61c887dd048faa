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
