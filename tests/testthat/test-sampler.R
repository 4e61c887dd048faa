# The sampler's moves: the schedule read off the model description, and the
# per-move report (acceptance and adapted scale by name).

# the ball data's model (p = q = 1) as calibrate() builds it
ball_spec <- function() {
  set.seed(1)
  calibrate(ballSim, ballField, nMCMC = 4, nBurn = 0, thinning = 1, nChains = 1,
            kernelS = "powexp", kernelB = "powexp")$spec  # with the smoothness parameters
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
  sp <- fit$spec
  res <- run_sampler(fit$data, sp, "single", nIter = 250, nBurn = 200, thinning = 1)
  moved <- res$state$logsd - sp$logsd
  free <- sp$table$family != FBC:::prior_families[["fixed"]]
  expect_equal(moved[free] / 0.5, round(moved[free] / 0.5))
  expect_true(all(abs(moved[free]) <= 2 + 1e-12))
})

test_that("the simulator block's sigma2S drawn from the runs' conditional targets the grid posterior", {
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
  tab <- fit$spec$table
  cols <- match(c("thetaS1", "thetaS2", "sigma2S"), fit$spec$vars)
  W <- log(FBC:::sampler_draws(fit)[, cols])
  phi <- fit$state$chains[[1]]$last
  dat <- fit$data
  g <- lapply(1:3, function(i) seq(mean(W[, i]) - 5 * sd(W[, i]), mean(W[, i]) + 5 * sd(W[, i]),
                                   length.out = 22))
  grid <- as.matrix(expand.grid(g))
  lp <- apply(grid, 1, function(w) {
    x <- exp(w)
    phi[cols] <- x
    .fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, model = fit$spec$model) +
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
  cols <- match(c("thetaS1", "thetaS2", "thetaS3", "sigma2S"), fit$spec$vars)
  W <- log(FBC:::sampler_draws(fit)[, cols])
  tab <- fit$spec$table
  phi <- fit$state$chains[[1]]$last
  dat <- fit$data
  g <- lapply(1:4, function(i) seq(mean(W[, i]) - 5 * sd(W[, i]), mean(W[, i]) + 5 * sd(W[, i]),
                                   length.out = 11))
  lp <- apply(as.matrix(expand.grid(g)), 1, function(w) {
    x <- exp(w)
    phi[cols] <- x
    .fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, model = fit$spec$model) +
      sum(vapply(1:4, function(i) FBC:::log_prior_row(tab, cols[i], x[i]), numeric(1))) + sum(w)
  })
  dens <- array(exp(lp - max(lp)), rep(11, 4))
  for (i in 1:4) {
    marg <- apply(dens, i, sum)
    marg <- marg / sum(marg)
    mu <- sum(g[[i]] * marg)
    s <- sqrt(sum((g[[i]] - mu)^2 * marg))
    expect_lt(abs(mean(W[, i]) - mu) / s, 0.1)
    expect_lt(abs(sd(W[, i]) / s - 1), 0.08)
  }
  # an explicit burn-in keeps the walk (the estimate's effective draws are
  # not known there)
  set.seed(5)
  fixed <- do.call(calibrate, c(args, list(nMCMC = 600, nBurn = 300)))
  expect_identical(FBC:::move_report(fixed)$kind, "joint")
})
