# The warm-up of data-dependent length (nBurn = NULL) and the run that stops
# when converged (nMCMC = NULL): where warm-up ends, that the draws are the
# posterior's (kappa against the grid posterior of helper-grid.R with
# dense_loglik() of helper-dense.R), and that a run of data-dependent
# length is reproduced by set.seed() on every plan and by its checkpoints.

# Every hyperparameter fixed (the values of test-exact-posterior.R): kappa
# alone is sampled, and its posterior is known on a grid.
# (in the power exponential's parameters: the calls name that kernel; the
# dense reference, helper-dense.R, is written in them)
kappa_only <- function(sigma2E = 0.15) {
  set_hyperPriors(
    thetaSDist = "fixed", thetaSInit = c(3.6, 0.42), alphaSDist = "fixed", alphaSInit = 1.95,
    thetaBDist = "fixed", thetaBInit = 2, alphaBDist = "fixed", alphaBInit = 1.8,
    sigma2SDist = "fixed", sigma2SInit = 3.3, sigma2BDist = "fixed", sigma2BInit = 0.9,
    sigma2EDist = "fixed", sigma2EInit = sigma2E, muBDist = "fixed", muBInit = 0.2
  )
}

expect_grid_kappa <- function(fit, u = seq(0, 1, length.out = 101), ...) {
  d <- fit$model$data
  expect_kappa_grid(fit, function(phi) {
    dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, fbc_nugget)
  }, u, ...)
}

test_that("warm-up ends early where the proposals settle at once, and the draws are the posterior's", {
  set.seed(31)
  # the default run (warm-up of data-dependent length, stop when converged)
  # with a larger ESS asked, for a sharp comparison with the grid
  fit <- calibrate(ballSim, ballField, nChains = 2, hypers = kappa_only(),
                   kernelS = "powexp", kernelB = "powexp", converge = until_converged(ess = 1500))
  # kappa's walk has its scale right within two windows of 100 sweeps: the
  # warm-up ends at the earliest (300 sweeps: two settled windows after the
  # first)
  expect_true(all(fit$settings$warmup <= 300))
  expect_length(fit$settings$warmupCapped, 0)
  expect_true(fit$settings$converge$converged)
  expect_gte(fit$estimates["kappa1", "ess"], 1500)
  # each chain kept the sweeps after its own warm-up, at thinning 2
  post <- fit$settings$converge$sweeps - fit$settings$warmup
  expect_equal(as.vector(table(fit$chain)), post %/% 2)
  expect_grid_kappa(fit)
})

test_that("warm-up goes on while a proposal is badly scaled, and the draws are the posterior's", {
  skip_if_not_slow()
  # precise field data (sigma2E fixed 1000 times smaller): kappa's posterior
  # is some 30 times narrower than its initial proposal SD, so its walk
  # accepts almost nothing until the scale has come down by steps of at
  # most 0.5 on the log scale
  set.seed(32)
  fit <- calibrate(ballSim, ballField, nChains = 2, hypers = kappa_only(sigma2E = 1.5e-4),
                   kernelS = "powexp", kernelB = "powexp", converge = until_converged(ess = 1500))
  expect_true(all(fit$settings$warmup >= 500))
  expect_true(all(fit$settings$warmup < 5000))
  expect_true(fit$settings$converge$converged)
  # the grid over where the posterior lies (on the sampler's [0, 1] scale;
  # fine: kappa's jump move visits a minor mode near 13.8, about 2% of the
  # draws, far from the main one near 6.2, so the draws' range is wide and
  # the main mode narrow within it: with 201
  # points the grid's own error gave KS 0.070-0.073 on seeds 32-35, with
  # 2001 points 0.011-0.019. Without the jump, on those seeds two chains
  # kept different modes: bulk ESS 7-8 after 99,000 draws)
  sc <- fit$model$scale
  u <- (fit$Phi[, "kappa1"] - sc$xmin[2]) / (sc$xmax[2] - sc$xmin[2])
  w <- diff(range(u))
  expect_grid_kappa(fit, seq(max(0, min(u) - w), min(1, max(u) + w), length.out = 2001))
})

