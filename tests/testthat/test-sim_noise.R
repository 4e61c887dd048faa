# Stochastic simulators (R/sim_noise.R): replicate runs found, the
# simulator's own noise modelled by the replicates' sufficient statistics,
# and every model without it unchanged to the bit.

# A stochastic simulator, eta = 5 exp(-t x) plus N(0, sd^2) noise, on
# `nx` x `nt` unique inputs (a product of x in [0, 3] and t in [0.5, 3])
# with `reps` replicates each (a vector: one count per unique input), and
# field data at t = 1.7 with measurement error sd 0.05.
stochastic_problem <- function(nx = 5, nt = 5, reps = 10, sd = 0.2, nf = 10, seed = 1) {
  set.seed(seed)
  U <- expand.grid(x = seq(0, 3, length.out = nx), t = seq(0.5, 3, length.out = nt))
  reps <- rep_len(reps, nrow(U))
  X <- U[rep(seq_len(nrow(U)), reps), ]
  sim <- cbind(y = 5 * exp(-X$t * X$x) + stats::rnorm(nrow(X), 0, sd), x = X$x, t = X$t)
  xf <- seq(0.1, 2.9, length.out = nf)
  field <- cbind(y = 5 * exp(-1.7 * xf) + stats::rnorm(nf, 0, 0.05), x = xf)
  list(sim = unname_rows(sim), field = field)
}
unname_rows <- function(m) { rownames(m) <- NULL; m }

test_that("replicates are grouped, and differ only beyond rounding", {
  sim <- cbind(y = c(1, 2, 1 + 1e-14, 3, 2.5), x = c(0, 1, 0, 2, 1), t = c(1, 1, 1, 1, 1))
  r <- FBC:::sim_replicates(sim)
  expect_identical(r$group, c(1L, 2L, 1L, 3L, 2L))
  expect_identical(r$count, c(2L, 2L, 1L))
  expect_identical(r$first, c(1L, 2L, 4L))
  # rows 1 and 3 differ by rounding, rows 2 and 5 by 0.5
  expect_identical(r$differ, c(FALSE, TRUE, FALSE))
  # the sufficient statistics: means and the within sum of squares
  dat <- list(Xs = sim[, -1], ys = sim[, 1])
  cr <- FBC:::collapse_replicates(dat, r)
  expect_equal(cr$dat$ys, c(1 + 0.5e-14, 2.25, 3))
  expect_equal(cr$replicates$ssw, 2 * 0.25^2 + 2 * (0.5e-14)^2)
  expect_identical(cr$dat$Xs, sim[c(1, 2, 4), -1])
  expect_equal(cr$pooled, cr$replicates$ssw / 2)
})

test_that("the sufficient-statistic likelihood is the likelihood of every run", {
  pb <- stochastic_problem(nx = 4, nt = 3, reps = c(1, 3, 2, 4), nf = 4, seed = 2)
  for (disc in c("gp", "none")) {
    model <- calibrate(pb$sim, pb$field, simNoise = "constant", discrepancy = disc, fit = FALSE)
    d <- model$data
    expect_identical(nrow(d$Xs), 12L)
    reps <- FBC:::sim_replicates(pb$sim)
    # every run on the scaled space, and phi with sigma2R last
    ys <- (pb$sim[, 1] - model$scale$ymean) / model$scale$ysd
    idx <- FBC:::param_indices(1, 1, disc, replicates = 1L)
    expect_identical(idx$sigma2R, model$dims$d)
    set.seed(3)
    for (k in 1:3) {
      phi <- random_phi(1, 1, disc)
      r <- stats::rgamma(1, 2, 20)
      full <- c(phi, r)
      got <- FBC:::.fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, full, FBC:::fbc_nugget, model = model$spec$model)
      # plain R: the unique inputs' covariance (the nugget on their eta),
      # expanded to every run, plus r on each run
      Cu <- dense_cov(d$Xf, d$Xs, phi, FBC:::fbc_nugget, "matern52", "matern52", disc)
      n <- nrow(d$Xf)
      E <- rbind(cbind(diag(n), matrix(0, n, 12)),
                 cbind(matrix(0, length(ys), n), diag(12)[reps$group, ]))
      C <- E %*% Cu %*% t(E) + diag(c(rep(0, n), rep(r, length(ys))))
      th <- unpack_phi(phi, 1, 1, disc)
      res <- c(d$yf - if (disc == "gp") th$muB else 0, ys)
      L <- chol(C)
      a <- backsolve(L, res, transpose = TRUE)
      ref <- -0.5 * (length(res) * log(2 * pi) + 2 * sum(log(diag(L))) + sum(a^2))
      expect_equal(got, ref, tolerance = 1e-8)
    }
  }
})

