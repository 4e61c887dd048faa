# Plain-R references for sensitivity(): the emulator's posterior mean at one
# parameter draw written from the dense joint covariance (helper-dense.R),
#   mu(z) = s2S R(z, X) C^-1 (yf - muB, ys),   X = ((Xf, kappa); Xs),
# and its Sobol variances by a tensor product of composite Gauss-Legendre
# rules on the inputs' ranges, split at every centre's coordinate (the
# Matern and power exponential correlations are not smooth there), so that
# the grid integrates mu, mu^2 and the conditional means to near machine
# precision for the smooth families.

# Every |actual - expected| below tol (an absolute error: indices near 0
# are compared as strictly as large ones).
expect_abs <- function(actual, expected, tol) {
  expect_identical(length(actual), length(expected))
  expect_lt(max(abs(actual - expected)), tol)
}

# Two fits of the same model on two algebras: the same indices and shares
# (same seed, 2 draws, `paths` support points).
expect_same_sensitivity <- function(fit, other, paths, shares = TRUE, tol = 1e-6) {
  set.seed(1)
  a <- sensitivity(fit, ndraws = 2, points = 8, paths = paths)
  set.seed(1)
  b <- sensitivity(other, ndraws = 2, points = 8, paths = paths)
  expect_abs(b$draws$simulator, a$draws$simulator, tol)
  expect_abs(b$draws$prediction, a$draws$prediction, tol)
  if (shares) expect_abs(b$shares$share, a$shares$share, tol)
  invisible(list(a = a, b = b))
}

# The weights a and centres X of mu at the scaled-space draw phi.
plain_sim_mean <- function(fit, phi, kernS) {
  d <- fit$model$data
  p <- ncol(d$Xf); q <- ncol(d$Xs) - p; n <- nrow(d$Xf)
  th <- unpack_phi(phi, p, q)
  C <- dense_cov(d$Xf, d$Xs, phi, fit$settings$nugget, kernS, "powexp")
  list(a = th$sigma2S * solve(C, c(d$yf - th$muB, d$ys)),
       X = rbind(cbind(d$Xf, matrix(th$kappa, n, q, byrow = TRUE)), d$Xs), th = th)
}

# Composite Gauss-Legendre nodes and weights (summing to one) on [lo, hi],
# panels split at `breaks`; `dens`: a density to weight them by.
composite_rule <- function(breaks, lo = 0, hi = 1, k = 10, dens = NULL) {
  gl <- FBC:::gauss_legendre01(k)
  b <- sort(unique(c(lo, breaks[breaks > lo & breaks < hi], hi)))
  x <- unlist(lapply(seq_len(length(b) - 1), function(i) b[i] + (b[i + 1] - b[i]) * gl$x))
  w <- unlist(lapply(seq_len(length(b) - 1), function(i) (b[i + 1] - b[i]) * gl$w))
  if (!is.null(dens)) w <- w * dens(x)
  list(x = x, w = w / sum(w))
}

# Sobol indices of mu (p + q = 3 inputs) on the tensor grid of `rules`
# (one per input), and the main effects E[mu | z_k = t] at `at` (a matrix,
# one column per input).
plain_sobol <- function(mp, kernS, rules, at = NULL) {
  X <- mp$X
  D <- ncol(X)
  R <- lapply(seq_len(D), function(j) {
    dense_corr(rules[[j]]$x, X[, j], mp$th$thetaS[j], mp$th$alphaS[j], kernS)
  })
  G <- lengths(lapply(rules, `[[`, "x"))
  f <- array(0, G)
  for (i3 in seq_len(G[3])) f[, , i3] <- R[[1]] %*% (mp$a * R[[3]][i3, ] * t(R[[2]]))
  w <- Reduce(`%o%`, lapply(rules, `[[`, "w"))
  f0 <- sum(w * f)
  V <- sum(w * f^2) - f0^2
  V1 <- VT <- numeric(D)
  for (j in seq_len(D)) {
    wj <- rules[[j]]$w
    e1 <- apply(w * f, j, sum) / wj
    V1[j] <- sum(wj * e1^2) - f0^2
    wk <- apply(w, seq_len(D)[-j], sum)
    ek <- apply(w * f, seq_len(D)[-j], sum) / wk
    VT[j] <- V - (sum(wk * ek^2) - f0^2)
  }
  main <- NULL
  if (!is.null(at)) {
    # E[mu | z_j = t] = sum_i a_i r(t - X_ij) prod_{k != j} E r(z_k - X_ik)
    I1 <- sapply(seq_len(D), function(j) colSums(rules[[j]]$w * R[[j]]))
    main <- sapply(seq_len(D), function(j) {
      Rt <- dense_corr(at[, j], X[, j], mp$th$thetaS[j], mp$th$alphaS[j], kernS)
      drop(Rt %*% (mp$a * apply(I1[, -j, drop = FALSE], 1, prod)))
    })
  }
  list(S1 = V1 / V, ST = VT / V, main = main)
}

test_that("the closed-form indices are those of the emulator's mean integrated on a fine grid (Gaussian, Matern)", {
  set.seed(5)
  phi <- random_phi(2, 1)
  phi[2:4] <- c(20, 60, 40)  # thetaS: a mean with structure on the box
  for (kern in c("gaussian", "matern52", "matern32")) {
    fit <- fixed_fit(phi, kernelS = kern)
    sc <- fit$model$scale
    mp <- plain_sim_mean(fit, phi, kern)
    rules <- lapply(1:3, function(j) composite_rule(mp$X[, j]))
    s <- sensitivity(fit, paths = 0, prediction = FALSE)
    at <- sapply(s$main$simulator, function(me) me$x)
    ref <- plain_sobol(mp, kern, rules, at = sweep(sweep(at, 2, sc$xmin), 2, sc$xmax - sc$xmin, "/"))
    # every draw is phi: one value of each index
    expect_equal(s$simulator$lower, s$simulator$upper, tolerance = 1e-12)
    expect_abs(unname(s$draws$simulator[1, , "first"]), ref$S1, 1e-6)
    expect_abs(unname(s$draws$simulator[1, , "total"]), ref$ST, 1e-6)
    expect_abs(s$simulator$median, c(ref$S1, ref$ST), 1e-6)
    # a non-additive mean: the total indices exceed the first-order ones
    expect_true(all(ref$ST - ref$S1 > 0.01))
    # the main effects in the response's units
    me <- sapply(s$main$simulator, function(me) me$median)
    expect_abs(unname(me), sc$ymean + sc$ysd * ref$main, 1e-6)
  }
})

