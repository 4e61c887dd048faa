# The Kronecker algebra on a product design that is not experimental x
# calibration settings (src/kronecker.cpp, the general split): an output
# index on a grid crossed with scattered run settings that mix experimental
# and calibration inputs, against the plain-R dense likelihood and GP
# conditional of helper-dense.R and helper-predict.R.

# Runs: every combination of I settings of the columns `a` and J scattered
# settings of the others (d columns, the first p experimental), rows
# shuffled; n field points off the grid.
split_data <- function(I, J, a, d, p, n, seed) {
  set.seed(seed)
  A <- matrix(runif(I * length(a)), I, length(a))
  B <- matrix(runif(J * (d - length(a))), J, d - length(a))
  g <- expand.grid(i = seq_len(I), j = seq_len(J))
  g <- g[sample(nrow(g)), ]
  Xs <- matrix(0, nrow(g), d)
  Xs[, a] <- A[g$i, ]
  Xs[, -a] <- B[g$j, ]
  list(Xf = matrix(runif(n * p), n, p), yf = rnorm(n), Xs = Xs, ys = rnorm(nrow(Xs)))
}

# (output index) x (x2, t1); (x1, t2) x (x2, t1); (x1) x (x2, t1, t2)
splits <- list(list(I = 6, J = 5, a = 1L, d = 3, p = 2),
               list(I = 5, J = 6, a = c(1L, 4L), d = 4, p = 2),
               list(I = 7, J = 4, a = 1L, d = 4, p = 2))

test_that("product designs of any two groups of columns are recognised, and only they", {
  for (s in splits) {
    d <- split_data(s$I, s$J, s$a, s$d, s$p, 4, seed = 1)
    got <- .sim_algebra(d$Xs, s$p, 0L, TRUE)
    expect_identical(as.vector(got), as.integer(c(s$I, s$J)))
    expect_identical(attr(got, "a"), s$a)
    # not experimental x calibration settings: none without `general`
    expect_identical(.sim_algebra(d$Xs, s$p), integer(0))
    # a run missing: a missing cell; a run twice: no product
    expect_identical(attr(.sim_algebra(d$Xs[-3, ], s$p, 0L, TRUE), "missing"), 1L)
    expect_identical(.sim_algebra(d$Xs[c(1, seq_len(nrow(d$Xs))), ], s$p, 0L, TRUE), integer(0))
  }
  # experimental x calibration first, with `general` as without it
  e <- split_data(6, 5, 1:2, 3, 2, 4, seed = 2)
  expect_identical(.sim_algebra(e$Xs, 2L, 0L, TRUE), structure(c(6L, 5L), a = 1:2))
  expect_identical(.sim_algebra(e$Xs, 2L), c(6L, 5L))
})

test_that("the general Kronecker log-likelihood and moves equal the dense ones", {
  for (s in splits) {
    p <- s$p; q <- s$d - p
    d <- split_data(s$I, s$J, s$a, s$d, p, n = 5, seed = 10 + s$I)
    expect_kron_loglik_dense(d, p, q)
  }
})

test_that("general Kronecker predictions equal the dense GP conditional (every type)", {
  for (s in splits[1:2]) {
    p <- s$p; q <- s$d - p
    d <- split_data(s$I, s$J, s$a, s$d, p, n = 5, seed = 30 + s$I)
    phis <- rbind(random_phi(p, q), random_phi(p, q))
    Xn <- matrix(runif(4 * p), 4, p)
    expect_kron_predict_dense(d, phis, Xn)
  }
})

test_that("calibrate() runs a height grid x (R, C) settings on the Kronecker algebra and says which split", {
  set.seed(21)
  h <- seq(0.1, 1, length.out = 8)
  rc <- cbind(R = c(0.1, 0.2, 0.3, 0.4, 0.5), C = c(0.25, 0.1, 0.3, 0.15, 0.2))
  g <- expand.grid(i = seq_along(h), j = seq_len(5))
  sim <- data.frame(y = rc[g$j, "C"] * h[g$i] / rc[g$j, "R"], height = h[g$i], R = rc[g$j, "R"],
                    C = rc[g$j, "C"])[sample(nrow(g)), ]
  field <- data.frame(height = c(0.2, 0.5, 0.8, 0.3), R = c(0.2, 0.2, 0.4, 0.4))
  field <- cbind(y = 0.2 * field$height / field$R + rnorm(4, 0, 0.01), field)
  set.seed(22)
  fit <- calibrate(sim, field, nMCMC = 60, nBurn = 20, nChains = 1)
  expect_identical(fit$model$algebra[c("name", "dims", "split")],
                   list(name = "kronecker", dims = c(8L, 5L), split = 1L))
  expect_true(any(startsWith(capture.output(print(fit)), "  algebra: Kronecker: height (8) x R, C (5): exact")))
  # the dense algebra: the same chain up to rounding
  set.seed(22)
  dense <- calibrate(sim, field, nMCMC = 60, nBurn = 20, nChains = 1, algebra = "dense")
  expect_identical(dense$model$algebra$name, "dense")
  expect_equal(dense$Phi, fit$Phi, tolerance = 1e-6)
  newx <- data.frame(height = c(0.4, 0.6), R = c(0.3, 0.25))
  expect_equal(predict(dense, newx)$pred, predict(fit, newx)$pred, tolerance = 1e-6)
})
