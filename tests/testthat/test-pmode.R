test_that("pmode() returns the mean of the fullest bin", {
  # breaks = 10 over [0, 10]: bin [0, 1) holds 0, 0.1, 0.15, 0.2 -> mean 0.1125
  x <- c(0, 0.1, 0.15, 0.2, 1, 2, 3, 4, 10)
  expect_equal(pmode(x, breaks = 10), mean(c(0, 0.1, 0.15, 0.2)))
  # two bins over [0, 10]: [0, 5) is the fuller one
  expect_equal(pmode(x, breaks = 2), mean(x[x < 5]))
  expect_equal(pmode(rep(3, 5)), 3)
  # one value: itself (nclass.FD() fails on it)
  expect_equal(pmode(2.5), 2.5)
  expect_equal(pmode(c(NA, 7, Inf)), 7)
  expect_equal(pmode(4, breaks = 3), 4)
})

test_that("pmode() finds the mode of known distributions", {
  set.seed(3)
  expect_equal(pmode(rnorm(1e5, mean = 2)), 2, tolerance = 0.05)
  # gamma(3, 1) has its mode at shape - 1 = 2
  expect_equal(pmode(rgamma(2e5, 3, 1)), 2, tolerance = 0.1)
})

test_that("pmode() explains bad input", {
  expect_snapshot(error = TRUE, pmode(character(0)))
  expect_snapshot(error = TRUE, pmode(1:10, breaks = 0))
})