test_that("print() says how long the warm-up was, and when it reached its maximum", {
  s <- list(nBurn = 700, warmup = c(500L, 700L), warmupBounds = list(min = 200L, max = 5000L),
            warmupCapped = integer())
  expect_identical(FBC:::warmup_text(s), "500-700 warm-up (adaptive)")
  s$warmup <- c(5000L, 700L)
  s$warmupCapped <- 1L
  expect_identical(FBC:::warmup_text(s), "700-5000 warm-up (adaptive, maximum 5000 reached by chain 1)")
  expect_identical(FBC:::warmup_text(list(nBurn = 2000)), "2000 burn-in")
})

test_that("the warm-up's maximum ends it, and thinning counts from its end", {
  set.seed(33)
  # nMCMC = 400: at most 200 sweeps of warm-up (half the run), too few for
  # the ball's hyperparameters to settle
  fit <- calibrate(ballSim, ballField, nMCMC = 400, nChains = 2, thinning = 3)
  expect_identical(fit$settings$warmup, c(200L, 200L))
  expect_identical(fit$settings$warmupCapped, 1:2)
  expect_match(FBC:::warmup_text(fit$settings), "maximum 200 reached by chain 1, 2")
  expect_equal(as.vector(table(fit$chain)), c(66, 66))  # (400 - 200) %/% 3
  expect_output(print(fit), "200 warm-up (adaptive, maximum 200", fixed = TRUE)
})

test_that("explicit nMCMC and nBurn keep the fixed run", {
  set.seed(34)
  fit <- calibrate(ballSim, ballField, nMCMC = 500, nBurn = 200, nChains = 2)
  expect_identical(fit$settings$warmup, c(200L, 200L))
  expect_null(fit$settings$converge)
  expect_null(fit$settings$warmupBounds)
  expect_equal(as.vector(table(fit$chain)), c(150, 150))
})

test_that("run-length arguments are checked, naming the argument", {
  expect_snapshot(error = TRUE, {
    calibrate(ballSim, ballField, nMCMC = 150)
    calibrate(ballSim, ballField, nBurn = 60000)
    calibrate(ballSim, ballField, nMCMC = 500, nBurn = 500)
  })
})

test_that("set.seed() reproduces a run of data-dependent length on every plan", {
  skip_if_not_slow()
  skip_on_cran()
  args <- list(ballSim, ballField, nChains = 2, kernelS = "matern52", kernelB = "matern52")
  set.seed(35)
  a <- do.call(calibrate, args)
  expect_true(a$settings$converge$converged)
  old <- future::plan(future::multisession, workers = 2)
  on.exit(future::plan(old), add = TRUE)
  set.seed(35)
  b <- do.call(calibrate, args)
  expect_identical(b$Phi, a$Phi)
  expect_identical(b$chain, a$chain)
  expect_identical(b$settings$warmup, a$settings$warmup)
  expect_identical(b$settings$converge$sweeps, a$settings$converge$sweeps)
  # update() under the rule goes on from the run's end the same way
  future::plan(future::sequential)
  set.seed(36)
  ua <- update(a, converge = until_converged(ess = 800))
  future::plan(future::multisession, workers = 2)
  set.seed(36)
  ub <- update(b, converge = until_converged(ess = 800))
  expect_identical(ub$Phi, ua$Phi)
  expect_gte(min(ua$estimates$ess), 800)
})

# A warm-up's epochs (src/sampler.cpp, Block::epoch()): window j (sweeps
# 100 j + 1 ... 100 (j + 1)) is in epoch 0 for j < 2, else floor(log2(j / 2)) + 1
# (sweeps 1-200, 201-400, 401-800, ...).
warm_epoch <- function(j) ifelse(j < 2, 0, floor(log2(j / 2)) + 1)

