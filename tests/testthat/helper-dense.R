# Plain-R reference implementations used as independent checks of the
# compiled code: dense covariance, dense Cholesky log-likelihood.

# Has the discrepancy model parameters of class `cls`?
model_has <- function(discrepancy, cls) {
  FBC:::class_in_model(discrepancy)[match(cls, FBC:::model_classes$class)]
}

# R(X, Y) = prod_k r(|x_k - y_k|), one outer() per input, with r written
# from the formulas of ?correlation (h = sqrt(theta) d):
#   powexp exp(-theta d^alpha), gaussian exp(-theta d^2),
#   matern32 (1 + sqrt(3) h) exp(-sqrt(3) h),
#   matern52 (1 + sqrt(5) h + 5 h^2 / 3) exp(-sqrt(5) h).
dense_corr <- function(X, Y, theta, alpha, kernel = "powexp") {
  X <- as.matrix(X); Y <- as.matrix(Y)
  r1 <- function(d, theta, alpha) {
    h <- sqrt(theta) * d
    switch(kernel,
      powexp = exp(-theta * d^alpha),
      gaussian = exp(-theta * d^2),
      matern32 = (1 + sqrt(3) * h) * exp(-sqrt(3) * h),
      matern52 = (1 + sqrt(5) * h + 5 * h^2 / 3) * exp(-sqrt(5) * h))
  }
  out <- matrix(1, nrow(X), nrow(Y))
  for (k in seq_len(ncol(X))) {
    out <- out * r1(abs(outer(X[, k], Y[, k], "-")), theta[k], alpha[k])
  }
  out
}

# The kernel names and the codes the compiled entry points take.
kernel_code <- function(kernel) {
  c(powexp = 1L, gaussian = 2L, matern32 = 3L, matern52 = 4L)[[kernel]]
}
all_kernels <- c("powexp", "gaussian", "matern32", "matern52")

# Unpacks phi (scaled space, kappa on [0, 1]) into named pieces, one per
# parameter class, at the positions FBC's model description gives (under
# discrepancy "none" the bias classes are empty).
unpack_phi <- function(phi, p, q, discrepancy = "gp", G = 1L, nLev = 0L, nSrc = 0L) {
  lapply(FBC:::param_indices(p, q, discrepancy, G, nLev, nSrc), function(i) phi[i])
}

# The levels' correlation of a categorical input with L levels from its
# canonical partial correlations z (column by column: z(2,1), ..., z(L,1),
# z(3,2), ...; z(i,1) the correlation of levels i and 1, z(i,j) that of i
# and j given levels 1 .. j-1), by the partial-correlation recursion of the
# C-vine (Joe 2006; Lewandowski, Kurowicka and Joe 2009, sec. 2.2):
#   r(i,j | 1..k-1) = r(i,j | 1..k) sqrt((1 - r(i,k | 1..k-1)^2)
#                     (1 - r(j,k | 1..k-1)^2)) + r(i,k | 1..k-1) r(j,k | 1..k-1),
# not the Cholesky construction FBC computes it by.
level_corr_plain <- function(L, z) {
  P <- matrix(0, L, L)
  at <- 0
  for (j in seq_len(L - 1)) for (i in (j + 1):L) { at <- at + 1; P[i, j] <- z[at] }
  C <- diag(L)
  for (j in seq_len(L - 1)) for (i in (j + 1):L) {
    r <- P[i, j]
    if (j > 1) for (k in (j - 1):1) r <- r * sqrt((1 - P[i, k]^2) * (1 - P[j, k]^2)) + P[i, k] * P[j, k]
    C[i, j] <- C[j, i] <- r
  }
  C
}

# The factor the levels put on the correlation between rows of X and Y:
# prod_f C_f[level of x, level of y] over the categorical inputs `levels`
# (list(col, ncol, L) as FBC:::model_levels() gives them: the first
# indicator column, their number and the levels), z their partial
# correlations in order; 1 without levels.
level_factor <- function(X, Y, levels, z) {
  out <- matrix(1, nrow(X), nrow(Y))
  if (is.null(levels)) return(out)
  code <- function(A, f) {
    cols <- levels$col[f] + seq_len(levels$ncol[f]) - 1L
    if (length(cols) == 1L) 1L + (A[, cols] > 0.5) else max.col(A[, cols, drop = FALSE], "first")
  }
  at <- 0
  for (f in seq_along(levels$L)) {
    L <- levels$L[f]
    C <- level_corr_plain(L, z[at + seq_len(L * (L - 1) / 2)])
    at <- at + L * (L - 1) / 2
    out <- out * C[code(as.matrix(X), f), code(as.matrix(Y), f), drop = FALSE]
  }
  out
}