test_that("without replicates that differ, the model and draws are the deterministic ones", {
  # deterministic duplicates: "auto" is "none", to the bit
  s2 <- rbind(ballSim, ballSim[c(4, 9), ])
  fit1 <- function(...) {
    set.seed(7)
    suppressMessages(calibrate(s2, ballField, nMCMC = 300, nBurn = 100, nChains = 2,
                               converge = FALSE, ...))
  }
  auto <- fit1()
  none <- fit1(simNoise = "none")
  expect_identical(auto$Phi, none$Phi)
  expect_identical(auto$logPost, none$logPost)
  expect_false("sigma2R" %in% colnames(auto$Phi))
  expect_null(auto$model$spec$model$replicates)
  expect_false("sigma2R" %in% auto$model$classes$class)
  # noisy replicates under "none": the deterministic model, the old message
  pb <- stochastic_problem(nx = 4, nt = 3, reps = 2, nf = 4)
  expect_message(m0 <- calibrate(pb$sim, pb$field, simNoise = "none", fit = FALSE),
                 "duplicated runs")
  expect_identical(nrow(m0$data$Xs), 24L)
  expect_false("sigma2R" %in% m0$spec$vars)
  m1 <- calibrate(pb$sim, pb$field, fit = FALSE)
  expect_identical(nrow(m1$data$Xs), 12L)
  expect_identical(m1$spec$vars[m1$dims$d], "sigma2R")
  # its algebra: the unique inputs are a product design, the dense one runs
  expect_identical(m1$algebra$name, "dense")
})

test_that("the simulator's noise and t are recovered on a stochastic simulator", {
  pb <- stochastic_problem(nx = 5, nt = 5, reps = 10, sd = 0.2)
  set.seed(11)
  fit <- calibrate(pb$sim, pb$field, discrepancy = "none", nMCMC = 1500, nBurn = 500,
                   nChains = 2, converge = FALSE)
  sdR <- sqrt(fit$Phi[, "sigma2R"]) * fit$model$scale$ysd
  ci <- stats::quantile(sdR, c(0.025, 0.975), names = FALSE)
  expect_true(ci[1] < 0.2 && 0.2 < ci[2])
  # 225 within degrees of freedom: the sd within about +-10%
  expect_lt(diff(ci), 0.06)
  t90 <- stats::quantile(fit$Phi[, fit$indices$kappa], c(0.05, 0.95), names = FALSE)
  expect_true(t90[1] < 1.7 && 1.7 < t90[2])
  # predict(): the noise sd beside the simulator's mean
  pr <- predict(fit, c(0.5, 1.5), type = "simulator", ndraws = 50)
  expect_equal(pr$noiseSd, rep(sqrt(mean(fit$Phi[attr(pr, "draw_rows"), "sigma2R"])) *
                                 fit$model$scale$ysd, 2))
  expect_equal(pr$pred, 5 * exp(-1.7 * c(0.5, 1.5)), tolerance = 0.05)
  expect_null(predict(fit, c(0.5, 1.5), ndraws = 50)$noiseSd)
  # set.seed() reproduces the run
  set.seed(11)
  again <- calibrate(pb$sim, pb$field, discrepancy = "none", nMCMC = 1500, nBurn = 500,
                     nChains = 2, converge = FALSE)
  expect_identical(again$Phi, fit$Phi)
})