test_that("the prediction's closed-form indices are those of predict()'s mean integrated on a fine grid", {
  set.seed(7)
  for (case in list(c("matern52", "matern32", "gp"), c("gaussian", "gaussian", "gp"),
                    c("matern52", "matern52", "sgasp"))) {
    phi <- random_phi(2, 1, case[3])
    phi[2:4] <- c(20, 60, 40)
    fit <- fixed_fit(phi, kernelS = case[1], kernelB = case[2], discrepancy = case[3])
    sc <- fit$model$scale
    d <- fit$model$data
    s <- sensitivity(fit, ndraws = 2, points = 8)
    # predict()'s mean (every draw is phi) on a tensor grid split at the
    # runs' and the field inputs' coordinates, in the inputs' units
    rules <- lapply(1:2, function(k) composite_rule(c(d$Xs[, k], d$Xf[, k])))
    u <- lapply(1:2, function(k) sc$xmin[k] + (sc$xmax[k] - sc$xmin[k]) * rules[[k]]$x)
    X <- as.matrix(expand.grid(x1 = u[[1]], x2 = u[[2]]))
    f <- matrix(predict(fit, X, type = "mean", ndraws = 1)$pred, length(u[[1]]))
    w <- rules[[1]]$w %o% rules[[2]]$w
    f0 <- sum(w * f)
    V <- sum(w * f^2) - f0^2
    e1 <- drop(f %*% rules[[2]]$w)
    e2 <- drop(rules[[1]]$w %*% f)
    V1 <- c(sum(rules[[1]]$w * e1^2), sum(rules[[2]]$w * e2^2)) - f0^2
    # two inputs: the total index of one is 1 - the other's first-order
    ref <- c(V1 / V, 1 - rev(V1) / V)
    expect_abs(as.vector(s$draws$prediction[1, , ]), ref, 1e-6)
    expect_abs(s$prediction$median, ref, 1e-6)
    expect_true(all(ref[3:4] - ref[1:2] > 0.01))
    # the main effects E[zeta | x_k = t] in the response's units
    for (k in 1:2) {
      t <- s$main$prediction[[k]]$x
      Xk <- X[rep(seq_along(u[[3 - k]]), length(t)), , drop = FALSE]
      Xk[, 3 - k] <- rep(u[[3 - k]], length(t))
      Xk[, k] <- rep(t, each = length(u[[3 - k]]))
      g <- matrix(predict(fit, Xk, type = "mean", ndraws = 1)$pred, length(u[[3 - k]]))
      expect_abs(s$main$prediction[[k]]$median, drop(rules[[3 - k]]$w %*% g), 1e-6)
    }
  }
})

test_that("a range or a density given in `inputs` is the measure integrated against", {
  set.seed(6)
  phi <- random_phi(2, 1)
  phi[2:4] <- c(15, 30, 25)
  for (kern in c("gaussian", "matern52")) {
    fit <- fixed_fit(phi, kernelS = kern)
    sc <- fit$model$scale
    mp <- plain_sim_mean(fit, phi, kern)
    # x1 uniform on a sub-range (native units, x1 = 10 x scaled); t by a
    # density on the design's range (a beta(2, 3) on the scaled t)
    lo <- (2.5 - sc$xmin[1]) / (sc$xmax[1] - sc$xmin[1])
    hi <- (7 - sc$xmin[1]) / (sc$xmax[1] - sc$xmin[1])
    dt <- function(x) stats::dbeta((x - sc$xmin[3]) / (sc$xmax[3] - sc$xmin[3]), 2, 3)
    s <- sensitivity(fit, inputs = list(x1 = c(2.5, 7), t = dt), paths = 0, prediction = FALSE)
    rules <- list(composite_rule(mp$X[, 1], lo, hi), composite_rule(mp$X[, 2]),
                  composite_rule(mp$X[, 3], dens = function(x) stats::dbeta(x, 2, 3)))
    ref <- plain_sobol(mp, kern, rules)
    expect_abs(unname(s$draws$simulator[1, , "first"]), ref$S1, 1e-6)
    expect_abs(unname(s$draws$simulator[1, , "total"]), ref$ST, 1e-6)
    expect_identical(unname(s$settings$measure),
                     c("uniform on [2.5, 7]", "uniform over the design's range",
                       "the density given, over the design's range"))
    # the main effect of x1 spans the range given
    expect_equal(range(s$main$simulator$x1$x), c(2.5, 7))
  }
})

test_that("the power exponential's quadrature is accurate to about 1e-3", {
  # 64 Gauss-Legendre nodes against a correlation with a cusp at each centre
  # (alpha < 2): the accuracy the help page states
  set.seed(5)
  phi <- random_phi(2, 1)
  phi[2:4] <- c(20, 60, 40)
  fit <- fixed_fit(phi)
  mp <- plain_sim_mean(fit, phi, "powexp")
  ref <- plain_sobol(mp, "powexp", lapply(1:3, function(j) composite_rule(mp$X[, j], k = 16)))
  s <- sensitivity(fit, paths = 0, prediction = FALSE)
  expect_abs(unname(s$draws$simulator[1, , "first"]), ref$S1, 1e-3)
  expect_abs(unname(s$draws$simulator[1, , "total"]), ref$ST, 1e-3)
})

