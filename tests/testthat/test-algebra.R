# choose_algebra(): the algebra and neighbours by projected cost (R/algebra.R).

test_that("the projected dense sweep: the measured constants times what the default sweep does", {
  k <- FBC:::fbc_dense_cost
  # m = 1000, n = 60, p = q = 2: the large schedule (one simulator-block
  # move; kappa: 2 walks, 2 jumps, 1 joint; bias, sigma2E, muB, scale)
  mv <- FBC:::dense_sweep_moves(2, TRUE)
  expect_identical(mv, c(sim = 1L, kappa = 5L, other = 5L))
  expect_equal(FBC:::dense_sweep_cost(1000, 60, 2, 2),
               k[["A"]] * 1000^3 + k[["B"]] * 4 * 1000^2 + k[["C"]] * 60 * 1000^2 +
                 5 * (k[["C"]] * 60 * 1000^2 + k[["D"]] * 4 * 60 * 1000) + 11 * k[["E"]] * 60^3)
  # the moves counted are those sampler_moves() schedules
  for (q in 1:3) for (large in c(FALSE, TRUE)) {
    p <- 2
    sp <- FBC:::build_priors(list(dist = rep("beta", q), init = rep(NA, q), p1 = rep(1.1, q),
                                  p2 = rep(1.1, q)), set_hyperPriors(),
                             list(xmin = rep(0, p + q), xmax = rep(1, p + q), p = p, q = q), p, q)
    sp$model <- FBC:::compiled_model(p, q)
    sm <- FBC:::sampler_moves("blocks", sp, large = large)
    nm <- names(sm$blocks)
    kappaMoves <- sum(sm$repeats[startsWith(nm, "kappa")]) + length(sm$jump)
    mv <- FBC:::dense_sweep_moves(q, large)
    expect_identical(mv[["sim"]], sm$repeats[nm == "sim"])
    expect_identical(mv[["kappa"]], as.integer(kappaMoves))
    # bias block, sigma2E, muB (exact), scale
    expect_identical(mv[["other"]], sm$repeats[nm == "bias"] + 1L + 1L + 1L)
  }
  # more inputs and more kappa moves cost more, at the same m + n
  expect_gt(FBC:::dense_sweep_cost(780, 30, 3, 3), FBC:::dense_sweep_cost(780, 30, 1, 1))
  expect_identical(FBC:::vecchia_neighbours(3999), 20L)
  expect_identical(FBC:::vecchia_neighbours(4000), 10L)
})

test_that("auto: dense while cheap, Vecchia above, Kronecker on a product design", {
  set.seed(1)
  ca <- function(...) FBC:::choose_algebra(...)
  small <- ca("auto", NULL, matrix(runif(300 * 3), 300), 1, "matern52", 20)
  expect_identical(small[c("name", "code", "neighbours", "forced")],
                   list(name = "dense", code = 0L, neighbours = NULL, forced = FALSE))
  # m + n = 1060: 0.18 s a sweep on the reference BLAS, over 0.1 s
  X <- matrix(runif(1000 * 4), 1000)
  large <- ca("auto", NULL, X, 2, "matern52", 60)
  expect_identical(large[c("name", "code", "neighbours", "forced")],
                   list(name = "vecchia", code = 2L, neighbours = 20L, forced = FALSE))
  # (whatever BLAS runs: the choice takes no BLAS; R/algebra.R says why)
  expect_false("blas" %in% names(formals(FBC:::choose_algebra)))
  # from 4000 runs, 10 neighbours; a given count is kept
  big <- matrix(runif(4000 * 3), 4000)
  expect_identical(ca("auto", NULL, big, 1, "matern52", 50)$neighbours, 10L)
  expect_identical(ca("auto", 15, big, 1, "matern52", 50)$neighbours, 15L)
  # a product design of 80 x 50 runs (m = 4000): Kronecker, exact
  grid <- as.matrix(expand.grid(x = seq(0, 1, length.out = 80), t = seq(0, 1, length.out = 50)))
  kron <- ca("auto", NULL, grid, 1, "powexp", 30)
  expect_identical(kron[c("name", "code", "neighbours", "forced")],
                   list(name = "kronecker", code = 0L, neighbours = NULL, forced = FALSE))
  # one run missing: Kronecker with a missing cell (exact); half the runs
  # missing: the 2000 x 2000 system of the missing cells costs more than a
  # Cholesky factor of the 2000 runs, and large: Vecchia
  expect_identical(ca("auto", NULL, grid[-1, ], 1, "powexp", 30)[c("name", "missing")],
                   list(name = "kronecker", missing = 1L))
  expect_identical(ca("auto", NULL, grid[sort(sample(4000, 2000)), ], 1, "powexp", 30)$name, "vecchia")
  expect_snapshot({
    writeLines(small$reason)
    writeLines(large$reason)
    writeLines(kron$reason)
  })
})