test_that("the nearest-neighbour algebra carries the noise: with every predecessor, the dense likelihood and moves", {
  pb <- stochastic_problem(nx = 4, nt = 3, reps = c(1, 3, 2, 4), nf = 4, seed = 2)
  for (mode in c("constant", "input")) {
    dense <- calibrate(pb$sim, pb$field, simNoise = mode, fit = FALSE)
    vec <- calibrate(pb$sim, pb$field, simNoise = mode, algebra = "vecchia", neighbours = 12,
                     fit = FALSE)
    expect_identical(vec$algebra$name, "vecchia")
    d <- dense$data
    m <- nrow(d$Xs)
    set.seed(5)
    phis <- t(replicate(3, {
      phi <- random_phi(1, 1, "gp")
      if (mode == "constant") c(phi, stats::rgamma(1, 2, 20)) else
        c(phi, stats::rnorm(m, -3, 0.7), stats::rnorm(1, -3), stats::rgamma(1, 2, 2),
          stats::rgamma(2, 2, 1))
    }))
    ll <- function(model, phi) FBC:::.fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, FBC:::fbc_nugget,
                                                 model = model$spec$model)
    for (i in 1:3) expect_equal(ll(vec, phis[i, ]), ll(dense, phis[i, ]), tolerance = 1e-8)
    # the moves of every class one after another (rejected decoys between),
    # then the scale move: the same path
    path <- function(model, scale) FBC:::.loglik_path(d$Xf, d$yf, d$Xs, d$ys, phis, FBC:::fbc_nugget,
                                                      decoys = TRUE, scale = scale,
                                                      model = model$spec$model)
    expect_equal(path(vec, FALSE), path(dense, FALSE), tolerance = 1e-8)
    if (mode == "constant") expect_equal(path(vec, TRUE), path(dense, TRUE), tolerance = 1e-8)
  }
  # a fit's predictions of the simulator's mean and noise at the same draws
  go <- function(...) {
    set.seed(1)
    calibrate(pb$sim, pb$field, simNoise = "constant", discrepancy = "none", nMCMC = 200,
              nBurn = 100, nChains = 1, converge = FALSE, ...)
  }
  vfit <- go(algebra = "vecchia", neighbours = 12)
  dfit <- go()
  expect_match(paste(capture.output(print(vfit)), collapse = "\n"), "Vecchia")
  # the same moves on the same likelihood: the same draws (the simulator
  # block walks sigma2S with the rest: with the noise its conditional given
  # the runs is not the inverse gamma the deterministic model's is)
  expect_equal(vfit$Phi, dfit$Phi, tolerance = 1e-6)
  dfit$Phi[] <- vfit$Phi
  at <- function(fit) { set.seed(2); predict(fit, c(0.5, 1.5), type = "simulator", ndraws = 40) }
  expect_equal(at(vfit), at(dfit), tolerance = 1e-6)
})

test_that("sigma2R drawn from the replicates' within term in the simulator block targets the grid posterior", {
  # 12 unique inputs x 3 replicates, everything fixed but thetaS1, thetaS2
  # and sigma2R: the simulator block walks (or after warm-up proposes) the
  # length-scales and draws sigma2R from IG(df / 2 - 1, SSW / 2), an
  # independence proposal corrected by Metropolis-Hastings
  pb <- stochastic_problem(nx = 4, nt = 3, reps = 3, nf = 6, seed = 3)
  hyp <- set_hyperPriors(sigma2SDist = "fixed", sigma2SInit = 1, sigma2EDist = "fixed",
                         sigma2EInit = 0.01)
  set.seed(6)
  fit <- calibrate(pb$sim, pb$field, simNoise = "constant", discrepancy = "none", hypers = hyp,
                   kappaDist = "fixed", kappaInit = 1.7, nMCMC = 6000, nChains = 1,
                   converge = FALSE)
  mv <- FBC:::move_report(fit)
  expect_identical(mv$parameters[mv$move == "sim"], "thetaS1,thetaS2,sigma2R")
  expect_draws_match_grid(fit, c("thetaS1", "thetaS2", "sigma2R"), 15)
})

test_that("print() says what was found and modelled", {
  pb <- stochastic_problem(nx = 4, nt = 3, reps = c(1, 3), nf = 4)
  set.seed(2)
  fit <- calibrate(pb$sim, pb$field, discrepancy = "none", nMCMC = 300, nBurn = 100,
                   nChains = 1, converge = FALSE)
  out <- capture.output(print(fit))
  expect_snapshot(cat(grep("replicates:", out, value = TRUE), sep = "\n"))
  expect_snapshot(print(calibrate(pb$sim, pb$field, fit = FALSE)))
  expect_snapshot(FBC:::sim_noise_line(suppressMessages(
    calibrate(pb$sim, pb$field, simNoise = "none", fit = FALSE))))
})