# A calibration problem with known indices: y = x1 + 2 x2 + t on the unit
# cube (the simulator's S = ST = (1, 4, 1) / 6), the field at t = 0.5 with
# small noise (the mean response x1 + 2 x2 + 0.5: S = ST = (1, 4) / 5).
linear_fit <- function() {
  set.seed(2)
  m <- 40
  Xs <- cbind(x1 = runif(m), x2 = runif(m), t = runif(m))
  sim <- cbind(y = Xs[, 1] + 2 * Xs[, 2] + Xs[, 3], Xs)
  Xf <- cbind(x1 = runif(8), x2 = runif(8))
  field <- cbind(y = Xf[, 1] + 2 * Xf[, 2] + 0.5 + rnorm(8, 0, 0.02), Xf)
  # the random field inputs may overhang the random design
  suppressWarnings(calibrate(sim, field, nMCMC = 400, nBurn = 200, nChains = 1,
                             kernelS = "gaussian"), classes = "fbc_extrapolation")
}

test_that("the indices of a linear simulator are recovered", {
  fit <- linear_fit()
  sc <- fit$model$scale
  s <- sensitivity(fit, ndraws = 100)
  # over the design's box (not exactly the unit cube): variances w_k^2 r_k^2 / 12
  r <- (sc$xmax - sc$xmin) * c(1, 2, 1)
  S <- r^2 / sum(r^2)
  sim <- s$simulator
  expect_abs(sim$median, c(S, S), 0.01)
  expect_true(all(sim$lower <= sim$median & sim$median <= sim$upper))
  expect_true(all(sim$mcse >= 0 & sim$mcse < 0.01))
  # the prediction over x1, x2 (kappa's value adds a constant): (1, 4) / 5
  # on the box of the experimental inputs
  rp <- r[1:2]
  Sp <- rp^2 / sum(rp^2)
  expect_abs(s$prediction$median, c(Sp, Sp), 0.02)
  expect_identical(s$prediction$role, rep("experimental", 4))
  expect_identical(s$simulator$role, rep(c("experimental", "experimental", "calibration"), 2))
  # the sampling estimator recovers them too, within its sampling error
  set.seed(3)
  e <- sensitivity(fit, ndraws = 50, estimator = "sampling")
  expect_abs(e$simulator$median, c(S, S), 0.02)
  expect_abs(e$prediction$median, c(Sp, Sp), 0.03)
  expect_true(all(e$simulator$sampling_sd < 0.03))
})

test_that("the variance shares sum to one and to predict()'s squared standard error over the box", {
  fit <- linear_fit()
  sc <- fit$model$scale
  s <- sensitivity(fit, ndraws = 50, points = 64)
  sh <- s$shares
  expect_identical(sh$source, c("kappa", "bias", "emulator", "noise"))
  expect_equal(sum(sh$share), 1, tolerance = 1e-12)
  expect_equal(sh$share, sh$variance / sum(sh$variance), tolerance = 1e-12)
  # predict()'s se^2 averaged over the same quasi-random points of the box
  X <- s$points
  expect_identical(dim(X), c(64L, 2L))
  expect_true(all(X[, 1] >= sc$xmin[1] & X[, 1] <= sc$xmax[1]))
  w <- rep(1 / nrow(X), nrow(X))
  field <- predict(fit, X, type = "field", ndraws = 50)
  mean <- predict(fit, X, type = "mean", ndraws = 50)
  expect_equal(sum(sh$variance), sum(w * field$se^2), tolerance = 1e-8)
  expect_equal(sum(sh$variance[sh$source != "noise"]), sum(w * mean$se^2), tolerance = 1e-8)
  # the noise share: the draws' mean measurement error variance
  expect_equal(sh$variance[sh$source == "noise"], mean(field$se^2 - mean$se^2), tolerance = 1e-8)
})

test_that("print() shows the indices, the intervals and the shares", {
  set.seed(5)
  phi <- random_phi(2, 1)
  phi[2:4] <- c(20, 60, 40)
  fit <- fixed_fit(phi, kernelS = "gaussian")
  expect_snapshot(print(sensitivity(fit, points = 64)))
  expect_snapshot(print(sensitivity(fit, prediction = FALSE, level = 0.5), digits = 5))
  # the sampling estimator adds each index's sampling error
  set.seed(4)
  expect_snapshot(print(sensitivity(fit, ndraws = 4, points = 16, estimator = "sampling",
                                    samples = 500), digits = 2))
})

test_that("bad arguments and unsupported fits are errors naming the argument", {
  set.seed(5)
  fit <- fixed_fit(random_phi(2, 1))
  expect_snapshot(error = TRUE, {
    sensitivity(fit, ndraws = 1)
    sensitivity(fit, ndraws = "all")
    sensitivity(fit, level = 1.5)
    sensitivity(fit, level = c(0.5, 0.9))
    sensitivity(fit, prediction = NA)
    sensitivity(fit, points = 1)
    sensitivity(fit, draws = 10)
    sensitivity(list(a = 1))
    sensitivity(fit, inputs = list(1, 2))
    sensitivity(fit, inputs = list(z = c(0, 1)))
    sensitivity(fit, inputs = list(x1 = c(5, 1)))
    sensitivity(fit, inputs = list(x1 = "wide"))
    sensitivity(fit, inputs = list(t = function(x) -x))
    sensitivity(fit, estimator = "exact")
    sensitivity(fit, samples = 1)
    plot(sensitivity(fit, prediction = FALSE), of = "prediction")
  })
  # the fits without one kernel expansion of the simulator's mean
  set.seed(3)
  field <- data.frame(y = rnorm(6), x = seq(0, 1, length.out = 6))
  fun <- suppressWarnings(calibrate(function(x, kappa) kappa[["a"]] * x$x, field,
                                    kappaDist = "uniform", kappaP1 = c(a = 0), kappaP2 = 2,
                                    nMCMC = 6, nBurn = 2, nChains = 1))
  expect_snapshot(error = TRUE, sensitivity(fun))
  # sample paths on a product design with missing cells (the Kronecker
  # algebra's correction has no whitening for them); paths = 0 runs
  g <- expand.grid(i = 1:6, j = 1:4)
  Xs <- cbind(x = seq(0, 1, length.out = 6)[g$i], t = seq(0, 1, length.out = 4)[g$j])
  sim <- cbind(y = Xs[, 1] + Xs[, 2], Xs)
  sim[c(3, 11), "y"] <- NA
  kr <- suppressWarnings(suppressMessages(calibrate(sim, field, nMCMC = 40, nBurn = 20,
                                                    nChains = 1, converge = FALSE)))
  expect_identical(kr$model$algebra$missing, 2L)
  expect_snapshot(error = TRUE, sensitivity(kr, ndraws = 2))
  expect_s3_class(sensitivity(kr, ndraws = 2, paths = 0, points = 8), "fbc_sensitivity")
})