# The fewest effective draws per parameter in a joint block's estimate where
# its warm-up ended, in plain R from the block's state: its windows' draws
# weighted a = forget^(E - epoch) (E the newest window's epoch), of
# effective size N = sum(a n)^2 / sum(a^2 n) for independent draws, over the
# mixing time tau_i = nbar var(window means_i) / v_i measured on the recent
# windows (the newest two epochs; the newest alone when forget = 0: v_i
# their pooled variance, nbar their mean count): ESS_i = N / tau_i.
block_ess <- function(b, forget) {
  m <- as.matrix(b$winMeans)
  k <- nrow(m)
  n <- b$winCount
  ep <- warm_epoch(b$winIndex)
  E <- ep[length(ep)]
  a <- forget^(E - ep)
  N <- sum(a * n)^2 / sum(a^2 * n)
  r <- ep >= (if (forget > 0) E - 1 else E)
  mu <- drop(m[, r, drop = FALSE] %*% n[r]) / sum(n[r])
  m2 <- vapply(which(r), function(i) diag(as.matrix(b$winM2)[, (i - 1) * k + seq_len(k), drop = FALSE]),
               numeric(k))
  v <- (rowSums(matrix(m2, k)) + drop((m[, r, drop = FALSE] - mu)^2 %*% n[r])) / sum(n[r])
  s2 <- apply(m[, r, drop = FALSE], 1, stats::var)
  N * v / (mean(n[r]) * s2)
}

# Runs `code` with the warm-up's effective-draws rule at `ess` per
# parameter (fbc_warmup$ess, R/converge.R).
with_warmup_ess <- function(ess, code) {
  ns <- asNamespace("FBC")
  old <- get("fbc_warmup", ns)
  unlockBinding("fbc_warmup", ns)
  on.exit(assign("fbc_warmup", old, envir = ns), add = TRUE)
  assign("fbc_warmup", utils::modifyList(old, list(ess = ess)), envir = ns)
  force(code)
}

test_that("warm-up waits for the joint blocks' shapes to be learnt from enough effective draws", {
  skip_if_not_slow()
  # the ball drop with a second, irrelevant field input z: the simulator
  # block is thetaS of h, z and g and sigma2S (4 parameters), the bias block
  # thetaB of h and z and sigma2B (3): the rule holds blocks of 4 or more
  set.seed(39)
  sim <- cbind(ballSim[, 1:2], z = runif(nrow(ballSim)), ballSim[, 3, drop = FALSE])
  field <- cbind(ballField, z = runif(nrow(ballField)))
  args <- list(sim, field, nChains = 2, nMCMC = 3000)
  set.seed(38)
  fit <- with_warmup_ess(10, do.call(calibrate, args))
  # where warm-up ended (but at its maximum, half of nMCMC) each joint
  # block held at least 10 effective draws per parameter in its weighted
  # estimate, over at least 4 windows of 100 sweeps
  capped <- fit$settings$warmupCapped
  expect_true(all(fit$settings$warmup[capped] == 1500))
  expect_lt(length(capped), 2)
  for (k in setdiff(1:2, capped)) {
    st <- fit$state$chains[[k]]$sampler
    expect_identical(st$warmESS, 10)
    expect_identical(st$warmForget, 0.5)
    big <- Filter(function(b) length(b$index) >= 4, st$blocks)
    expect_length(big, 1)
    for (b in big) {
      expect_gte(sum(warm_epoch(b$winIndex) >= max(warm_epoch(b$winIndex)) - 1), 4)
      expect_true(all(block_ess(b, st$warmForget) >= 10 * length(b$index)))
    }
  }
  # without the rule the same chains end warm-up sooner: it is what held them
  set.seed(38)
  off <- with_warmup_ess(0, do.call(calibrate, args))
  expect_true(all(off$settings$warmup <= fit$settings$warmup))
  expect_true(any(off$settings$warmup < fit$settings$warmup))
})