test_that("what the simulator's noise cannot do is refused, naming simNoise", {
  pb <- stochastic_problem(nx = 4, nt = 3, reps = 2, nf = 4)
  same <- rbind(ballSim, ballSim[1:3, ])
  two <- two_outputs(m = 12)
  noisy <- two$sim[c(1:24, 1:3), ]
  noisy$y[25:27] <- noisy$y[25:27] + 0.1
  expect_snapshot(error = TRUE, {
    calibrate(noisy, two$field, output = "out", fit = FALSE)
    calibrate(function(x, kappa) 5 * exp(-kappa[["t"]] * x$x), pb$field, simNoise = "input")
    calibrate(pb$sim, pb$field, simNoise = "noisy")
    calibrate(same, ballField, simNoise = "constant", fit = FALSE)
    calibrate(function(x, kappa) 5 * exp(-kappa[["t"]] * x$x), pb$field, simNoise = "constant")
  })
  set.seed(1)
  fit <- calibrate(pb$sim, pb$field, discrepancy = "none", nMCMC = 200, nBurn = 100,
                   nChains = 1, converge = FALSE)
  # (propose_runs() scores such fits: test-propose_runs-noise.R)
  expect_true(is.logical(suppressMessages(propose_runs(fit, ndraws = 20))$replicate))
  # an input-dependent noise on more unique inputs than its dense latent GP takes
  big <- data.frame(y = stats::rnorm(4002), x = rep(seq(0, 1, length.out = 2001), 2),
                    t = rep((seq_len(2001) * 0.618034) %% 1, 2))
  expect_snapshot(error = TRUE,
    calibrate(big, data.frame(y = 1:3, x = c(0.2, 0.5, 0.8)), simNoise = "input", fit = FALSE))
})

test_that("a run with the simulator's noise resumes from its checkpoint, and takes new runs", {
  pb <- stochastic_problem(nx = 4, nt = 3, reps = 3, nf = 4)
  dir <- withr::local_tempdir()
  go <- function(...) {
    set.seed(2)
    calibrate(pb$sim, pb$field, discrepancy = "none", nMCMC = 300, nBurn = 100, nChains = 1,
              converge = FALSE, ...)
  }
  plain <- go()
  first <- go(checkpoint = dir)
  expect_identical(first$Phi, plain$Phi)
  expect_message(again <- go(checkpoint = dir), "Resuming")
  expect_identical(again$Phi, plain$Phi)
  # new replicates of existing inputs: the model keeps its unique inputs
  up <- update(plain, sim = pb$sim[1:12, ], nMCMC = 200, reweight = FALSE)
  expect_identical(up$model$design$simNoise$runs, 48L)
  expect_identical(up$model$dims$m, 12L)
  # (rows 1 to 12: the first 4 inputs, 3 runs each)
  expect_identical(up$model$spec$model$replicates$count, rep(c(6, 3), c(4, 8)))
})

# The latent GP's log density of g (plain R): N(muG, sigma2G (Rg + 1e-6 I)),
# Rg the Matern 5/2 correlation over the scaled inputs Xs.
latent_prior_plain <- function(g, Xs, muG, s2G, thetaG) {
  K <- s2G * (dense_corr(Xs, Xs, thetaG, rep(2, ncol(Xs)), "matern52") + 1e-6 * diag(nrow(Xs)))
  L <- chol(K)
  a <- backsolve(L, g - muG, transpose = TRUE)
  -0.5 * (length(g) * log(2 * pi) + 2 * sum(log(diag(L))) + sum(a^2))
}

# The covariance of the field rows and every run (plain R, dense: run r at
# unique input i has variance v_i on top of the emulator's covariance) and
# the residuals, standardised as the model's data.
full_row_system <- function(model, sim, phi, v, disc) {
  d <- model$data
  reps <- FBC:::sim_replicates(sim)
  ys <- (sim[, 1] - model$scale$ymean) / model$scale$ysd
  m <- nrow(d$Xs); n <- nrow(d$Xf)
  Cu <- dense_cov(d$Xf, d$Xs, phi, FBC:::fbc_nugget, "matern52", "matern52", disc)
  E <- rbind(cbind(diag(n), matrix(0, n, m)),
             cbind(matrix(0, length(ys), n), diag(m)[reps$group, , drop = FALSE]))
  th <- unpack_phi(phi, 1, 1, disc)
  list(C = E %*% Cu %*% t(E) + diag(c(rep(0, n), v[reps$group])),
       res = c(d$yf - if (disc == "gp") th$muB else 0, ys), n = n)
}

# The log-likelihood of every run (plain R, dense), noise variance exp(g_i).
input_noise_full <- function(model, sim, phi, g, disc) {
  sys <- full_row_system(model, sim, phi, exp(g), disc)
  C <- sys$C; res <- sys$res
  L <- chol(C)
  a <- backsolve(L, res, transpose = TRUE)
  -0.5 * (length(res) * log(2 * pi) + 2 * sum(log(diag(L))) + sum(a^2))
}

