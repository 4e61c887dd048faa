# The sampler's moves: the schedule read off the model description, and the
# per-move report (acceptance and adapted scale by name).

# the ball data's model (p = q = 1) as calibrate() builds it
ball_spec <- function() {
  set.seed(1)
  calibrate(ballSim, ballField, nMCMC = 4, nBurn = 0, thinning = 1, nChains = 1,
            kernelS = "powexp", kernelB = "powexp")$model$spec  # with the smoothness parameters
}

test_that("the blocks schedule follows the model description's move column", {
  sp <- ball_spec()
  mv <- FBC:::sampler_moves("blocks", sp)
  idx <- FBC:::param_indices(1, 1)
  # one walk per kappa, the simulator GP's and the bias GP's joint moves
  expect_identical(names(mv$blocks), c("kappa1", "sim", "bias"))
  expect_identical(mv$blocks$sim, c(idx$thetaS, idx$alphaS, idx$sigma2S))
  expect_identical(mv$blocks$bias, c(idx$thetaB, idx$alphaB, idx$sigma2B))
  expect_identical(mv$repeats, c(3L, 2L, 2L))
  expect_true(mv$scale)
  expect_true(mv$gibbsMuB)
  expect_identical(mv$params, sp$vars)
})

test_that("each move is reported by name, and its counts add up over update()", {
  set.seed(3)
  fit <- calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, thinning = 2, nChains = 2,
                   kernelS = "powexp", kernelB = "powexp")
  rep <- FBC:::move_report(fit)
  expect_identical(rep$move, c("kappa1", "sim", "bias", "sigma2E", "muB", "kappa1 jump", "scale"))
  expect_identical(rep$kind, c("walk", "joint", "joint", "single", "gibbs", "jump", "scale"))
  expect_identical(rep$parameters[2], "thetaS1,thetaS2,alphaS1,alphaS2,sigma2S")
  # tries: repeats x retained sweeps x chains
  ms <- lapply(fit$state$chains, function(s) s$sampler$moves)
  expect_identical(ms[[1]]$tries, c(3, 2, 2, 1, 1, 1, 1) * 200)
  # a move's acceptance is the mean over chains of its parameters' acceptance
  # (equal tries per chain)
  expect_equal(rep$acceptance[rep$move == "sim"], mean(vapply(fit$state$chains,
    function(s) s$acceptance[["thetaS1"]], numeric(1))))
  expect_equal(rep$acceptance[rep$move == "muB"], 1)
  more <- update(fit, nMCMC = 100)
  ms2 <- lapply(more$state$chains, function(s) s$sampler$moves)
  expect_identical(ms2[[1]]$tries, c(3, 2, 2, 1, 1, 1, 1) * 300)
  expect_true(all(ms2[[1]]$accepted >= ms[[1]]$accepted))
})

test_that("kappa jumps over its prior's support, or its central 99.9% when unbounded", {
  # a kappa with a proper prior jumps; the interval is on the sampler's
  # scale x, where the prior's argument is a + b x
  tab <- data.frame(family = unname(FBC:::prior_families[c("beta", "uniform", "gaussian", "logistic")]),
                    p1 = c(1.1, 2, 9.8, 0), p2 = c(1.1, 5, 0.5, 2), a = c(0, 6, 4, 1), b = c(1, 3, 2, -2))
  r <- FBC:::jump_ranges(tab, 1:4)
  expect_equal(r[1, ], c(lower = 0, upper = 1))
  expect_equal(r[2, ], c(lower = (2 - 6) / 3, upper = (5 - 6) / 3))
  expect_equal(r[3, ], c(lower = (stats::qnorm(0.0005, 9.8, 0.5) - 4) / 2,
                         upper = (stats::qnorm(0.9995, 9.8, 0.5) - 4) / 2))
  # b < 0: the interval's ends swap
  expect_equal(r[4, ], c(lower = (stats::qlogis(0.9995, 0, 2) - 1) / -2,
                         upper = (stats::qlogis(0.0005, 0, 2) - 1) / -2))
  # the schedule: a fixed kappa does not jump; the moves carry the intervals
  sp <- FBC:::build_priors(list(dist = c("gaussian", "fixed"), init = c(0.5, 0.5), p1 = c(0.5, NA),
                                p2 = c(0.2, NA)), set_hyperPriors(),
                           list(xmin = rep(0, 3), xmax = rep(1, 3), p = 1, q = 2), 1, 2)
  sp$model <- FBC:::compiled_model(1, 2)
  mv <- FBC:::sampler_moves("blocks", sp)
  expect_identical(mv$jump, 1L)
  expect_equal(mv$jumpRange, FBC:::jump_ranges(sp$table, 1L))
  expect_null(FBC:::sampler_moves("blocks", sp, jump = FALSE)$jumpRange)
})

