# Choosing runs of a stochastic simulator (R/propose_runs.R with simNoise):
# a replicate at a run's input scored beside new inputs, against the
# plain-R look-ahead (helper-design.R) with the noise in the runs' block
# and in each candidate value's variance.

# a 1-D stochastic toy: eta(x, t) = 5 exp(-t x), 6 inputs x 3 replicates,
# noise sd 0.5 (large against the field's 0.05), a short constant-noise fit
noisy_fit <- function(seed = 1) {
  set.seed(seed)
  X <- cbind(x = rep(c(0.3, 0.9, 1.5, 0.3, 0.9, 1.5), 3), t = rep(c(1, 1, 1, 2.4, 2.4, 2.4), 3))
  sim <- cbind(y = 5 * exp(-X[, "t"] * X[, "x"]) + stats::rnorm(nrow(X), 0, 0.5), X)
  xf <- c(0.3, 0.9, 1.5)
  field <- cbind(y = 5 * exp(-1.7 * xf) + stats::rnorm(3, 0, 0.05), x = xf)
  suppressWarnings(calibrate(sim, field, discrepancy = "none", simNoise = "constant",
                             nMCMC = 1200, nBurn = 300, nChains = 1, showProgress = FALSE))
}

test_that("a replicate's and a new input's scores are the plain-R look-ahead's with the noise", {
  fit <- noisy_fit()
  model <- fit$model
  expect_equal(model$design$simNoise$mode, "constant")
  set.seed(2)
  # new inputs, then the 6 runs' inputs (replicates), as propose_runs() has them
  U <- rbind(matrix(stats::runif(16), 8, 2), model$data$Xs)
  for (method in c("joint", "plugin")) {
    parts <- FBC:::design_particles(fit, 30, method)
    # a run's noise variance per draw and candidate: the draw's sigma2R
    r <- FBC:::run_noise(model, parts$phi, U)
    expect_equal(r, matrix(parts$phi[, model$spec$classes == "sigma2R"], nrow(U), 30, byrow = TRUE))
    for (entropy in c(FALSE, method == "plugin")) {
      set.seed(11)
      cpp <- FBC:::look_ahead(parts, U, model, 2, 25, entropy = entropy)
      set.seed(11)
      sys <- lapply(seq_len(nrow(parts$phi)), function(s) draw_system(parts$phi[s, ], model, U))
      ref <- look_ahead_r(sys, parts, U, model, 2, 25, entropy = entropy, noise = t(r))
      expect_identical(cpp$chosen, as.integer(ref$chosen))
      expect_equal(cpp$variance, ref$variance, tolerance = 1e-8)
      expect_equal(cpp$scores, ref$scores, tolerance = 1e-8)
      # the noise matters: scored as noise-free runs the gains differ
      set.seed(11)
      free <- look_ahead_r(sys, parts, U, model, 2, 25, entropy = entropy)
      expect_gt(max(abs(free$scores[, 1] - ref$scores[, 1])), 0.05 * max(abs(ref$scores[, 1])))
    }
  }
  # each draw's conditional at the runs' inputs is eta's given the noisy
  # means: the C++ systems' mean and variance (noise-free) against plain R
  d <- model$data
  phis <- FBC:::design_particles(fit, 5, "joint")$phi
  sys <- FBC:::.design_systems(d$Xf, d$yf, d$Xs, d$ys, phis, U, matrix(0, 0, 1), fbc_nugget,
                                model$spec$model)
  for (s in 1:5) {
    ref <- draw_system(phis[s, ], model, U)
    expect_equal(sys$mu[, s], ref$mu, tolerance = 1e-8)
    expect_equal(sys$v[, s], ref$v, tolerance = 1e-8)
  }
})

test_that("propose_runs() proposes a replicate or a new input by the scores, a replicate at a run's inputs", {
  fit <- noisy_fit()
  model <- fit$model
  raw <- model$raw$sim
  runs <- unique(raw[, c("x", "t")])
  # a new input where the look-ahead expects most of a run (x = 0.9,
  # t = 1.52: kappa's posterior is there) and two where it expects little
  # (x = 0.1, at t = 1.06 and 2.44), then those two alone: a replicate
  # (at x = 0.3, t = 2.4) is scored between them
  good <- data.frame(x = c(0.9, 0.1, 0.1), t = c(1.52, 1.06, 2.44))
  for (cand in list(good, good[-1, ])) {
    set.seed(7)
    pr <- propose_runs(fit, n = 1, candidates = cand, method = "joint")
    U <- rbind(FBC:::scale_inputs(as.matrix(cand), model$scale, 1:2), model$data$Xs)
    set.seed(7)
    la <- FBC:::look_ahead(FBC:::design_particles(fit, 100, "joint"), U, model, 1, 50)
    best <- which.max(la$scores[, 1])
    expect_equal(pr$replicate, best > nrow(cand))
    if (pr$replicate) {
      # exactly a run's inputs (a replicate, not a new input nearby)
      expect_true(any(runs[, "x"] == pr$x & runs[, "t"] == pr$t))
      expect_equal(unlist(runs[best - nrow(cand), ]), c(x = pr$x, t = pr$t))
    } else {
      expect_equal(unlist(pr[c("x", "t")]), unlist(cand[best, ]))
    }
  }
  # the two choices: the good new input first, a replicate without it
  set.seed(7)
  expect_false(propose_runs(fit, n = 1, candidates = good, method = "joint")$replicate)
  set.seed(7)
  expect_true(propose_runs(fit, n = 1, candidates = good[-1, ], method = "joint")$replicate)
})