test_that("the input-dependent noise's likelihood is that of every run, plus the latent GP", {
  pb <- stochastic_problem(nx = 4, nt = 3, reps = c(1, 3, 2, 4), nf = 4, seed = 2)
  for (disc in c("gp", "none")) {
    model <- calibrate(pb$sim, pb$field, simNoise = "input", discrepancy = disc, fit = FALSE)
    d <- model$data
    m <- nrow(d$Xs)
    expect_identical(m, 12L)
    idx <- FBC:::param_indices(1, 1, disc, replicates = c(0L, m))
    expect_identical(names(idx)[length(idx) - 3:0], c("gR", "muG", "sigma2G", "thetaG"))
    expect_identical(lengths(idx[c("gR", "muG", "sigma2G", "thetaG")]),
                     c(gR = 12L, muG = 1L, sigma2G = 1L, thetaG = 2L))
    expect_identical(model$spec$vars[idx$gR], paste0("gR", 1:12))
    set.seed(3)
    for (k in 1:3) {
      phi <- random_phi(1, 1, disc)
      g <- stats::rnorm(m, -3, 0.7)
      muG <- stats::rnorm(1, -3); s2G <- stats::rgamma(1, 2, 2); thG <- stats::rgamma(2, 2, 1)
      got <- FBC:::.fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, c(phi, g, muG, s2G, thG), FBC:::fbc_nugget,
                               model = model$spec$model)
      ref <- input_noise_full(model, pb$sim, phi, g, disc) +
        latent_prior_plain(g, d$Xs, muG, s2G, thG)
      expect_equal(got, ref, tolerance = 1e-8)
    }
  }
  # the starting values: each input's log within variance, the pooled one
  # where it has one run
  model <- calibrate(pb$sim, pb$field, simNoise = "input", fit = FALSE)
  init <- model$spec$init[model$spec$classes == "gR"]
  ys <- (pb$sim[, 1] - model$scale$ymean) / model$scale$ysd
  grp <- FBC:::sim_replicates(pb$sim)$group
  v <- tapply(ys, grp, stats::var)
  pooled <- sum(tapply(ys, grp, function(y) sum((y - mean(y))^2))) / (nrow(pb$sim) - 12)
  expect_equal(init, log(ifelse(is.na(v), pooled, v)), ignore_attr = TRUE)
  expect_equal(model$spec$init[model$spec$classes == "muG"], mean(init))
})

# A tiny problem whose only unknowns are the latent log-variances at 5
# unique inputs (x and t crossed): everything else fixed at values near the truth.
tiny_latent <- function(nMCMC, seed = 4, s2G = "fixed", ...) {
  set.seed(1)
  x <- c(0.2, 1.5, 2.8, 0.2, 2.8)
  X <- cbind(x = rep(x, c(3, 4, 3, 2, 3)), t = rep(c(1.2, 1.7, 1.2, 2.2, 2.2), c(3, 4, 3, 2, 3)))
  sim <- cbind(y = 5 * exp(-X[, "t"] * X[, "x"]) + stats::rnorm(nrow(X), 0, 0.1 + 0.1 * X[, "x"]), X)
  field <- cbind(y = 5 * exp(-1.7 * c(0.5, 2)) + c(0.03, -0.02), x = c(0.5, 2))
  h <- set_hyperPriors(thetaSDist = "fixed", thetaSInit = c(0.5, 1),
                       sigma2SDist = "fixed", sigma2SInit = 1, sigma2EDist = "fixed",
                       sigma2EInit = 0.01, muGDist = "fixed", muGInit = -3,
                       sigma2GDist = s2G, sigma2GInit = 1, thetaGDist = "fixed",
                       thetaGInit = c(1, 1))
  set.seed(seed)
  calibrate(sim, field, simNoise = "input", discrepancy = "none", hypers = h,
            kappaDist = "fixed", kappaInit = 1.7, nMCMC = nMCMC, nBurn = 200, nChains = 1,
            converge = FALSE, ...)
}

test_that("elliptical slice sampling gives the latent log-variances' posterior", {
  fit <- tiny_latent(4000)
  mo <- fit$model
  d <- mo$data
  G <- fit$Phi[, paste0("gR", 1:5)]
  # the exact posterior by importance sampling from the GP prior (plain R):
  # weights the likelihood of every run
  phi0 <- mo$spec$init[!mo$spec$classes %in% FBC:::sim_noise_classes]
  set.seed(9)
  K <- dense_corr(d$Xs, d$Xs, c(1, 1), c(2, 2), "matern52") + 1e-6 * diag(5)
  Z <- matrix(stats::rnorm(5 * 20000), ncol = 5) %*% chol(K) - 3
  ll <- apply(Z, 1, function(g) input_noise_full(mo, mo$raw$sim, phi0, g, "none"))
  w <- exp(ll - max(ll)); w <- w / sum(w)
  mu <- colSums(w * Z)
  sdv <- sqrt(colSums(w * (Z - rep(mu, each = nrow(Z)))^2))
  expect_gt(1 / sum(w^2), 2000)  # enough importance draws
  # the chain's means within 4 Monte Carlo sds (its effective draws from
  # batch means), its sds within 15%
  bm <- apply(G, 2, function(v) stats::sd(colMeans(matrix(v, 100))) / sqrt(ncol(matrix(v, 100))))
  expect_true(all(abs(colMeans(G) - mu) < 4 * bm + 0.02))
  expect_equal(apply(G, 2, stats::sd), sdv, tolerance = 0.15, ignore_attr = TRUE)
  # set.seed() reproduces the run
  expect_identical(tiny_latent(300)$Phi, tiny_latent(300)$Phi)
})

