# Exact leave-one-out densities of the field data (src/loo.cpp, R/loo.R)
# against the Gaussian conditionals of the dense (n + m) covariance
# (helper-dense.R) computed in plain R: for a left-out group G of field rows,
#   y_G | y_-G ~ N(mu_G + C_G,-G C_-G,-G^-1 (y_-G - mu_-G),
#                  C_GG - C_G,-G C_-G,-G^-1 C_-G,G),
# the rest being the other field rows and every simulator run.

dense_loo <- function(d, phi, group, discrepancy) {
  p <- ncol(d$Xf); q <- ncol(d$Xs) - p; n <- nrow(d$Xf)
  th <- unpack_phi(phi, p, q, discrepancy)
  C <- dense_cov(d$Xf, d$Xs, phi, 1e-6, discrepancy = discrepancy)
  mu <- c(rep(if (discrepancy == "gp") th$muB else 0, n), rep(0, nrow(d$Xs)))
  y <- c(d$yf, d$ys)
  vapply(sort(unique(group)), function(g) {
    G <- which(group == g)
    R <- setdiff(seq_along(y), G)
    K <- C[G, R, drop = FALSE] %*% solve(C[R, R])
    m <- mu[G] + K %*% (y[R] - mu[R])
    V <- C[G, G] - K %*% C[R, G, drop = FALSE]
    L <- chol(V)
    z <- backsolve(L, y[G] - m, transpose = TRUE)
    -0.5 * (length(G) * log(2 * pi) + 2 * sum(log(diag(L))) + sum(z^2))
  }, numeric(1))
}

test_that("exact leave-one-out densities equal the dense Gaussian conditionals", {
  for (disc in c("gp", "sgasp", "none")) {
    for (s in list(c(p = 1, q = 1), c(p = 2, q = 1), c(p = 1, q = 2))) {
      p <- s[["p"]]; q <- s[["q"]]
      d <- random_koh_data(7, 15, p, q, seed = 30 + p + 2 * q)
      d$Xf <- d$Xf[c(1:7, 3, 3, 5), , drop = FALSE]  # replicated inputs
      d$yf <- c(d$yf, rnorm(3))
      model <- FBC:::compiled_model(p, q, discrepancy = disc)
      phis <- rbind(random_phi(p, q, disc), random_phi(p, q, disc))
      for (unit in c("input", "observation")) {
        group <- FBC:::loo_groups(d$Xf, unit)
        expect_identical(max(group), if (unit == "input") 7L else 10L)
        got <- FBC:::.fbc_loo(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, group, model = model)
        for (i in 1:2) {
          expect_equal(got[i, ], dense_loo(d, phis[i, ], group, disc), tolerance = 1e-8)
        }
      }
    }
  }
})

test_that("loo() of a fit with every parameter fixed is the exact density in the data's units", {
  skip_if_not_installed("loo")
  # every draw is phi: the importance weights are equal, so each pointwise
  # elpd is log p(y_i | y_-i, phi), here from the dense conditional on the
  # scaled space minus log(ysd) per observation (y = ymean + ysd y_scaled)
  set.seed(8)
  phi <- random_phi(2, 1)
  fit <- fixed_fit(phi)
  d <- fit$model$data
  # (4 equal draws: loo warns that it cannot fit Pareto tails, and uses none)
  res <- suppressWarnings(loo::loo(fit, unit = "observation"))
  expect_s3_class(res, "psis_loo")
  expect_identical(attr(res, "unit"), "observation")
  ref <- dense_loo(d, phi, seq_along(d$yf), "gp") - log(fit$model$scale$ysd)
  expect_equal(res$pointwise[, "elpd_loo"], ref, tolerance = 1e-8)
  expect_equal(res$estimates["elpd_loo", "Estimate"], sum(ref), tolerance = 1e-8)
})