test_that("a jump from outside its interval is rejected, from inside it is made", {
  # kappa starts at 7 (0.12 on the sampler's scale), its walk's step 1e-9
  # and not adapted (nBurn = 0): only the jump can move it. With the
  # interval [0.3, 0.7] (the posterior's mode, near 0.47, inside; the
  # chain outside) the reverse proposal's density is 0 and every jump is
  # rejected; with [0, 0.7] (the chain inside) the jump moves it (this
  # build: acceptance 0.74, kappa 6.1-11.6).
  set.seed(1)
  m <- calibrate(ballSim, ballField, fit = FALSE, kappaInit = c(g = 7))
  m$spec$logsd[1] <- log(1e-9)
  runs <- lapply(list(c(0.3, 0.7), c(0, 0.7)), function(r) {
    m$moves$jumpRange[1, ] <- r
    set.seed(2)
    fit <- suppressWarnings(calibrate(m, nMCMC = 200, nBurn = 0, nChains = 1))
    list(kappa = fit$Phi[, "kappa1"], rep = FBC:::move_report(fit))
  })
  expect_equal(runs[[1]]$kappa, rep(7, 100), tolerance = 1e-6)
  expect_identical(runs[[1]]$rep$acceptance[runs[[1]]$rep$move == "kappa1 jump"], 0)
  expect_gt(runs[[2]]$rep$acceptance[runs[[2]]$rep$move == "kappa1 jump"], 0.2)
  expect_gt(diff(range(runs[[2]]$kappa)), 2)
})

test_that("moves stored without the jumps' intervals (fits made before they were stored) get them", {
  set.seed(1)
  m <- calibrate(ballSim, ballField, fit = FALSE)
  old <- m
  old$moves$jumpRange <- NULL
  set.seed(3)
  a <- suppressWarnings(calibrate(m, nMCMC = 200, nBurn = 100, nChains = 1))
  set.seed(3)
  b <- suppressWarnings(calibrate(old, nMCMC = 200, nBurn = 100, nChains = 1))
  expect_identical(a$Phi, b$Phi)
  # the compiled sampler refuses jumps without them
  sp <- m$spec
  st <- FBC:::initial_state(sp$init, sp)
  expect_error(FBC:::.fbc_sample(m$data$Xf, m$data$yf, m$data$Xs, m$data$ys, as.list(sp$table),
                                 old$moves, st, 10L, 0L, 1L, 1e-6, NULL, model = sp$model),
               "jumpRange")
})

test_that("proposalSD is the step each parameter's move makes, joint moves included", {
  set.seed(3)
  fit <- calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, thinning = 2, nChains = 1,
                   kernelS = "powexp", kernelB = "powexp")
  st <- fit$state$chains[[1]]$sampler
  sim <- st$blocks[[2]]
  # the joint move's marginal step: exp(s) times the SD its shape L gives
  want <- exp(sim$logscale) * sqrt(rowSums(sim$chol^2))
  expect_equal(unname(fit$proposalSD[c("thetaS1", "thetaS2", "alphaS1", "alphaS2", "sigma2S")]),
               want)
  expect_equal(fit$proposalSD[["sigma2E"]], exp(st$logsd[10]))
  # the exact draw of muB has no proposal
  expect_true(is.na(fit$proposalSD[["muB"]]))
  # the initial diagonal shape is gone: the report is not the starting SDs
  expect_false(isTRUE(all.equal(unname(fit$proposalSD[1:5]), c(0.1, 0.5, 0.5, 0.5, 0.5))))
})