test_that("with sigma2G sampled too, the moves give the joint posterior", {
  skip_if_not_slow()
  # the slice move of g, the walk of sigma2G given g and the move of both
  # with the whitened g fixed, against importance sampling from the prior
  fit <- tiny_latent(6000, s2G = "halft_sd")
  mo <- fit$model
  d <- mo$data
  expect_true("latent shift" %in% FBC:::move_report(fit)$move)
  phi0 <- mo$spec$init[!mo$spec$classes %in% FBC:::sim_noise_classes]
  set.seed(10)
  N <- 40000
  sdG <- abs(stats::rcauchy(N))
  K <- dense_corr(d$Xs, d$Xs, c(1, 1), c(2, 2), "matern52") + 1e-6 * diag(5)
  Z <- sdG * (matrix(stats::rnorm(5 * N), ncol = 5) %*% chol(K)) - 3
  # (gR's own prior: flat on [-50, 50]; far out the runs' likelihood is nil)
  ll <- apply(Z, 1, function(g) if (all(abs(g) < 50) && all(g > -15)) {
    input_noise_full(mo, mo$raw$sim, phi0, g, "none")
  } else -Inf)
  w <- exp(ll - max(ll)); w <- w / sum(w)
  expect_gt(1 / sum(w^2), 1000)
  ref <- c(colSums(w * Z), sum(w * log(sdG^2)))
  got <- cbind(fit$Phi[, paste0("gR", 1:5)], log(fit$Phi[, "sigma2G"]))
  bm <- apply(got, 2, function(v) stats::sd(colMeans(matrix(v, 100))) / sqrt(ncol(matrix(v, 100))))
  expect_true(all(abs(colMeans(got) - ref) < 4 * bm + 0.03))
})

test_that("an input-dependent noise predicts its sd, prints, and resumes from a checkpoint", {
  fit <- tiny_latent(300)
  # at a unique input (x = 1.5, t = kappa = 1.7) the latent GP gives that
  # input's own log-variance (up to the jitter)
  pr <- predict(fit, c(1.5, 0.2), type = "simulator", ndraws = 100)
  rows <- attr(pr, "draw_rows")
  expect_equal(pr$noiseSd[1], sqrt(mean(exp(fit$Phi[rows, "gR2"]))) * fit$model$scale$ysd,
               tolerance = 1e-4)
  # elsewhere, the conditional log-normal mean (plain R, one draw)
  one <- predict(fit, c(1, 2.5), type = "simulator", method = "MAP")
  ph <- fit$Phi[which.max(fit$logPost), ]
  Xs <- fit$model$data$Xs
  sc <- fit$model$scale
  Z <- cbind((c(1, 2.5) - sc$xmin[1]) / (sc$xmax[1] - sc$xmin[1]),
             (1.7 - sc$xmin[2]) / (sc$xmax[2] - sc$xmin[2]))
  K <- dense_corr(Xs, Xs, c(1, 1), c(2, 2), "matern52") + 1e-6 * diag(5)
  k <- dense_corr(Xs, Z, c(1, 1), c(2, 2), "matern52")
  g <- ph[paste0("gR", 1:5)]
  mu <- -3 + drop(t(k) %*% solve(K, g + 3))
  v <- 1 + 1e-6 - colSums(k * solve(K, k))
  expect_equal(one$noiseSd, sqrt(exp(mu + v / 2)) * fit$model$scale$ysd, tolerance = 1e-6)
  out <- capture.output(print(fit))
  expect_match(out, "input-dependent", all = FALSE)
  # print() summarises the latent log-variances in one line: their count
  # and the range of their medians, none of them as a row of the table
  expect_false(any(grepl("^gR[0-9]+ ", out)))
  med <- apply(fit$Phi[, paste0("gR", 1:5)], 2, stats::median)
  line <- grep("^gR: ", out, value = TRUE)
  expect_match(line, sprintf("5 latent log-variances .* medians %s to %s;",
                             format(signif(min(med), 3)), format(signif(max(med), 3))))
  expect_true(all(paste0("gR", 1:5) %in% attr(summary(fit), "row.names")))
  # a checkpointed run is the same run, and resumes
  dir <- withr::local_tempdir()
  first <- tiny_latent(300, checkpoint = dir)
  expect_identical(first$Phi, fit$Phi)
  expect_message(again <- tiny_latent(300, checkpoint = dir), "Resuming")
  expect_identical(again$Phi, fit$Phi)
})

