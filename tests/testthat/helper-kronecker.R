# Shared by the Kronecker algebra's tests (test-kronecker*.R).


# The dense algebra's log-likelihoods, moves and joint moves on d (a grid
# and field data), the field data given a replicated input first.
expect_kron_loglik_dense <- function(d, p, q) {
  d$Xf <- d$Xf[c(1:5, 2), , drop = FALSE]  # a replicated field input
  d$yf <- c(d$yf, rnorm(1))
  for (r in 1:4) {
    phi <- random_phi(p, q)
    kron <- .fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6)
    expect_equal(kron, dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6), tolerance = 1e-8)
  }
  phis <- one_move_path(random_phi(p, q), p, q)
  dense <- apply(phis, 1, function(phi) dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6))
  path <- .loglik_path(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, decoys = TRUE)
  expect_equal(path, dense, tolerance = 1e-8)
  expect_joint_moves_dense(d, phis, p, q)
}

# Predictions of every type at Xn from the draws phis equal the dense GP
# conditional's.
expect_kron_predict_dense <- function(d, phis, Xn) {
  for (t in 1:4) {
    type <- c("field", "mean", "simulator", "bias")[t]
    kron <- .fbc_predict(d$Xf, d$yf, d$Xs, d$ys, phis, Xn, t, 1e-6, nrow(phis))
    for (i in seq_len(nrow(phis))) {
      ref <- dense_predict(d$Xf, d$yf, d$Xs, d$ys, phis[i, ], Xn, type)
      expect_equal(kron$mean[, i], ref$mean, tolerance = 1e-8)
      expect_equal(kron$var[, i], ref$var, tolerance = 1e-8)
    }
  }
}