test_that("the nearest-neighbour algebra with every predecessor gives the dense algebra's indices", {
  set.seed(5)
  phi <- random_phi(2, 1)
  phi[2:4] <- c(20, 60, 40)
  dense <- fixed_fit(phi, kernelS = "matern52")
  # 12 runs: every run and field latent conditions on all its predecessors
  vec <- fixed_fit(phi, kernelS = "matern52", algebra = "vecchia", neighbours = 12)
  expect_identical(vec$model$algebra$name, "vecchia")
  for (paths in c(0, 16)) {
    ab <- expect_same_sensitivity(dense, vec, paths)
    me <- function(s) unlist(lapply(s$main$simulator, `[[`, "median"))
    expect_abs(me(ab$b), me(ab$a), 1e-6 * max(abs(me(ab$a))))
  }
  # with fewer neighbours: an approximation, near the exact indices here
  set.seed(1)
  few <- sensitivity(fixed_fit(phi, kernelS = "matern52", algebra = "vecchia", neighbours = 6),
                     ndraws = 2, points = 8, paths = 0)
  set.seed(1)
  a <- sensitivity(dense, ndraws = 2, points = 8, paths = 0)
  expect_abs(few$draws$simulator, a$draws$simulator, 0.05)
})

test_that("the Kronecker algebra's indices are the dense algebra's on a product design", {
  # 6 experimental settings x 4 calibration settings: Ds^-1 by the two
  # eigendecompositions (sampled indices too, for the same random numbers)
  set.seed(8)
  d <- random_koh_data(n = 7, m = 24, p = 2, q = 1, seed = 8)
  g <- expand.grid(i = 1:6, j = 1:4)
  d$Xs <- cbind(matrix(runif(12), 6, 2)[g$i, ], seq(0.1, 0.9, length.out = 4)[g$j])
  phi <- random_phi(2, 1)
  phi[2:4] <- c(8, 20, 10)
  dense <- fixed_fit(phi, kernelS = "matern52", d = d, algebra = "dense")
  kron <- fixed_fit(phi, kernelS = "matern52", d = d)  # "auto": the product design
  expect_identical(kron$model$algebra$name, "kronecker")
  for (est in c("closed", "sampling")) {
    set.seed(1)
    a <- sensitivity(dense, ndraws = 2, points = 8, paths = 16, estimator = est, samples = 200)
    set.seed(1)
    b <- sensitivity(kron, ndraws = 2, points = 8, paths = 16, estimator = est, samples = 200)
    expect_abs(b$draws$simulator, a$draws$simulator, 1e-8)
    expect_abs(b$draws$prediction, a$draws$prediction, 1e-8)
  }
})

test_that("the sampling estimator agrees with the closed form within its sampling error", {
  set.seed(5)
  phi <- random_phi(2, 1)
  phi[2:4] <- c(8, 20, 10)
  for (kern in c("gaussian", "matern32")) {
    fit <- fixed_fit(phi, kernelS = kern)
    set.seed(1)
    cl <- sensitivity(fit, ndraws = 2, points = 8, paths = 0)
    set.seed(1)
    sa <- sensitivity(fit, ndraws = 2, points = 8, paths = 0, estimator = "sampling",
                      samples = 4000)
    expect_identical(sa$settings$estimator, "sampling")
    expect_identical(cl$settings$estimator, "closed")
    for (part in c("simulator", "prediction")) {
      x <- sa[[part]]
      y <- cl[[part]]
      expect_true(all(x$sampling_sd > 0 & x$sampling_sd < 0.05))
      expect_true(all(abs(x$median - y$median) < 4 * x$sampling_sd + 1e-9))
      # the first-order variances by quadrature are exact: each draw's
      # first-order indices differ from the closed form's by one factor (the
      # sampled total variance) for every input
      ratio <- sa$draws[[part]][, , "first"] / cl$draws[[part]][, , "first"]
      expect_lt(max(abs(ratio - rowMeans(ratio))), 1e-5)
      expect_lt(max(abs(ratio - 1)), 0.2)
    }
    # the main effects are in closed form either way
    expect_equal(sa$main, cl$main, tolerance = 1e-10)
  }
  # more samples, a smaller sampling error: about 1 / sqrt(samples)
  fit <- fixed_fit(phi, kernelS = "gaussian")
  set.seed(2)
  small <- sensitivity(fit, ndraws = 2, points = 8, paths = 0, estimator = "sampling",
                       samples = 500, prediction = FALSE)
  set.seed(2)
  large <- sensitivity(fit, ndraws = 2, points = 8, paths = 0, estimator = "sampling",
                       samples = 8000, prediction = FALSE)
  r <- small$simulator$sampling_sd / large$simulator$sampling_sd
  expect_true(all(r > 2.5 & r < 6))
})