test_that("a block's warm-up estimate keeps the earlier epochs at falling weights", {
  # walk positions of a 3-parameter block, correlated and drifting (as
  # early in a warm-up); 1450 sweeps: epochs 0-3 closed or open
  set.seed(40)
  S <- matrix(c(1, 0.5, 0.2, 0.5, 2, 0.3, 0.2, 0.3, 1), 3)
  W <- matrix(rnorm(1450 * 3), ncol = 3) %*% chol(S) + outer(1:1450, c(0.002, 0, -0.001))
  j <- (seq_len(nrow(W)) - 1) %/% 100
  for (forget in c(0, 0.5, 1)) {
    est <- FBC:::.fbc_block_estimate_c(W, forget)
    # the same draws, each weighted forget^(epochs before the newest)
    a <- forget^(warm_epoch(max(j)) - warm_epoch(j))
    ref <- stats::cov.wt(W, wt = a / sum(a), method = "ML")
    expect_equal(est$cov, ref$cov, tolerance = 1e-12)
    expect_equal(drop(est$mean), ref$center, tolerance = 1e-12)
    expect_identical(est$count, sum(a > 0))
    # the effective draws at the last window's end (1400) as block_ess() counts them
    w14 <- j < 14
    b <- list(winIndex = 0:13, winCount = rep(100, 14),
              winMeans = t(apply(W[w14, ], 2, function(x) tapply(x, j[w14], mean))),
              winM2 = do.call(cbind, lapply(0:13, function(i) {
                x <- W[j == i, ]
                crossprod(sweep(x, 2, colMeans(x)))
              })))
    expect_equal(est$ess, min(block_ess(b, forget)), tolerance = 1e-10)
  }
  # a block whose walk moves its first k - 1 parameters (sigma2S drawn from
  # its conditional, BlockMove's collapse) counts their effective draws
  # only: a last column that barely mixes (a slow drift) does not hold it
  Wd <- W
  Wd[, 3] <- Wd[, 3] + cumsum(rnorm(1450, 0, 0.3))
  bd <- b
  bd$winMeans[3, ] <- tapply(Wd[w14, 3], j[w14], mean)
  bd$winM2 <- do.call(cbind, lapply(0:13, function(i) crossprod(sweep(Wd[j == i, ], 2, colMeans(Wd[j == i, ])))))
  ess3 <- block_ess(bd, 0.5)
  expect_lt(ess3[3], min(ess3[1:2]))
  expect_equal(FBC:::.fbc_block_estimate_c(Wd, 0.5)$ess, min(ess3), tolerance = 1e-10)
  expect_equal(FBC:::.fbc_block_estimate_c(Wd, 0.5, walked = 2L)$ess, min(ess3[1:2]),
               tolerance = 1e-10)
  # a known mixing time: independent AR(1) walks with rho = 0.9 (integrated
  # autocorrelation time (1 + rho) / (1 - rho) = 19 sweeps), 6400 sweeps: the
  # effective draws are the weighted estimate's effective size over 19
  # (batch means over the 48 recent windows: within about 25%)
  set.seed(41)
  Z <- apply(matrix(rnorm(6400 * 3), ncol = 3), 2, function(e) stats::filter(e, 0.9, method = "recursive"))
  jz <- (seq_len(6400) - 1) %/% 100
  az <- 0.5^(warm_epoch(63) - warm_epoch(jz))
  N <- sum(az)^2 / sum(az^2)
  expect_equal(FBC:::.fbc_block_estimate_c(Z, 0.5)$ess / (N / 19), 1, tolerance = 0.25)
  # forget = 0 is the estimate started afresh at 200, 400, 800, ...: 650
  # draws since sweep 800; forget = 0.5 keeps all 1450, the epoch of sweeps
  # 801-1600 weighted 1, 401-800 1/2, 201-400 1/4, 1-200 1/8
  expect_identical(FBC:::.fbc_block_estimate_c(W, 0)$count, 650L)
  expect_identical(FBC:::.fbc_block_estimate_c(W, 0.5)$count, 1450L)
  # a new epoch's first draw barely moves the estimate (no restart): from
  # 800 to 801 draws the covariance moves by about 1/(weighted draws)
  e800 <- FBC:::.fbc_block_estimate_c(W[1:800, ], 0.5)$cov
  e801 <- FBC:::.fbc_block_estimate_c(W[1:801, ], 0.5)$cov
  expect_lt(max(abs(e801 - e800)), 0.05)
  expect_gt(max(abs(FBC:::.fbc_block_estimate_c(W[1:801, ], 0)$cov - e800)), 0.5)
})