# The exact leave-one-out log density of each field row given the others
# and every run (plain R, the full-row covariance: run r at unique input i
# with noise variance v_i), from the inverse covariance.
loo_plain <- function(model, sim, phi, v, disc) {
  sys <- full_row_system(model, sim, phi, v, disc)
  n <- sys$n
  Q <- solve(sys$C)
  a <- drop(Q %*% sys$res)[1:n]
  q <- diag(Q)[1:n]
  -0.5 * log(2 * pi) + 0.5 * log(q) - 0.5 * a^2 / q
}

test_that("loo() compares simNoise choices on the same field data", {
  skip_if_not_installed("loo")
  pb <- stochastic_problem(nx = 4, nt = 3, reps = c(2, 3), nf = 5, seed = 5)
  # each model's pointwise density is that of the field row given the other
  # field rows and every run (the means carry all the runs say of eta)
  set.seed(6)
  for (mode in c("constant", "input")) {
    model <- calibrate(pb$sim, pb$field, simNoise = mode, fit = FALSE)
    d <- model$data
    phi <- random_phi(1, 1, "gp")
    noise <- if (mode == "constant") stats::rgamma(1, 2, 20) else
      c(stats::rnorm(12, -3, 0.5), -3, 0.5, 1, 2)
    v <- if (mode == "constant") rep(noise, 12) else exp(noise[1:12])
    got <- FBC:::.fbc_loo(d$Xf, d$yf, d$Xs, d$ys, rbind(c(phi, noise)), FBC:::fbc_nugget,
                          group = seq_len(nrow(d$Xf)), model = model$spec$model)
    expect_equal(drop(got), loo_plain(model, pb$sim, phi, v, "gp"), tolerance = 1e-8)
  }
  # fits under each choice: loo objects over the same 5 field observations
  fits <- lapply(c(none = "none", constant = "constant", input = "input"), function(mode) {
    set.seed(8)
    suppressMessages(calibrate(pb$sim, pb$field, simNoise = mode, nMCMC = 300, nBurn = 200,
                               nChains = 2, converge = FALSE))
  })
  loos <- lapply(fits, function(f) suppressWarnings(loo::loo(f, ndraws = 200)))
  expect_true(all(vapply(loos, function(l) nrow(l$pointwise), integer(1)) == 5L))
  cmp <- suppressWarnings(loo::loo_compare(loos))
  expect_setequal(rownames(cmp), names(fits))
  expect_equal(unname(cmp[, "elpd_diff"][1]), 0)
})