test_that("design_loop() calls a stochastic f as it is and records its replicates", {
  set.seed(2)
  # noise sd 1.5 over 20 starting runs: replicates are worth proposing
  f <- function(x, kappa) 5 * exp(-kappa[[1]] * x$x) + stats::rnorm(nrow(x), 0, 1.5)
  xf <- seq(0.2, 2.8, length.out = 6)
  field <- data.frame(y = 5 * exp(-1.7 * xf) + stats::rnorm(6, 0, 0.05), x = xf)
  out <- suppressMessages(design_loop(f, field, lower = c(x = 0, t = 0.5), upper = c(x = 3, t = 3),
                                      n0 = 20, batch = 3, budget = 6, simNoise = "constant",
                                      discrepancy = "none", nChains = 1, nMCMC = 800,
                                      showProgress = FALSE))
  expect_equal(out$fit$model$design$simNoise$mode, "constant")
  # each step's replicates: its runs at an earlier run's inputs
  key <- paste(out$sim$x, out$sim$t)
  steps <- rep(seq_len(nrow(out$history)), diff(c(0, out$history$runs)))
  seen <- vapply(seq_along(key), function(i) key[i] %in% key[seq_len(i - 1)], logical(1))
  expect_equal(out$history$replicates, as.integer(tapply(seen, steps, sum)))
  expect_gt(sum(out$history$replicates), 0)
  # a replicate's value is another call's: it differs from its run's
  rep1 <- which(seen)[1]
  expect_false(out$sim$y[rep1] == out$sim$y[match(key[rep1], key)])
  expect_equal(out$fit$model$design$simNoise$replicated, length(unique(key[seen])))
})

test_that("an input-dependent noise: a run's noise variance is its input's exp(gR), a new input's the GP's mean", {
  set.seed(4)
  X <- cbind(x = rep(c(0.3, 0.9, 1.5, 0.3, 0.9, 1.5), 3), t = rep(c(1, 1, 1, 2.4, 2.4, 2.4), 3))
  sim <- cbind(y = 5 * exp(-X[, "t"] * X[, "x"]) + stats::rnorm(nrow(X), 0, 0.1 + 0.2 * X[, "x"]), X)
  xf <- c(0.3, 0.9, 1.5)
  field <- cbind(y = 5 * exp(-1.7 * xf) + stats::rnorm(3, 0, 0.05), x = xf)
  fit <- suppressWarnings(calibrate(sim, field, discrepancy = "none", simNoise = "input",
                                    nMCMC = 300, nBurn = 100, nChains = 1, converge = FALSE,
                                    showProgress = FALSE))
  model <- fit$model
  cls <- model$spec$classes
  phis <- FBC:::design_particles(fit, 10, "joint")$phi
  # at the runs' inputs: exp(gR) (up to the GP's jitter, 1e-6 of sigma2G)
  r <- FBC:::run_noise(model, phis, model$data$Xs)
  expect_equal(r, t(exp(phis[, cls == "gR"])), tolerance = 1e-4)
  # at a new input: exp(mean + var / 2) of g's conditional, in plain R
  u <- matrix(c(0.4, 0.7), 1)
  ph <- phis[3, ]
  th <- ph[cls == "thetaG"]
  Xs <- model$data$Xs
  Kg <- FBC:::.corr_matrix(Xs, Xs, th, c(2, 2), 4L) + 1e-6 * diag(nrow(Xs))
  k <- drop(FBC:::.corr_matrix(Xs, u, th, c(2, 2), 4L))
  muG <- ph[cls == "muG"]
  s2G <- ph[cls == "sigma2G"]
  m <- muG + sum(k * solve(Kg, ph[cls == "gR"] - muG))
  v <- s2G * (1 + 1e-6 - sum(k * solve(Kg, k)))
  expect_equal(FBC:::run_noise(model, phis, u)[1, 3], exp(m + v / 2), tolerance = 1e-8)
  set.seed(5)
  pr <- suppressMessages(propose_runs(fit, n = 2, ndraws = 20))
  expect_type(pr$replicate, "logical")
  expect_length(pr$replicate, 2)
})