test_that("the estimator is the closed form up to 2000 centres", {
  fit <- linear_fit()
  expect_identical(FBC:::sensitivity_estimator(fit, 128, "auto"), "closed")
  expect_identical(FBC:::sensitivity_estimator(fit, 128, "sampling"), "sampling")
  N <- nrow(fit$model$data$Xs) + nrow(unique(fit$model$data$Xf))
  expect_identical(FBC:::sensitivity_estimator(fit, 2000 - N, "auto"), "closed")
  expect_identical(FBC:::sensitivity_estimator(fit, 2001 - N, "auto"), "sampling")
})

test_that("set.seed() reproduces sensitivity(), which leaves the fit as it was", {
  fit <- linear_fit()
  before <- fit
  set.seed(99)
  a <- sensitivity(fit, ndraws = 20, points = 64)
  set.seed(99)
  b <- sensitivity(fit, ndraws = 20, points = 64)
  expect_identical(a, b)
  expect_identical(fit, before)
  # the draws used: evenly spaced, as predict() takes them
  expect_identical(a$settings$draw_rows, FBC:::draw_rows(nrow(fit$Phi), 20))
  expect_identical(a$settings$ndraws, 20L)
  expect_identical(dim(a$draws$simulator), c(20L, 3L, 2L))
  expect_identical(dim(a$draws$prediction), c(20L, 2L, 2L))
  # a wider level: wider intervals about the same medians
  set.seed(99)
  w <- sensitivity(fit, ndraws = 20, points = 64, level = 0.99)
  expect_identical(w$simulator$median, a$simulator$median)
  expect_true(all(w$simulator$lower <= a$simulator$lower & w$simulator$upper >= a$simulator$upper))
})

test_that("as.data.frame() stacks the indices; plot() draws the main effects and the indices", {
  fit <- linear_fit()
  s <- sensitivity(fit, ndraws = 20, points = 64)
  df <- as.data.frame(s)
  expect_identical(names(df), c("of", "input", "role", "index", "median", "lower", "upper", "mcse"))
  expect_identical(nrow(df), 2L * 3L + 2L * 2L)
  expect_identical(df$of, rep(c("simulator", "prediction"), c(6, 4)))
  expect_identical(df$input, c(rep(c("x1", "x2", "t"), 2), rep(c("x1", "x2"), 2)))
  expect_equal(df$median, c(s$simulator$median, s$prediction$median))
  s0 <- sensitivity(fit, ndraws = 20, prediction = FALSE)
  expect_identical(nrow(as.data.frame(s0)), 6L)
  for (what in c("main", "indices")) {
    for (of in c("simulator", "prediction")) {
      g <- plot(s, what = what, of = of)
      expect_s3_class(g, "ggplot")
      built <- ggplot2::ggplot_build(g)
      n_in <- if (of == "simulator") 3L else 2L
      if (what == "main") {
        expect_identical(length(unique(built$data[[1]]$PANEL)), n_in)
      } else {
        expect_identical(nrow(built$data[[1]]), 2L * n_in)
      }
    }
  }
})

test_that("a draw's sample path has the emulator's conditional mean and covariance at its support points", {
  set.seed(5)
  phi <- random_phi(2, 1)
  phi[2:4] <- c(20, 60, 40)
  fit <- fixed_fit(phi, kernelS = "gaussian")
  mp <- plain_sim_mean(fit, phi, "gaussian")
  th <- mp$th
  P <- matrix(c(0.2, 0.5, 0.8, 0.7, 0.1, 0.4, 0.3, 0.9, 0.6), 3, 3)
  corr <- function(A, B) {
    Reduce(`*`, lapply(1:3, function(j) dense_corr(A[, j], B[, j], th$thetaS[j], th$alphaS[j], "gaussian")))
  }
  d <- fit$model$data
  C <- dense_cov(d$Xf, d$Xs, phi, fit$settings$nugget, "gaussian", "powexp")
  K <- th$sigma2S * corr(P, mp$X)
  mu <- drop(K %*% (mp$a / th$sigma2S))
  Sig <- th$sigma2S * corr(P, P) - K %*% solve(C, t(K))
  n <- 3000
  phis <- FBC:::sampler_draws(fit, rep(1L, n))
  sup <- P[rep(seq_len(3), n), ]
  set.seed(9)
  paths <- FBC:::at_draws(fit, FBC:::.fbc_sim_mean_c, phis, support = sup)
  g <- t(vapply(paths, function(e) drop(corr(P, e$Z) %*% e$w), numeric(3)))
  # the paths' values at P: mean mu, covariance Sig (Monte Carlo: n draws)
  sds <- sqrt(diag(Sig))
  expect_true(all(abs(colMeans(g) - mu) < 4 * sds / sqrt(n)))
  expect_lt(max(abs(stats::cov(g) - Sig)) / max(diag(Sig)), 0.1)
  expect_gt(min(sds), 1e-3)
  # without support points the expansion is the mean itself
  m0 <- FBC:::at_draws(fit, FBC:::.fbc_sim_mean_c, phis[1, , drop = FALSE],
                       support = matrix(0, 0, 3))[[1]]
  expect_equal(drop(corr(P, m0$Z) %*% m0$w), mu, tolerance = 1e-8)
})

# Categorical inputs and several outputs. The references: the emulator's
# posterior mean at a draw phi written from the dense joint covariance with
# the levels' correlations (dense_cov()), a sum over its centres of a
# product of one factor per input of the measure (a numeric input's
# correlation, a categorical input's level correlation C[l, a_n]) times the
# factors of the levels held (an output), integrated on a tensor grid:
# composite Gauss-Legendre rules split at the centres for a numeric input,
# the levels with their probabilities for a categorical one.