test_that("single-site and adapted moves follow the one adaptation rule", {
  # log s moves by +-min(0.5, 1/sqrt(b)) at the end of batch b (50 sweeps):
  # after 4 burn-in batches every single-site log SD has moved by a sum of
  # four steps of 0.5, so it sits on a 0.5 grid from its start
  set.seed(1)
  fit <- calibrate(ballSim, ballField, nMCMC = 4, nBurn = 0, thinning = 1, nChains = 1)
  sp <- fit$model$spec
  res <- run_sampler(fit$model$data, sp, "single", nIter = 250, nBurn = 200, thinning = 1)
  moved <- res$state$logsd - sp$logsd
  free <- sp$table$family != FBC:::prior_families[["fixed"]]
  expect_equal(moved[free] / 0.5, round(moved[free] / 0.5))
  expect_true(all(abs(moved[free]) <= 2 + 1e-12))
})

test_that("the simulator block's sigma2S drawn from the runs' conditional targets the grid posterior", {
  skip_if_not_slow()
  # 30 runs, 12 field rows (p = q = 1), the Vecchia algebra with 5
  # neighbours (the algebra that gives ys' Ds^-1 ys ahead of a proposal),
  # every parameter fixed but thetaS1, thetaS2 and sigma2S: the sim block's
  # move walks the length-scales and draws sigma2S from IG(a + m/2, b +
  # zz/2), corrected by Metropolis-Hastings for the field data. Reference:
  # the compiled approximate log-likelihood times the priors on a 3-d grid
  # of (log thetaS1, log thetaS2, log sigma2S), its marginals' quantiles.
  d <- random_koh_data(12, 30, 1, 1, seed = 7)
  sim <- data.frame(y = d$ys, x = d$Xs[, 1], t = d$Xs[, 2])
  field <- data.frame(y = d$yf, x = d$Xf[, 1])
  hyp <- set_hyperPriors(thetaBDist = "fixed", thetaBInit = 2, sigma2BDist = "fixed",
                         sigma2BInit = 0.2, sigma2EDist = "fixed", sigma2EInit = 0.1,
                         muBDist = "fixed", muBInit = 0)
  set.seed(5)
  fit <- calibrate(sim, field, kappaDist = "fixed", kappaInit = 0.5, hypers = hyp,
                   algebra = "vecchia", neighbours = 5, nMCMC = 12000, nBurn = 2000,
                   nChains = 1)
  expect_identical(fit$model$moves$collapse, match("sim", names(fit$model$moves$blocks)))
  rep <- FBC:::move_report(fit)
  expect_identical(rep$parameters[rep$move == "sim"], "thetaS1,thetaS2,sigma2S")
  tab <- fit$model$spec$table
  cols <- match(c("thetaS1", "thetaS2", "sigma2S"), fit$model$spec$vars)
  W <- log(FBC:::sampler_draws(fit)[, cols])
  phi <- fit$state$chains[[1]]$last
  dat <- fit$model$data
  g <- lapply(1:3, function(i) seq(mean(W[, i]) - 5 * sd(W[, i]), mean(W[, i]) + 5 * sd(W[, i]),
                                   length.out = 22))
  grid <- as.matrix(expand.grid(g))
  lp <- apply(grid, 1, function(w) {
    x <- exp(w)
    phi[cols] <- x
    .fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, model = fit$model$spec$model) +
      sum(vapply(1:3, function(i) FBC:::log_prior_row(tab, cols[i], x[i]), numeric(1))) + sum(w)
  })
  dens <- array(exp(lp - max(lp)), c(22, 22, 22))
  probs <- c(0.05, 0.25, 0.5, 0.75, 0.95)
  for (i in 1:3) {
    marg <- apply(dens, i, sum)
    ref <- grid_quantile(g[[i]], marg, probs)
    got <- stats::quantile(W[, i], probs, names = FALSE)
    expect_lt(max(abs(got - ref)) / sd(W[, i]), 0.15)
  }
})