test_that("a run interrupted in its warm-up resumes from its checkpoint to the uninterrupted draws", {
  skip_if_not_slow()
  args <- list(ballSim, ballField, nChains = 2, kernelS = "matern52", kernelB = "matern52")
  set.seed(37)
  ref <- do.call(calibrate, args)
  expect_true(all(ref$settings$warmup > 200))
  dir <- tempfile("ck-warm-")
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  # imitated Ctrl-C 200 sweeps (4 pieces) into chain 1: in its warm-up
  old <- options(FBC.sampler = interrupt_at_call(4))
  set.seed(37)
  expect_error(
    suppressWarnings(do.call(calibrate, c(args, list(checkpoint = dir)))),
    "before any draw was retained"
  )
  options(old)
  expect_equal(ck_iter(dir, 1), 200)
  ck <- readRDS(file.path(dir, "chain-1.rds"))
  expect_identical(ck$start$state$warmup, 0L)  # not ended yet
  set.seed(999)
  expect_message(fit <- do.call(calibrate, c(args, list(checkpoint = dir))), "Resuming")
  expect_identical(fit$Phi, ref$Phi)
  expect_identical(fit$settings$warmup, ref$settings$warmup)
  expect_identical(fit$settings$converge$sweeps, ref$settings$converge$sweeps)
})

test_that("a run of data-dependent length interrupted after its warm-up resumes to the uninterrupted draws", {
  skip_if_not_slow()
  # the ball drop with an irrelevant field input z: the simulator block
  # walks 4 parameters, so after warm-up it proposes from its warm-up
  # estimate, which the resumed piece must rebuild to the bit
  set.seed(39)
  sim <- cbind(ballSim[, 1:2], z = runif(nrow(ballSim)), ballSim[, 3, drop = FALSE])
  field <- cbind(ballField, z = runif(nrow(ballField)))
  args <- list(sim, field, nChains = 2)
  set.seed(37)
  ref <- do.call(calibrate, args)
  expect_identical(FBC:::move_report(ref)$kind[FBC:::move_report(ref)$move == "sim"], "independent")
  dir <- tempfile("ck-run-")
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  # imitated Ctrl-C 100 sweeps after chain 1's warm-up (pieces of 50 sweeps),
  # before its first check (500 sweeps after warm-up)
  at <- ref$settings$warmup[1] %/% 50 + 2L
  old <- options(FBC.sampler = interrupt_at_call(at))
  set.seed(37)
  expect_warning(part <- do.call(calibrate, c(args, list(checkpoint = dir))), "Resume it with the same")
  options(old)
  expect_equal(ck_iter(dir, 1), at * 50)
  expect_equal(nrow(part$Phi), 50)  # 100 retained sweeps at thinning 2
  set.seed(999)
  expect_message(fit <- do.call(calibrate, c(args, list(checkpoint = dir))), "Resuming")
  expect_identical(fit$Phi, ref$Phi)
  expect_identical(fit$settings$converge$sweeps, ref$settings$converge$sweeps)
})