test_that("loo_compare() ranks the discrepancy models of the ball data", {
  skip_if_not_slow()
  skip_if_not_installed("loo")
  set.seed(4)
  args <- list(ballSim, ballField, nMCMC = 700, nBurn = 300, nChains = 2, kernelS = "matern52",
               kernelB = "matern52")
  fits <- lapply(c(gp = "gp", sgasp = "sgasp", none = "none"), function(disc) {
    # (the bias kernel is unused, with a warning, under "none")
    suppressWarnings(do.call(calibrate, c(args, discrepancy = disc)))
  })
  loos <- suppressWarnings(lapply(fits, loo::loo, ndraws = 200))  # Pareto k warnings
  # the ball field data: 63 drops at 21 heights, 3 each; one unit per height
  for (l in loos) expect_identical(nrow(l$pointwise), 21L)
  cmp <- loo::loo_compare(loos)
  expect_setequal(rownames(cmp), c("gp", "sgasp", "none"))
  # the simulator t = sqrt(2 h / g) ignores air resistance, which slows the
  # wiffle ball: without a discrepancy the field data are predicted worst
  # (by 7.1 elpd with se 2.4 when this was written)
  expect_identical(rownames(cmp)[3], "none")
  expect_lt(cmp["none", "elpd_diff"], -2 * cmp["none", "se_diff"])
  obs <- suppressWarnings(loo::loo(fits$none, unit = "observation", ndraws = 200))
  expect_identical(nrow(obs$pointwise), 63L)
})

test_that("loo() refuses what it cannot use", {
  skip_if_not_installed("loo")
  set.seed(2)
  fit <- calibrate(ballSim, ballField, nMCMC = 60, nBurn = 20, nChains = 2)
  expect_snapshot(error = TRUE, loo::loo(fit, unit = "replicate"))
  expect_snapshot(error = TRUE, loo::loo(fit, ndraws = 0))
  expect_snapshot(error = TRUE, loo::loo(fit, r_eff = 1))
})

test_that("unit = \"input\" leaves out every output and data set observed at an input together", {
  skip_if_not_installed("loo")
  # Data sets at one input were grouped, outputs were not. Two
  # outputs at 6 inputs, a second laboratory repeating the first output at
  # 3 of them: 6 inputs, 15 observations
  set.seed(5)
  x <- runif(30); t <- runif(30, 0.5, 3)
  sim <- rbind(data.frame(y = 5 * exp(-t * x), x = x, out = "conc", t = t),
               data.frame(y = 2 * t * x, x = x, out = "rate", t = t))
  xf <- seq(0.1, 0.9, length.out = 6)
  field <- rbind(data.frame(y = 5 * exp(-1.7 * xf) + rnorm(6, 0, 0.05), x = xf, out = "conc", lab = "A"),
                 data.frame(y = 3.4 * xf + rnorm(6, 0, 0.05), x = xf, out = "rate", lab = "A"),
                 data.frame(y = 5 * exp(-1.7 * xf[1:3]) + rnorm(3, 0, 0.05), x = xf[1:3],
                            out = "conc", lab = "B"))
  set.seed(6)
  fit <- calibrate(sim, field, output = "out", outputs = "shared", source = "lab", nMCMC = 200, nBurn = 100,
                   nChains = 2, kernelS = "matern52", kernelB = "matern52")
  g <- FBC:::loo_groups(fit$model$data$Xf, "input", FBC:::loo_input_columns(fit$model$scale))
  expect_identical(g, match(field$x, xf))
  l <- suppressWarnings(loo::loo(fit, ndraws = 40))  # (Pareto k: 40 draws)
  expect_identical(nrow(l$pointwise), 6L)
  expect_identical(nrow(suppressWarnings(loo::loo(fit, unit = "observation", ndraws = 40))$pointwise), 15L)
  # a categorical input that is not the output stays part of the input
  expect_identical(FBC:::loo_input_columns(list(p = 3L, names = list(inputs = c("x", "m[b]", "out[rate]")),
                                                output = list(columns = "out[rate]"))), 1:2)
})

test_that("loo() needs a few draws per chain", {
  skip_if_not_installed("loo")
  # ndraws = 3 with 2 chains gave one draw a chain and failed inside loo
  set.seed(2)
  fit <- calibrate(ballSim, ballField, nMCMC = 60, nBurn = 20, nChains = 2)
  expect_snapshot(error = TRUE, loo::loo(fit, ndraws = 3))
  expect_s3_class(suppressWarnings(loo::loo(fit, ndraws = 4)), "psis_loo")
  # a chain interrupted early may keep a single draw
  expect_snapshot(error = TRUE, FBC:::check_loo_draws(c(1, 1, 1, 2), NULL))
})