test_that("after warm-up the simulator block proposes from its warm-up estimate and targets the grid posterior", {
  skip_if_not_slow()
  # 40 runs of a smooth function (p = 2, q = 1), 12 field rows, the dense
  # algebra; every parameter fixed but thetaS1-3 and sigma2S: the simulator
  # block walks 4 parameters, so after a warm-up of data-dependent length
  # (nBurn = NULL) it proposes from a multivariate t fitted to its warm-up
  # draws (independence Metropolis-Hastings), with an explicit nBurn it
  # walks on. Reference: the compiled log-likelihood times the priors on a
  # 4-d grid of the walk's scales (11 points a side, +-5 sd), its marginals'
  # means and sds (the trapezoid rule, exact enough for smooth densities at
  # this spacing: a 13- or 17-point grid moves them by < 0.01 sd). Three
  # seeds measured: mean within 0.036 sd, sd within 3%.
  set.seed(3)
  Xs <- matrix(runif(40 * 3), 40, 3)
  f <- function(x1, x2, t) sin(3 * x1) + x2^2 + 0.5 * t
  sim <- data.frame(y = f(Xs[, 1], Xs[, 2], Xs[, 3]), x1 = Xs[, 1], x2 = Xs[, 2], t = Xs[, 3])
  Xf <- matrix(runif(12 * 2), 12, 2)
  field <- data.frame(y = f(Xf[, 1], Xf[, 2], 0.5) + rnorm(12, sd = 0.05), x1 = Xf[, 1], x2 = Xf[, 2])
  hyp <- set_hyperPriors(thetaBDist = "fixed", thetaBInit = c(2, 2), sigma2BDist = "fixed",
                         sigma2BInit = 0.2, sigma2EDist = "fixed", sigma2EInit = 0.01,
                         muBDist = "fixed", muBInit = 0)
  args <- list(sim, field, kappaDist = "fixed", kappaInit = 0.5, hypers = hyp, nChains = 1)
  set.seed(5)
  fit <- do.call(calibrate, c(args, list(nMCMC = 6000, converge = FALSE)))
  rep <- FBC:::move_report(fit)
  expect_identical(rep$kind, "independent")
  expect_identical(rep$parameters, "thetaS1,thetaS2,thetaS3,sigma2S")
  expect_length(fit$settings$warmupCapped, 0)
  expect_gt(rep$acceptance, 0.3)
  expect_true(is.na(rep$scale))
  expect_draws_match_grid(fit, c("thetaS1", "thetaS2", "thetaS3", "sigma2S"), 11)
  # an explicit burn-in keeps the walk (the estimate's effective draws are
  # not known there)
  set.seed(5)
  fixed <- do.call(calibrate, c(args, list(nMCMC = 600, nBurn = 300)))
  expect_identical(FBC:::move_report(fixed)$kind, "joint")
})

test_that("a simulator block of three parameters proposes from its warm-up estimate and targets the grid posterior", {
  skip_if_not_slow()
  # 30 runs (p = q = 1), 15 field rows; every parameter fixed but thetaS1,
  # thetaS2 and sigma2S: a block of three walked parameters, fewer than the
  # warm-up's effective-draws rule holds, which after a warm-up of
  # data-dependent length proposes from a multivariate t fitted to its
  # warm-up draws. Reference: the compiled log-likelihood times the priors
  # on a 21-point grid a side of the walk's scales (+-5 sd).
  set.seed(11)
  Xs <- matrix(runif(30 * 2), 30, 2)
  f <- function(x, t) sin(4 * x) + t * x
  sim <- data.frame(y = f(Xs[, 1], Xs[, 2]), x = Xs[, 1], t = Xs[, 2])
  xf <- runif(15)
  field <- data.frame(y = f(xf, 0.5) + rnorm(15, sd = 0.05), x = xf)
  hyp <- set_hyperPriors(thetaBDist = "fixed", thetaBInit = 1, sigma2BDist = "fixed",
                         sigma2BInit = 0.1, sigma2EDist = "fixed", sigma2EInit = 0.0025,
                         muBDist = "fixed", muBInit = 0)
  args <- list(sim, field, kappaDist = "fixed", kappaInit = 0.5, hypers = hyp, nChains = 1)
  set.seed(5)
  fit <- do.call(calibrate, c(args, list(nMCMC = 6000, converge = FALSE)))
  rep <- FBC:::move_report(fit)
  expect_identical(rep$kind, "independent")
  expect_identical(rep$parameters, "thetaS1,thetaS2,sigma2S")
  expect_gt(rep$acceptance, 0.3)
  expect_draws_match_grid(fit, c("thetaS1", "thetaS2", "sigma2S"), 21)
})

