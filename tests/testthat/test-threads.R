# Threads inside a chain (calibrate(threads =), src/vecchia.cpp): the
# nearest-neighbour algebra's conditionals are computed in parallel and
# summed in node order, so every number, and so every draw, is the same for
# any number of threads. Without OpenMP (.has_openmp() FALSE) a run has one
# thread whatever it asks for.

test_that("the Vecchia log-likelihood along the sampler's moves is the same for 1, 2 and 3 threads", {
  skip_if_not(FBC:::.has_openmp(), "built without OpenMP")
  set.seed(65)
  m <- 300
  lev <- list(col = 2L, ncol = 3L, L = 3L)
  Xs <- cbind(runif(m), diag(3)[rep(1:3, length.out = m), ], runif(m))
  d <- list(Xf = cbind(runif(9), diag(3)[c(1, 2, 3, 1, 2, 3, 2, 1, 3), ]), yf = rnorm(9),
            Xs = Xs, ys = sin(4 * Xs[, 1]) + Xs[, 5] + rnorm(m, 0, 0.1))
  des <- FBC:::vecchia_design(d$Xs, d$ys, 4L, 8L, 4L)
  path <- function(threads, levels) {
    # (the same random phis for every number of threads)
    set.seed(66)
    phis <- t(replicate(4, random_phi(4, 1, nLev = if (levels) 3L else 0L)))
    model <- FBC:::compiled_model(4, 1, kernS = 4L, algebra = 2L, vecchia = des,
                                  levels = if (levels) lev)
    model$threads <- threads
    .loglik_path(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, decoys = TRUE, model = model)
  }
  for (levels in c(FALSE, TRUE)) {
    one <- path(1L, levels)
    expect_true(all(is.finite(one)))
    expect_identical(path(2L, levels), one)
    expect_identical(path(3L, levels), one)
  }
})

test_that("a Vecchia fit with 2 threads has the draws of one thread, and update() keeps its threads", {
  # (without OpenMP: the same, on one thread)
  args <- list(ballSim, ballField, nMCMC = 60, nBurn = 40, nChains = 1, converge = FALSE,
               algebra = "vecchia", neighbours = 8)
  set.seed(11)
  one <- do.call(calibrate, args)
  set.seed(11)
  two <- do.call(calibrate, c(args, threads = 2L))
  expect_identical(two$Phi, one$Phi)
  expect_identical(two$logLik, one$logLik)
  expect_null(one$model$spec$model$threads)
  expect_identical(two$model$spec$model$threads, 2L)
  set.seed(3)
  up <- update(two, nMCMC = 20)
  expect_identical(up$model$spec$model$threads, 2L)
  set.seed(3)
  expect_identical(update(one, nMCMC = 20)$Phi, up$Phi)
})

test_that("bad thread counts are refused", {
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, threads = 0))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, threads = 1.5))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, threads = NA))
})

test_that("a process forked after threads ran runs one thread, with the same draws", {
  # (GCC's OpenMP runtime hangs in such a child if it starts threads)
  skip_on_os("windows")
  skip_if_not(FBC:::.has_openmp(), "built without OpenMP")
  args <- list(ballSim, ballField, nMCMC = 40, nBurn = 20, nChains = 1, converge = FALSE,
               algebra = "vecchia", neighbours = 8, threads = 2L)
  set.seed(1)
  ref <- do.call(calibrate, args)
  job <- parallel::mcparallel({
    set.seed(1)
    do.call(calibrate, args)$Phi
  })
  res <- parallel::mccollect(job, wait = FALSE, timeout = 60)
  if (is.null(res)) tools::pskill(job$pid)
  expect_identical(res[[1]], ref$Phi)
})