test_that("an algebra that does not compute with a class: a product design goes to the rule's algebra, others are refused", {
  # the compiled core's table: the simulator's noise on the dense and
  # nearest-neighbour algebras of one output, every other class on all
  alg <- FBC:::.class_algebras()
  expect_setequal(names(alg), FBC:::model_code_tables(FBC:::.model_codes())$class)
  for (cls in FBC:::sim_noise_classes) expect_identical(alg[[cls]], c("dense", "vecchia"))
  every <- c("dense", "kronecker", "vecchia", "function", "outputs")
  for (cls in c("kappa", "thetaS", "alphaS", "rhoS", "thetaB", "sigma2S", "sigma2B", "sigma2E", "muB",
                "lambdaZ", "rhoD")) {
    expect_identical(alg[[cls]], every)
  }
  expect_true(all(vapply(alg, function(a) "dense" %in% a && all(a %in% every), logical(1))))
  out <- function(name, classes, outputs = 1L) FBC:::classes_outside(name, classes, outputs)
  expect_identical(out("kronecker", "kappa"), character(0))
  expect_identical(out("vecchia", c("kappa", "sigma2R")), character(0))
  expect_identical(out("kronecker", c("kappa", "sigma2R")), "sigma2R")
  expect_identical(out("dense", c("kappa", "gR", "muG"), outputs = 2L), c("gR", "muG"))
  ok <- list(name = "dense", forced = FALSE)
  expect_identical(FBC:::check_class_algebra(ok, c("kappa", "sigma2R")), ok)
  expect_snapshot(error = TRUE, {
    FBC:::check_class_algebra(list(name = "function", forced = FALSE), c("kappa", "sigma2R"))
    FBC:::check_class_algebra(list(name = "kronecker", forced = FALSE), c("kappa", "gR", "muG"),
                              outputs = 2L)
  })
  # on a product design such classes leave the choice to the rule: dense
  # while cheap (6 x 5 runs), the nearest-neighbour algebra on 80 x 50, each
  # saying why
  grid <- as.matrix(expand.grid(x = seq(0, 1, length.out = 80), t = seq(0, 1, length.out = 50)))
  big <- FBC:::choose_algebra("auto", NULL, grid, 1, "matern52", 30, without = "sigma2R")
  expect_identical(big[c("name", "neighbours")], list(name = "vecchia", neighbours = 10L))
  six <- as.matrix(expand.grid(x = seq(0, 1, length.out = 6), t = seq(0, 1, length.out = 5)))
  expect_identical(FBC:::choose_algebra("auto", NULL, six, 1, "matern52", 30)$name, "kronecker")
  small <- FBC:::choose_algebra("auto", NULL, six, 1, "matern52", 30, without = "sigma2R")
  expect_identical(small[c("name", "code")], list(name = "dense", code = 0L))
  for (a in list(big, small)) {
    expect_match(a$reason, "the runs are a product design, but the Kronecker algebra does not compute with `sigma2R`",
                 fixed = TRUE)
  }
  # a stochastic simulator on a product design of unique inputs: the model
  # takes the dense algebra (auto), and the compiled core, left to choose,
  # takes it too: the same log-likelihood to the bit
  set.seed(2)
  U <- expand.grid(x = seq(0, 3, length.out = 6), t = seq(0.5, 3, length.out = 5))
  X <- U[rep(seq_len(30), 2), ]
  sim <- data.frame(y = 5 * exp(-X$t * X$x) + stats::rnorm(60, 0, 0.2), x = X$x, t = X$t)
  field <- data.frame(y = 5 * exp(-1.7 * c(0.5, 1.5, 2.5)) + c(0.02, -0.03, 0.01), x = c(0.5, 1.5, 2.5))
  model <- calibrate(sim, field, fit = FALSE)
  expect_identical(model$algebra$name, "dense")
  expect_match(model$algebra$reason, "does not compute with `sigma2R`", fixed = TRUE)
  d <- model$data
  cm <- model$spec$model
  expect_true(length(FBC:::.sim_algebra(d$Xs, 1L, 0L)) > 0)  # a product design
  phi <- c(random_phi(1, 1, "gp"), 0.05)
  ll <- function(code) {
    cm$algebra <- code
    FBC:::.fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, FBC:::fbc_nugget, model = cm)
  }
  expect_identical(ll(0L), ll(1L))
  expect_true(is.finite(ll(0L)))
})

test_that("a named algebra is used as asked, and neighbours without Vecchia gets a message", {
  set.seed(2)
  X <- matrix(runif(200 * 2), 200)
  ca <- function(...) FBC:::choose_algebra(...)
  dense <- ca("dense", NULL, X, 1, "matern52", 10)
  expect_identical(dense[c("name", "code", "forced")], list(name = "dense", code = 1L, forced = TRUE))
  vec <- ca("vecchia", NULL, X, 1, "matern52", 10)
  expect_identical(vec[c("name", "code", "neighbours", "forced")],
                   list(name = "vecchia", code = 2L, neighbours = 20L, forced = TRUE))
  expect_identical(ca("vecchia", 7, X, 1, "matern52", 10)$neighbours, 7L)
  expect_snapshot({
    writeLines(dense$reason)
    writeLines(vec$reason)
    out <- ca("dense", 5, X, 1, "matern52", 10)
    out <- ca("auto", 5, X, 1, "matern52", 10)
  })
  expect_silent(ca("vecchia", 5, X, 1, "matern52", 10))
})

test_that("print() says which algebra ran and why", {
  set.seed(3)
  fit <- calibrate(ballSim, ballField, nMCMC = 40, nBurn = 10, nChains = 1, discrepancy = "none")
  expect_identical(fit$model$algebra$name, "dense")
  # the projected cost depends on the BLAS (0.00065 s on the reference one)
  expect_output(print(fit), "algebra: dense: exact; projected at about [0-9.]+ s a sweep \\(m = 100, n = 63, 2 inputs; under 0.1 s\\)")
  # a fit made before the reason was kept prints the old line
  old <- fit
  old$model$algebra$reason <- NULL
  expect_output(print(old), "algebra: dense\n", fixed = TRUE)
})