test_that("kappa's joint walk: an overlay block of the free kappas beside their own moves", {
  # q = 2 (the ball data's kappa with a second, made-up calibration input)
  sp <- function(q, fixed = FALSE) {
    set.seed(1)
    X <- cbind(x = runif(30), t1 = runif(30), t2 = runif(30))[, 1:(1 + q), drop = FALSE]
    sim <- data.frame(y = rowSums(X), X)
    field <- data.frame(y = 1 + runif(5), x = runif(5))
    kp <- if (fixed) list(kappaDist = c("beta", "fixed"), kappaInit = c(NA, 0.5)) else list()
    model <- do.call(calibrate, c(list(sim, field, fit = FALSE), kp))
    model$moves
  }
  mv <- sp(2)
  expect_identical(mv$overlay, length(mv$blocks))
  expect_identical(names(mv$blocks)[mv$overlay], "kappa")
  expect_identical(unname(mv$blocks[[mv$overlay]]), 1:2)
  expect_identical(mv$repeats[mv$overlay], 3L)
  # each kappa keeps its walk (once a sweep beside the joint one) and its jump
  expect_identical(unname(unlist(mv$blocks[c("kappa1", "kappa2")])), 1:2)
  expect_identical(mv$repeats[match(c("kappa1", "kappa2"), names(mv$blocks))], c(1L, 1L))
  expect_identical(mv$jump, 1:2)
  # one free kappa: no joint walk
  expect_length(sp(1)$overlay, 0L)
  expect_length(sp(2, fixed = TRUE)$overlay, 0L)
})

test_that("calibration inputs that trade off converge with the defaults and match the grid posterior", {
  # only kappa1 + kappa2 matters: f = (kappa1 + kappa2) sin(2 pi x) + x; no
  # discrepancy, sigma2E fixed; uniform priors on [0, 1]^2. Each kappa
  # walking alone took tens of thousands of sweeps.
  set.seed(1)
  x <- seq(0, 1, length.out = 20)
  field <- data.frame(y = 0.9 * sin(2 * pi * x) + x + rnorm(20, 0, 0.1), x = x)
  f <- function(x, kappa) (kappa[[1]] + kappa[[2]]) * sin(2 * pi * x$x) + x$x
  hyp <- set_hyperPriors(sigma2EDist = "fixed", sigma2EInit = 0.1^2 / stats::sd(field$y)^2)
  set.seed(2)
  fit <- calibrate(f, field, kappaDist = "uniform", kappaP1 = c(0, 0), kappaP2 = c(1, 1),
                   discrepancy = "none", hypers = hyp)
  cv <- fit$settings$converge
  expect_true(cv$converged)
  expect_lte(cv$sweeps, 5000L)
  mr <- FBC:::move_report(fit)
  expect_identical(mr$kind[mr$move == "kappa"], "joint")
  # plain R: the posterior on a grid of (kappa1, kappa2)
  g <- seq(0.0025, 0.9975, by = 0.005)
  s <- outer(g, g, `+`)
  sv <- sort(unique(round(s, 6)))
  llS <- vapply(sv, function(v) sum(dnorm(field$y, v * sin(2 * pi * x) + x, 0.1, log = TRUE)), 0)
  ll <- matrix(llS[match(round(s, 6), sv)], length(g))
  dens <- exp(ll - max(ll))
  probs <- c(0.05, 0.25, 0.5, 0.75, 0.95)
  # kappa1's marginal, and the identified sum
  m1 <- rowSums(dens)
  expect_lt(max(abs(quantile(fit$Phi[, "kappa1"], probs, names = FALSE) -
                      grid_quantile(g, m1, probs))) / sd(fit$Phi[, "kappa1"]), 0.15)
  sumDraws <- fit$Phi[, "kappa1"] + fit$Phi[, "kappa2"]
  ws <- tapply(as.vector(dens), round(as.vector(s), 6), sum)
  ref <- grid_quantile(as.numeric(names(ws)), as.vector(ws), probs)
  expect_lt(max(abs(quantile(sumDraws, probs, names = FALSE) - ref)) / sd(sumDraws), 0.15)
  # print() names the trade-off and what the data identify
  msg <- convergence_messages(fit)
  expect_true(any(grepl("kappa1, kappa2 trade off", msg, fixed = TRUE)))
  expect_true(any(grepl("the data identify kappa1 + kappa2", msg, fixed = TRUE)))
})