# One numeric experimental input x, one categorical input c (3 levels) and
# a calibration input t; a short chain (the draws differ).
level_fit <- function(seed = 3, m = 30, kernel = "matern52", discrepancy = "gp", ...) {
  set.seed(seed)
  lev <- c("a", "b", "c")
  x <- runif(m); t <- runif(m); cc <- factor(sample(lev, m, TRUE), lev)
  eff <- c(a = 0, b = 1, c = -0.5)
  f <- function(x, cc, t) sin(3 * x) + eff[as.character(cc)] * (1 + x) + t^2
  sim <- data.frame(y = f(x, cc, t), x = x, c = cc, t = t)
  xf <- runif(9); cf <- factor(rep(lev, 3), lev)
  field <- data.frame(y = f(xf, cf, 0.4) + rnorm(9, 0, 0.05), x = xf, c = cf)
  suppressWarnings(calibrate(sim, field, nMCMC = 40, nBurn = 20, nChains = 1, converge = FALSE,
                             kernelS = kernel, kernelB = kernel, discrepancy = discrepancy, ...),
                   classes = "fbc_extrapolation")
}

# The prediction's per-draw indices over x and the categorical c (uniform
# over its levels) from predict()'s per-draw means on a tensor grid.
expect_level_prediction <- function(fit, s) {
  d <- fit$model$data
  sc <- fit$model$scale
  r <- composite_rule(c(d$Xs[, 1], d$Xf[, 1]))
  u <- sc$xmin[1] + (sc$xmax[1] - sc$xmin[1]) * r$x
  nd <- expand.grid(x = u, c = factor(c("a", "b", "c"), c("a", "b", "c")))
  pr <- predict(fit, nd, type = "mean", ndraws = 2, draws = TRUE)$draws
  for (i in 1:2) {
    f <- matrix(pr[, i], length(u))
    w <- r$w %o% rep(1 / 3, 3)
    f0 <- sum(w * f)
    V <- sum(w * f^2) - f0^2
    V1 <- c(sum(r$w * drop(f %*% rep(1 / 3, 3))^2), sum(rep(1 / 3, 3) * drop(r$w %*% f)^2)) - f0^2
    ref <- c(V1 / V, 1 - rev(V1) / V)
    expect_abs(as.vector(s$draws$prediction[i, , ]), ref, 1e-6)
  }
}

# Two outputs sharing the rate t (two_outputs()), shared or independent.
outputs_fit <- function(outputs, m = 16, kernel = "matern52") {
  tw <- two_outputs(m = m)
  set.seed(4)
  suppressWarnings(calibrate(tw$sim, tw$field, output = "out", outputs = outputs, nMCMC = 40,
                             nBurn = 20, nChains = 1, converge = FALSE, kernelS = kernel,
                             kernelB = kernel), classes = "fbc_extrapolation")
}

# The codes (1-based levels) of the rows of X for categorical input f of
# `levels` (list(col, ncol, L)).
level_codes <- function(X, levels, f) {
  cols <- levels$col[f] + seq_len(levels$ncol[f]) - 1L
  if (length(cols) == 1L) 1L + (X[, cols] > 0.5) else max.col(X[, cols, drop = FALSE], "first")
}

# The emulator's mean at phi on data d as weights a and centres X (all
# columns), with th the parameters by class.
plain_level_mean <- function(d, phi, nugget, kern, levels, noise, G) {
  p <- ncol(d$Xf); q <- ncol(d$Xs) - p; n <- nrow(d$Xf)
  th <- unpack_phi(phi, p, q, "gp", G, FBC:::level_count(levels))
  C <- dense_cov(d$Xf, d$Xs, phi, nugget, kern, kern, "gp", noise, levels)
  list(a = th$sigma2S * solve(C, c(d$yf - th$muB, d$ys)),
       X = rbind(cbind(d$Xf, matrix(th$kappa, n, q, byrow = TRUE)), d$Xs), th = th)
}

# First-order and total indices of the mean over the inputs `num` (numeric
# columns) and the categorical inputs `cat` (indices into levels, uniform
# over their levels), the categorical inputs `held` at the levels `at`.
plain_level_sobol <- function(mp, kern, levels, num, cat = integer(), held = integer(),
                              at = integer()) {
  X <- mp$X
  th <- mp$th
  Cs <- list()
  off <- 0
  for (f in seq_along(levels$L)) {
    L <- levels$L[f]
    Cs[[f]] <- level_corr_plain(L, th$rhoS[off + seq_len(L * (L - 1) / 2)])
    off <- off + L * (L - 1) / 2
  }
  a <- mp$a
  for (i in seq_along(held)) a <- a * Cs[[held[i]]][at[i], level_codes(X, levels, held[i])]
  Fm <- list(); w <- list()
  for (k in num) {
    r <- composite_rule(X[, k])
    Fm[[length(Fm) + 1]] <- dense_corr(r$x, X[, k], th$thetaS[k], th$alphaS[k], kern)
    w[[length(w) + 1]] <- r$w
  }
  for (f in cat) {
    Fm[[length(Fm) + 1]] <- Cs[[f]][, level_codes(X, levels, f), drop = FALSE]
    w[[length(w) + 1]] <- rep(1 / levels$L[f], levels$L[f])
  }
  J <- length(Fm)
  G <- vapply(Fm, nrow, 1L)
  f <- array(0, G)
  if (J == 2) f[] <- Fm[[1]] %*% (a * t(Fm[[2]]))
  if (J == 3) for (i3 in seq_len(G[3])) f[, , i3] <- Fm[[1]] %*% (a * Fm[[3]][i3, ] * t(Fm[[2]]))
  W <- Reduce(`%o%`, w)
  f0 <- sum(W * f)
  V <- sum(W * f^2) - f0^2
  V1 <- VT <- numeric(J)
  for (j in seq_len(J)) {
    e1 <- apply(W * f, j, sum) / w[[j]]
    V1[j] <- sum(w[[j]] * e1^2) - f0^2
    wk <- apply(W, seq_len(J)[-j], sum)
    ek <- apply(W * f, seq_len(J)[-j], sum) / wk
    VT[j] <- V - (sum(wk * ek^2) - f0^2)
  }
  list(S1 = V1 / V, ST = VT / V)
}