test_that("a field that is one realization carries the simulator's noise in its variance", {
  pb <- stochastic_problem(nx = 4, nt = 3, reps = c(1, 3, 2, 4), nf = 4, seed = 2)
  set.seed(9)
  for (disc in c("gp", "none")) {
    model <- calibrate(pb$sim, pb$field, simNoise = "constant", fieldLink = "realization",
                       discrepancy = disc, fit = FALSE)
    mean_model <- calibrate(pb$sim, pb$field, simNoise = "constant", discrepancy = disc,
                            fit = FALSE)
    expect_true(model$spec$model$replicates$realization)
    expect_null(mean_model$spec$model$replicates$realization)
    d <- model$data
    n <- nrow(d$Xf)
    for (k in 1:2) {
      phi <- random_phi(1, 1, disc)
      r <- stats::rgamma(1, 2, 20)
      full <- c(phi, r)
      # plain R on every run: the field rows' variance gains r
      sys <- full_row_system(model, pb$sim, phi, rep(r, nrow(d$Xs)), disc)
      C <- sys$C + diag(c(rep(r, n), rep(0, length(sys$res) - n)))
      L <- chol(C)
      a <- backsolve(L, sys$res, transpose = TRUE)
      ref <- -0.5 * (length(sys$res) * log(2 * pi) + 2 * sum(log(diag(L))) + sum(a^2))
      got <- FBC:::.fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, full, FBC:::fbc_nugget,
                               model = model$spec$model)
      expect_equal(got, ref, tolerance = 1e-8)
      # the mean link is the same model without that term
      sysM <- full_row_system(mean_model, pb$sim, phi, rep(r, nrow(d$Xs)), disc)
      expect_equal(FBC:::.fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, full, FBC:::fbc_nugget,
                                     model = mean_model$spec$model),
                   as.numeric(determinant(sysM$C)$modulus) * -0.5 - 0.5 *
                     (length(sysM$res) * log(2 * pi) + sum(sysM$res * solve(sysM$C, sysM$res))),
                   tolerance = 1e-8)
      # leave-one-out densities of the field rows (what loo() compares)
      Q <- solve(C)
      q <- diag(Q)[1:n]
      aa <- drop(Q %*% sys$res)[1:n]
      loo_ref <- -0.5 * log(2 * pi) + 0.5 * log(q) - 0.5 * aa^2 / q
      got_loo <- FBC:::.fbc_loo(d$Xf, d$yf, d$Xs, d$ys, rbind(full), FBC:::fbc_nugget,
                                group = seq_len(n), model = model$spec$model)
      expect_equal(drop(got_loo), loo_ref, tolerance = 1e-8)
      # a new field observation at the first field input: its variance and
      # covariances as row 1's (the field's noise r + sigma2E its own)
      th <- unpack_phi(phi, 1, 1, disc)
      kv <- C[, 1]
      kv[1] <- kv[1] - th$sigma2E - r
      pr <- FBC:::.fbc_predict(d$Xf, d$yf, d$Xs, d$ys, rbind(full), d$Xf[1, , drop = FALSE],
                               type = 1L, nugget = FBC:::fbc_nugget, block = 10L,
                               model = model$spec$model, noise = integer(), source = integer())
      mu0 <- if (disc == "gp") th$muB else 0
      expect_equal(drop(pr$mean), mu0 + sum(kv * solve(C, sys$res)), tolerance = 1e-8)
      expect_equal(drop(pr$var), C[1, 1] - sum(kv * solve(C, kv)), tolerance = 1e-8)
    }
  }
})

test_that("loo() compares the field links on the same data, and ppc_field() follows the link", {
  skip_if_not_installed("loo")
  pb <- stochastic_problem(nx = 4, nt = 3, reps = c(2, 3), nf = 5, seed = 5)
  fits <- lapply(c(mean = "mean", realization = "realization"), function(link) {
    set.seed(8)
    calibrate(pb$sim, pb$field, fieldLink = link, discrepancy = "none", nMCMC = 200,
              nBurn = 100, nChains = 2, converge = FALSE)
  })
  loos <- lapply(fits, function(f) suppressWarnings(loo::loo(f, ndraws = 100)))
  expect_true(all(vapply(loos, function(l) nrow(l$pointwise), integer(1)) == 5L))
  cmp <- suppressWarnings(loo::loo_compare(loos))
  expect_setequal(rownames(cmp), names(fits))
  # the replicated field data: each draw's predictive variance carries r
  # under "realization" (as predict(type = "field") of that draw)
  f <- fits$realization
  set.seed(1)
  pp <- ppc_field(f, ndraws = 20)
  rows <- FBC:::check_rows(f, "Bayesian", 20)
  phis <- FBC:::sampler_draws(f, rows)
  d <- f$model$data
  one <- FBC:::.fbc_predict(d$Xf, d$yf, d$Xs, d$ys, phis, d$Xf, type = 1L,
                            nugget = f$settings$nugget, block = 100L, model = f$model$spec$model,
                            noise = integer(), source = integer())
  ysd <- f$model$scale$ysd
  expect_equal(pp$obs$sd^2, ysd^2 * (rowMeans(one$var) + rowMeans((one$mean - rowMeans(one$mean))^2)),
               tolerance = 1e-8)
  # and the field's noise is at least r at every draw
  expect_true(all(one$var >= matrix(phis[, ncol(phis)], nrow(one$var), ncol(one$var), byrow = TRUE)))
  expect_snapshot(print(calibrate(pb$sim, pb$field, fieldLink = "realization", fit = FALSE)))
  expect_snapshot(error = TRUE, {
    calibrate(pb$sim, pb$field, simNoise = "input", fieldLink = "realization", fit = FALSE)
    calibrate(pb$sim, pb$field, simNoise = "none", fieldLink = "realization", fit = FALSE)
    calibrate(pb$sim, pb$field, fieldLink = "one")
    calibrate(function(x, kappa) 5 * exp(-kappa[["t"]] * x$x), pb$field, fieldLink = "realization")
  })
})
