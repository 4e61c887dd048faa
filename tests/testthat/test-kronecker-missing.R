# The Kronecker algebra on a product design with missing cells (some
# combinations have no run; src/kronecker.cpp): the observed runs'
# likelihood, moves, predictions and held-out predictives against the
# plain-R dense ones and the compiled dense algebra on the observed runs.

# A grid of I x J settings (columns `a` against the others), rows shuffled,
# the cells `drop` (row numbers of the shuffled grid) removed.
missing_data <- function(I, J, a, d, p, n, seed, drop) {
  set.seed(seed)
  A <- matrix(runif(I * length(a)), I, length(a))
  B <- matrix(runif(J * (d - length(a))), J, d - length(a))
  g <- expand.grid(i = seq_len(I), j = seq_len(J))
  g <- g[sample(nrow(g)), ][-drop, ]
  Xs <- matrix(0, nrow(g), d)
  Xs[, a] <- A[g$i, ]
  Xs[, -a] <- B[g$j, ]
  list(Xf = matrix(runif(n * p), n, p), yf = rnorm(n), Xs = Xs, ys = rnorm(nrow(Xs)))
}

# experimental x calibration (8 x 6, 5 missing); height x (x2, t1)
# (9 x 6, 7 missing)
cases <- list(list(I = 8, J = 6, a = 1L, d = 2, p = 1, drop = c(3, 10, 11, 30, 41)),
              list(I = 9, J = 6, a = 1L, d = 3, p = 2, drop = c(1, 2, 7, 19, 23, 40, 52)))

test_that("a product design with missing cells is recognised, with their number", {
  for (s in cases) {
    d <- missing_data(s$I, s$J, s$a, s$d, s$p, 4, seed = 1, drop = s$drop)
    got <- .sim_algebra(d$Xs, s$p, 0L, TRUE)
    expect_identical(as.vector(got), as.integer(c(s$I, s$J)))
    expect_identical(attr(got, "missing"), length(s$drop))
  }
  # more missing cells than the algebra pays for: none (a scattered design
  # is a grid of m x m cells nearly all missing)
  r <- random_koh_data(5, 30, 1, 1, seed = 3)
  expect_identical(.sim_algebra(r$Xs, 1L, 0L, TRUE), integer(0))
  e <- missing_data(5, 5, 1L, 2, 1, 4, seed = 2, drop = 1:12)
  expect_identical(.sim_algebra(e$Xs, 1L, 0L, TRUE), integer(0))
})

test_that("with missing cells, log-likelihoods and moves are the dense ones of the observed runs", {
  for (s in cases) {
    p <- s$p; q <- s$d - p
    d <- missing_data(s$I, s$J, s$a, s$d, p, n = 5, seed = 10 + s$I, drop = s$drop)
    expect_kron_loglik_dense(d, p, q)
  }
})

test_that("with missing cells, predictions and held-out predictives are the dense ones", {
  for (s in cases) {
    p <- s$p; q <- s$d - p
    d <- missing_data(s$I, s$J, s$a, s$d, p, n = 5, seed = 30 + s$I, drop = s$drop)
    phis <- rbind(random_phi(p, q), random_phi(p, q))
    Xn <- matrix(runif(3 * p), 3, p)
    expect_kron_predict_dense(d, phis, Xn)
    fold <- rep(1:4, length.out = nrow(d$Xs))
    fold[1] <- 5L  # a fold of one run
    expect_equal(.fbc_heldout(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, fold),
                 .fbc_heldout(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, fold, algebra = 1L),
                 tolerance = 1e-8)
  }
})

test_that("calibrate() keeps the Kronecker algebra when runs of a product design fail, and says so", {
  set.seed(12)
  x <- seq(0, 1, length.out = 6)
  t1 <- seq(1, 3, length.out = 5)
  g <- expand.grid(x = x, t1 = t1)
  sim <- cbind(y = g$t1 * exp(-g$x), g)[sample(30), ]
  sim$y[c(4, 17)] <- NA  # two failed runs: missing cells of the 6 x 5 grid
  field <- cbind(y = 2 * exp(-c(0.1, 0.35, 0.6, 0.9)) + rnorm(4, 0, 0.01),
                 x = c(0.1, 0.35, 0.6, 0.9))
  set.seed(13)
  fit <- suppressMessages(calibrate(sim, field, nMCMC = 60, nBurn = 20, nChains = 1))
  expect_identical(fit$model$algebra[c("name", "dims", "missing")],
                   list(name = "kronecker", dims = c(6L, 5L), missing = 2L))
  expect_true(any(grepl("algebra: Kronecker, 6 x 5 (experimental x calibration settings): exact; the runs are a product design but for 2 of its 30 cells",
                        capture.output(print(fit)), fixed = TRUE)))
  # the same chain as the dense algebra on the 28 runs, up to rounding
  set.seed(13)
  dense <- suppressMessages(calibrate(sim, field, nMCMC = 60, nBurn = 20, nChains = 1,
                                      algebra = "dense"))
  expect_equal(dense$Phi, fit$Phi, tolerance = 1e-6)
  expect_equal(predict(dense, c(0.2, 0.5))$pred, predict(fit, c(0.2, 0.5))$pred, tolerance = 1e-6)
  # set.seed() reproduces the run, and a checkpointed run (the chain in
  # pieces of 50 sweeps, each resumed from its checkpoint) makes its draws:
  # the missing cells add no state to the chain
  set.seed(13)
  again <- suppressMessages(calibrate(sim, field, nMCMC = 60, nBurn = 20, nChains = 1))
  expect_identical(again$Phi, fit$Phi)
  dir <- tempfile("ck-")
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  set.seed(14)
  plain <- suppressMessages(calibrate(sim, field, nMCMC = 160, nBurn = 40, nChains = 1))
  set.seed(14)
  ck <- suppressMessages(calibrate(sim, field, nMCMC = 160, nBurn = 40, nChains = 1,
                                   checkpoint = dir, checkpointEvery = 0))
  expect_identical(ck$Phi, plain$Phi)
  expect_true(file.exists(file.path(dir, "chain-1.rds")))
})