test_that("a categorical input's closed-form indices are those of the emulator's mean summed over its levels", {
  fit <- level_fit()
  mc <- fit$model$spec$model
  d <- fit$model$data
  expect_identical(mc$levels$ncol, 3L)
  s <- sensitivity(fit, ndraws = 2, paths = 0, points = 8)
  expect_identical(s$settings$inputs, c("x", "c", "t"))
  expect_identical(unname(s$settings$measure[2]), "uniform over its levels")
  expect_identical(dimnames(s$draws$simulator)[[2]], c("x", "c", "t"))
  phis <- FBC:::sampler_draws(fit, s$settings$draw_rows)
  p <- ncol(d$Xf)
  for (i in 1:2) {
    mp <- plain_level_mean(d, phis[i, ], fit$settings$nugget, "matern52", mc$levels, NULL, 1L)
    # x, then c, then t (the calibration input, column p + 1)
    ref <- plain_level_sobol(mp, "matern52", mc$levels, num = c(1, p + 1), cat = 1)
    o <- c(1, 3, 2)
    expect_abs(unname(s$draws$simulator[i, , "first"]), ref$S1[o], 1e-6)
    expect_abs(unname(s$draws$simulator[i, , "total"]), ref$ST[o], 1e-6)
  }
  expect_gt(min(s$simulator$median[s$simulator$input == "c"]), 0.3)
  # the main effect at each level: E[mu | c = l]
  expect_identical(s$main$simulator$c$level, c("a", "b", "c"))
  expect_identical(s$main$simulator$c$x, 1:3)
  # the prediction's indices: predict()'s per-draw means on a tensor grid,
  # with the KOH bias and the S-GaSP one (its weights carry the levels too)
  expect_level_prediction(fit, s)
  sg <- level_fit(discrepancy = "sgasp")
  expect_level_prediction(sg, sensitivity(sg, ndraws = 2, paths = 0, points = 8))
  # level probabilities given: a point mass makes the input's indices 0
  s1 <- sensitivity(fit, ndraws = 2, paths = 0, prediction = FALSE,
                    inputs = list(c = c(b = 1)))
  expect_abs(s1$draws$simulator[, "c", ], rep(0, 4), 1e-9)
  expect_identical(unname(s1$settings$measure[2]), "the level probabilities given")
  pw <- c(0.2, 0.5, 0.3)
  s2 <- sensitivity(fit, ndraws = 2, paths = 0, prediction = FALSE, inputs = list(c = pw))
  s3 <- sensitivity(fit, ndraws = 2, paths = 0, prediction = FALSE,
                    inputs = list(c = c(c = 0.3, a = 0.2, b = 0.5)))
  expect_identical(s2$draws, s3$draws)
})

test_that("shared outputs: the indices at each output are those of the emulator's mean with the output held there", {
  fit <- outputs_fit("shared")
  mc <- fit$model$spec$model
  d <- fit$model$data
  s <- sensitivity(fit, ndraws = 2, paths = 0, points = 8)
  expect_identical(dimnames(s$draws$simulator)[[4]], c("conc", "rate"))
  expect_identical(s$simulator$output, rep(c("conc", "rate"), each = 4))
  expect_identical(unique(s$simulator$input), c("x", "t"))
  phis <- FBC:::sampler_draws(fit, s$settings$draw_rows)
  p <- ncol(d$Xf)
  for (i in 1:2) {
    mp <- plain_level_mean(d, phis[i, ], fit$settings$nugget, "matern52", mc$levels, mc$noise, 2L)
    for (j in 1:2) {
      ref <- plain_level_sobol(mp, "matern52", mc$levels, num = c(1, p + 1), held = 1, at = j)
      expect_abs(unname(s$draws$simulator[i, , "first", j]), ref$S1, 1e-6)
      expect_abs(unname(s$draws$simulator[i, , "total", j]), ref$ST, 1e-6)
    }
  }
  # the two outputs' indices differ (the decay and the linear response)
  expect_gt(max(abs(s$draws$simulator[, , , 1] - s$draws$simulator[, , , 2])), 0.01)
  # the shares sum to one at each output
  expect_identical(s$shares$output, rep(c("conc", "rate"), each = 4))
  for (o in c("conc", "rate")) expect_equal(sum(s$shares$share[s$shares$output == o]), 1, tolerance = 1e-12)
  # the main effects in each output's units
  sc <- fit$model$scale
  me <- s$main$simulator$x
  expect_identical(unique(me$output), c("conc", "rate"))
  expect_gt(abs(mean(me$median[me$output == "conc"]) - mean(me$median[me$output == "rate"])), 0.1)
})

