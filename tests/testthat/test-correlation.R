test_that("the vignette's correlation examples hold (section 1.8)", {
  X <- matrix(c(1, 3, 5,
                2, 2, 6,
                1, 4, 1), nrow = 3, byrow = TRUE)
  Y <- matrix(c(7, 3, 0,
                2, 2, 4), nrow = 2, byrow = TRUE)
  sc <- c(1, 2, 3)
  sm <- c(2, 1, 2)
  # by hand: rows 1 and 2 differ by (1, 1, 1): exp(-(1 + 2 + 3)) = exp(-6)
  expect_equal(correlation(X, theta = sc, alpha = sm),
               matrix(c(1, exp(-6), exp(-50),
                        exp(-6), 1, exp(-80),
                        exp(-50), exp(-80), 1), 3, byrow = TRUE))
  expect_equal(round(correlation(X, Y, theta = sc, alpha = sm), 5),
               matrix(c(0, 0.00248, 0, 0.00001, 0, 0), 3, byrow = TRUE))
})

test_that("correlation() equals the plain-R double loop", {
  set.seed(11)
  X <- matrix(runif(24), 8, 3)
  Y <- matrix(runif(15), 5, 3)
  th <- c(0.5, 3, 10)
  al <- c(1, 1.5, 2)
  expect_equal(correlation(X, Y, th, al), dense_corr(X, Y, th, al), tolerance = 1e-14)
  # scalars apply to every column; a vector is one column
  expect_equal(correlation(X, theta = 2, alpha = 1.7), dense_corr(X, X, rep(2, 3), rep(1.7, 3)))
  expect_equal(correlation(1:3, theta = 1, alpha = 2), exp(-outer(1:3, 1:3, "-")^2))
})

test_that("each family equals its formula (plain R, ?correlation)", {
  set.seed(12)
  X <- matrix(runif(24), 8, 3)
  Y <- matrix(runif(15), 5, 3)
  th <- c(0.5, 3, 10)
  for (k in c("gaussian", "matern32", "matern52")) {
    expect_equal(correlation(X, Y, th, kernel = k), dense_corr(X, Y, th, NULL, k),
                 tolerance = 1e-14)
  }
  # one dimension, written out: h = sqrt(theta) d
  d <- c(0, 0.1, 0.5, 1, 3)
  h <- sqrt(2) * d
  one <- function(k) correlation(d, 0, theta = 2, kernel = k)[, 1]
  expect_equal(one("gaussian"), exp(-2 * d^2))
  expect_equal(one("matern32"), (1 + sqrt(3) * h) * exp(-sqrt(3) * h))
  expect_equal(one("matern52"), (1 + sqrt(5) * h + 5 * h^2 / 3) * exp(-sqrt(5) * h))
  # the Gaussian is the power exponential at alpha = 2
  expect_equal(correlation(X, Y, th, kernel = "gaussian"), correlation(X, Y, th, alpha = 2))
  # near 0 each is 1 - c theta d^2 with c = 1, 3/2, 5/6
  e <- 1e-4
  curv <- vapply(c("gaussian", "matern32", "matern52"), function(k)
    (1 - correlation(e, 0, theta = 2, kernel = k)[1, 1]) / (2 * e^2), numeric(1))
  expect_equal(unname(curv), c(1, 3 / 2, 5 / 6), tolerance = 1e-3)
  # far apart: no overflow in the Matern products, the correlation goes to 0
  expect_identical(correlation(c(0, 1e6), theta = rep(1e4, 1), kernel = "matern52")[2, 1], 0)
})

test_that("alpha is needed by the power exponential only", {
  X <- matrix(runif(6), 3, 2)
  expect_snapshot(error = TRUE, correlation(X, theta = 1))
  expect_snapshot(correlation(X, theta = 1, alpha = 2, kernel = "matern32") -> r)
  expect_equal(r, correlation(X, theta = 1, kernel = "matern32"))
  expect_snapshot(error = TRUE, correlation(X, theta = 1, kernel = "matern"))
})

test_that("correlation() explains bad input", {
  X <- matrix(runif(6), 3, 2)
  expect_snapshot(error = TRUE, correlation(X, matrix(1, 2, 3), theta = 1, alpha = 2))
  expect_snapshot(error = TRUE, correlation(X, theta = c(1, 2, 3), alpha = 2))
  expect_snapshot(error = TRUE, correlation(X, theta = -1, alpha = 2))
  expect_snapshot(error = TRUE, correlation(X, theta = 1, alpha = 3))
  expect_snapshot(error = TRUE, correlation("a", theta = 1, alpha = 2))
})