# The bias GP's correlation between the rows of A and of B, for field
# inputs Xf: R(A, B) for the KOH bias; for the S-GaSP (Gu and Wang 2018) the
# discretized kernel on the nu distinct field inputs U,
#   Kz(A, B) = R(A, B) - R(A, U) (R(U, U) + nu / lambdaZ I)^-1 R(U, B).
#
# With a bias per field data set (`srcL` data sets) the last column of A, B
# and Xf holds each row's data set (1-based), and the kernel is multiplied
# by the data sets' level correlation C_D (partial correlations rhoD):
#   R((x, s), (x', s')) = R(x, x') C_D[s, s'].
bias_kernel_dense <- function(A, B, Xf, th, kernB, discrepancy, levels = NULL, srcL = 0L) {
  R <- function(X, Y) {
    X <- as.matrix(X); Y <- as.matrix(Y)
    p <- ncol(X) - (srcL > 0)
    out <- dense_corr(X[, seq_len(p), drop = FALSE], Y[, seq_len(p), drop = FALSE], th$thetaB,
                      th$alphaB, kernB) * level_factor(X, Y, levels, th$rhoB)
    if (srcL > 0) out <- out * level_corr_plain(srcL, th$rhoD)[X[, p + 1], Y[, p + 1], drop = FALSE]
    out
  }
  if (discrepancy != "sgasp") return(R(A, B))
  U <- unique(as.matrix(Xf))
  nu <- nrow(U)
  R(A, B) - R(A, U) %*% solve(R(U, U) + nu / th$lambdaZ * diag(nu), R(U, B))
}
bias_corr_dense <- function(Xf, th, kernB, discrepancy, levels = NULL, srcL = 0L) {
  bias_kernel_dense(Xf, Xf, Xf, th, kernB, discrepancy, levels, srcL)
}

# The full (n + m) x (n + m) covariance of y = (yf, ys) (vignette 2.4).
# kernS, kernB: the simulator and bias GPs' correlation families;
# discrepancy "none": no bias block (y_f = eta(x, kappa) + eps); "sgasp":
# the S-GaSP bias block (bias_corr_dense()).
dense_cov <- function(Xf, Xs, phi, nugget = 1e-6, kernS = "powexp", kernB = "powexp",
                      discrepancy = "gp", noise = NULL, levels = NULL, source = NULL) {
  n <- nrow(Xf); m <- nrow(Xs); p <- ncol(Xf); q <- ncol(Xs) - p
  th <- unpack_phi(phi, p, q, discrepancy, max(noise, 1L), FBC:::level_count(levels),
                   FBC:::source_count(source))
  Xk <- cbind(Xf, matrix(th$kappa, n, q, byrow = TRUE))
  X <- rbind(Xk, Xs)
  C <- th$sigma2S * dense_corr(X, X, th$thetaS, th$alphaS, kernS) *
    level_factor(X, X, levels, th$rhoS)
  f <- seq_len(n); s <- n + seq_len(m)
  C[s, s] <- C[s, s] + th$sigma2S * nugget * diag(m)
  # measurement error: sigma2E of each row's group (noise: 1-based groups)
  C[f, f] <- C[f, f] + diag(th$sigma2E[if (is.null(noise)) rep(1L, n) else noise], n)
  if (discrepancy != "none") {
    Xb <- if (is.null(source)) Xf else cbind(Xf, source$codes)
    C[f, f] <- C[f, f] + th$sigma2B * bias_corr_dense(Xb, th, kernB, discrepancy, levels,
                                                      if (is.null(source)) 0L else source$L)
  }
  C
}

# Gaussian log-likelihood of (yf, ys) via one dense Cholesky factor.
dense_loglik <- function(Xf, yf, Xs, ys, phi, nugget = 1e-6, kernS = "powexp",
                         kernB = "powexp", discrepancy = "gp", noise = NULL, levels = NULL,
                         source = NULL) {
  p <- ncol(Xf); q <- ncol(Xs) - p
  th <- unpack_phi(phi, p, q, discrepancy, max(noise, 1L), FBC:::level_count(levels),
                   FBC:::source_count(source))
  C <- dense_cov(Xf, Xs, phi, nugget, kernS, kernB, discrepancy, noise, levels, source)
  r <- c(yf - if (model_has(discrepancy, "muB")) th$muB else 0, ys)  # no muB: mean 0
  L <- chol(C)
  a <- backsolve(L, r, transpose = TRUE)
  -0.5 * (length(r) * log(2 * pi) + 2 * sum(log(diag(L))) + sum(a^2))
}

# A small random KOH data set on the scaled space.
random_koh_data <- function(n, m, p, q, seed) {
  set.seed(seed)
  Xf <- matrix(runif(n * p), n, p)
  Xs <- matrix(runif(m * (p + q)), m, p + q)
  list(Xf = Xf, yf = rnorm(n), Xs = Xs, ys = rnorm(m))
}