test_that("independent outputs: the indices at each output are those of its own GP's mean", {
  fit <- outputs_fit("independent")
  mc <- fit$model$spec$model
  d <- fit$model$data
  p <- ncol(d$Xf); q <- ncol(d$Xs) - p
  s <- sensitivity(fit, ndraws = 2, paths = 0, points = 8)
  phis <- FBC:::sampler_draws(fit, s$settings$draw_rows)
  idx <- FBC:::param_indices(p, q, "gp", 2L, outputs = 2L)
  for (o in 1:2) {
    rf <- which(d$outF == o); rs <- which(d$outS == o)
    g <- sort(unique(mc$noise[rf]))
    do <- list(Xf = d$Xf[rf, , drop = FALSE], yf = d$yf[rf], Xs = d$Xs[rs, , drop = FALSE],
               ys = d$ys[rs])
    # output o's parameters in the layout of one output
    one <- FBC:::param_indices(p, q, "gp", length(g))
    cols <- unlist(lapply(names(one), function(cl) {
      j <- idx[[cl]]
      if (cl == "kappa") j else if (cl == "sigma2E") j[g] else
        j[(o - 1) * length(one[[cl]]) + seq_along(one[[cl]])]
    }))
    for (i in 1:2) {
      mp <- plain_level_mean(do, phis[i, cols], fit$settings$nugget, "matern52", NULL,
                             match(mc$noise[rf], g), length(g))
      ref <- plain_level_sobol(mp, "matern52", NULL, num = c(1, p + 1))
      expect_abs(unname(s$draws$simulator[i, , "first", o]), ref$S1, 1e-6)
      expect_abs(unname(s$draws$simulator[i, , "total", o]), ref$ST, 1e-6)
    }
    expect_equal(sum(s$shares$share[s$shares$output == c("conc", "rate")[o]]), 1, tolerance = 1e-12)
  }
  # the prediction: predict()'s per-draw means at each output on a grid of x
  sc <- fit$model$scale
  r <- composite_rule(c(d$Xs[, 1], d$Xf[, 1]))
  u <- sc$xmin[1] + (sc$xmax[1] - sc$xmin[1]) * r$x
  for (o in c("conc", "rate")) {
    pr <- predict(fit, data.frame(x = u, out = o), type = "mean", ndraws = 2, draws = TRUE)$draws
    # one experimental input: both indices are one; its main effect is the mean
    expect_abs(as.vector(s$draws$prediction[, , , o]), rep(1, 4), 1e-12)
    me <- s$main$prediction$x
    me <- me[me$output == o, ]
    at <- predict(fit, data.frame(x = me$x, out = o), type = "mean", ndraws = 2, draws = TRUE)$draws
    expect_abs(me$median, apply(at, 1, stats::median), 1e-6)
  }
})

test_that("with levels and outputs the sampling estimator agrees with the closed form within its sampling error", {
  for (fit in list(level_fit(), outputs_fit("shared"))) {
    set.seed(1)
    cl <- sensitivity(fit, ndraws = 2, points = 8, paths = 0)
    set.seed(1)
    sa <- sensitivity(fit, ndraws = 2, points = 8, paths = 0, estimator = "sampling",
                      samples = 3000)
    for (part in c("simulator", "prediction")) {
      x <- sa[[part]]
      y <- cl[[part]]
      expect_identical(x[c("input", "index")], y[c("input", "index")])
      expect_true(all(x$sampling_sd < 0.05))
      expect_true(all(abs(x$median - y$median) < 4 * x$sampling_sd + 1e-9))
    }
    expect_equal(sa$main, cl$main, tolerance = 1e-10)
  }
})

test_that("print(), as.data.frame() and plot() show the levels and the outputs", {
  fit <- level_fit()
  set.seed(2)
  expect_snapshot(print(sensitivity(fit, ndraws = 4, paths = 8, points = 16)))
  sh <- outputs_fit("shared")
  set.seed(2)
  s <- sensitivity(sh, ndraws = 4, paths = 8, points = 16)
  expect_snapshot(print(s))
  df <- as.data.frame(s)
  expect_identical(names(df)[1:3], c("of", "output", "input"))
  expect_identical(nrow(df), 2L * 2L * 2L + 2L * 1L * 2L)
  # one panel row per output; `output =` picks some
  g <- plot(s)
  built <- ggplot2::ggplot_build(g)
  expect_identical(length(unique(built$data[[1]]$PANEL)), 4L)
  g <- plot(s, output = "rate", of = "prediction")
  expect_identical(length(unique(ggplot2::ggplot_build(g)$data[[1]]$PANEL)), 1L)
  expect_s3_class(plot(s, what = "indices"), "ggplot")
  # a categorical input's main effect: a point per level
  s1 <- sensitivity(fit, ndraws = 4, paths = 8, points = 16)
  b <- ggplot2::ggplot_build(plot(s1))
  expect_identical(nrow(b$data[[3]]), 3L)
  expect_snapshot(error = TRUE, {
    sensitivity(fit, inputs = list(c = c(0.5, 0.6, 0.1)))
    sensitivity(fit, inputs = list(c = c(d = 1)))
    sensitivity(fit, inputs = list(c = c(0, 1)))
    sensitivity(sh, inputs = list(out = c(conc = 1)))
    plot(s, output = "speed")
    plot(s1, output = "conc")
  })
})

test_that("levels drawn by their probabilities, an output held at its level; the nearest-neighbour algebra with every predecessor gives the dense indices", {
  fit <- level_fit()
  sc <- fit$model$scale
  m <- FBC:::sensitivity_measure(list(c = c(a = 0.2, b = 0.5, c = 0.3)), sc, fit$model$spec$model)
  set.seed(1)
  n <- 4000
  X <- FBC:::sobol_samples(n / 2, 1L, m)
  lev <- fit$model$spec$model$levels
  freq <- colMeans(X[, lev$col + 0:2])
  expect_true(all(abs(freq - c(0.2, 0.5, 0.3)) < 4 * sqrt(c(0.2, 0.5, 0.3) * 0.8 / n)))
  expect_true(all(rowSums(X[, lev$col + 0:2]) == 1))
  # shared outputs: every support point at the output held
  sh <- outputs_fit("shared")
  ms <- FBC:::sensitivity_measure(NULL, sh$model$scale, sh$model$spec$model, "rate")
  P <- FBC:::support_points(16, 2L, ms)
  expect_true(all(P[, sh$model$spec$model$levels$col] == 1))
  expect_identical(ms$names, c("x", "t"))
  # with every predecessor the nearest-neighbour algebra's mean is the
  # dense one's, sample paths too (the same draws)
  vec <- level_fit(algebra = "vecchia", neighbours = 40)
  expect_identical(vec$model$algebra$name, "vecchia")
  vec <- fit_with_draws(vec, fit$Phi, fit$chain, fit$logPost, fit$logLik)
  for (paths in c(0, 8)) expect_same_sensitivity(fit, vec, paths, shares = FALSE)
})