# A random parameter vector inside every domain: each class drawn by its
# domain in FBC's model description (kappa uniform on [0, 1], positive
# classes Gamma(2, 2) (+ 0.05 for the variances), smoothness on [1.1, 1.95],
# the bias mean N(0, 1), the S-GaSP scale 20 x Gamma(2, 2)); no bias
# classes under discrepancy "none".
random_phi <- function(p, q, discrepancy = "gp", G = 1L, nLev = 0L, nSrc = 0L) {
  idx <- FBC:::param_indices(p, q, discrepancy, G, nLev, nSrc)
  phi <- numeric(sum(lengths(idx)))
  for (cls in names(idx)) {
    k <- length(idx[[cls]])
    phi[idx[[cls]]] <- switch(FBC:::class_domain[[cls]],
      real = if (cls == "kappa") runif(k) else rnorm(k),
      positive = rgamma(k, 2, 2) * (if (cls == "lambdaZ") 20 else 1) +
        (if (grepl("^sigma2", cls)) 0.05 else 0),
      unit12 = runif(k, 1.1, 1.95),
      corr = runif(k, -0.9, 0.9))
  }
  phi
}

# The default sampler's joint moves along the path `phis` (rejected decoys
# before every move): (thetaS, alphaS, sigma2S), (thetaB, alphaB, sigma2B),
# and sigma2S, sigma2B, sigma2E scaled by one factor (up 1.7, then 0.3, then
# back); the compiled log-likelihoods against dense_loglik() at every row.
# Under discrepancy "none" there is no bias block and the scale move
# multiplies sigma2S and sigma2E.
expect_joint_moves_dense <- function(d, phis, p, q, nugget = 1e-6, discrepancy = "gp",
                                     noise = NULL) {
  idx <- FBC:::param_indices(p, q, discrepancy, max(noise, 1L))
  groups <- integer(ncol(phis))
  groups[c(idx$thetaS, idx$alphaS, idx$sigma2S)] <- 1L
  groups[c(idx$thetaB, idx$alphaB, idx$lambdaZ, idx$sigma2B)] <- 2L
  sig <- c(idx$sigma2S, idx$sigma2B, idx$sigma2E)
  scaled <- phis[c(1, 1, 1), ]
  scaled[2, sig] <- scaled[1, sig] * 1.7
  scaled[3, sig] <- scaled[2, sig] * 0.3
  phis2 <- rbind(phis, scaled, phis[2, ], scaled[3, ])
  dense2 <- apply(phis2, 1, function(phi) {
    dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, nugget, discrepancy = discrepancy, noise = noise)
  })
  block <- FBC:::.loglik_path(d$Xf, d$yf, d$Xs, d$ys, phis2, nugget, groups = groups,
                              decoys = TRUE, scale = TRUE,
                              model = FBC:::compiled_model(p, q, discrepancy = discrepancy,
                                                           noise = noise))
  testthat::expect_equal(block, dense2, tolerance = 1e-8)
}

# A path from phi0 on which each row changes one parameter (and a few rows
# change several), visiting every class and every dimension: kappa,
# thetaS/alphaS in the experimental and the calibration dimensions,
# thetaB/alphaB, each variance and muB, then back to the start.
one_move_path <- function(phi0, p, q, discrepancy = "gp") {
  idx <- FBC:::param_indices(p, q, discrepancy)
  rows <- list(phi0)
  move <- function(j, value) {
    phi <- rows[[length(rows)]]
    phi[j] <- value
    rows[[length(rows) + 1]] <<- phi
  }
  for (j in idx$kappa) move(j, runif(1))
  for (k in seq_len(p + q)) {
    move(idx$thetaS[k], rgamma(1, 2, 2))
    move(idx$alphaS[k], runif(1, 1.1, 1.95))
    move(idx$kappa[1], runif(1))  # kappa after each simulator change
  }
  for (k in seq_len(length(idx$thetaB))) {  # p with a bias, else none
    move(idx$thetaB[k], rgamma(1, 2, 2))
    move(idx$alphaB[k], runif(1, 1.1, 1.95))
  }
  for (j in c(idx$sigma2S, idx$sigma2B, idx$sigma2E)) move(j, rgamma(1, 2, 2) + 0.05)
  for (j in idx$muB) move(j, rnorm(1))
  for (j in idx$lambdaZ) move(j, 20 * rgamma(1, 2, 2))  # S-GaSP only
  move(idx$alphaS[p + q], 2)  # alpha = 2 and 1 take special branches
  for (j in idx$alphaB[1]) move(j, 1)
  rows[[length(rows) + 1]] <- random_phi(p, q, discrepancy)  # every coordinate at once
  rows[[length(rows) + 1]] <- phi0
  do.call(rbind, rows)
}
