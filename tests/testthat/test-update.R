test_that("update() appends draws to every chain and keeps the old ones", {
  fit <- small_fit(nChains = 2)
  set.seed(2)
  up <- update(fit, nMCMC = 60)
  expect_equal(as.vector(table(up$chain)), c(130, 130))
  for (k in 1:2) {
    old <- fit$Phi[fit$chain == k, ]
    expect_equal(up$Phi[up$chain == k, ][1:100, ], old)
    expect_equal(up$logPost[up$chain == k][1:100], fit$logPost[fit$chain == k])
  }
  expect_equal(up$settings$nMCMC, 360)
  expect_equal(up$state$chains[[1]]$done, 360)
  expect_equal(up$state$chains[[1]]$kept, 130)
  # proposals stay frozen at their adapted values
  expect_equal(up$state$chains[[2]]$logsd, fit$state$chains[[2]]$logsd)
  expect_equal(nrow(up$estimates), length(up$vars))
})

test_that("update() continues each chain from where it stopped", {
  # with thinning 1 and only kappa free, the first new draw is one Metropolis
  # step from the stored state: every other coordinate is unchanged, and kappa
  # either stayed or moved
  hyp <- set_hyperPriors(
    thetaSDist = "fixed", alphaSDist = "fixed", thetaBDist = "fixed", alphaBDist = "fixed",
    sigma2SDist = "fixed", sigma2BDist = "fixed", sigma2EDist = "fixed", muBDist = "fixed"
  )
  set.seed(4)
  fit <- calibrate(ballSim, ballField, nMCMC = 200, nBurn = 100, thinning = 1, nChains = 2,
                   hypers = hyp)
  up <- update(fit, nMCMC = 5)
  for (k in 1:2) {
    last <- fit$state$chains[[k]]$last
    new1 <- up$Phi[up$chain == k, ][101, ]
    expect_equal(unname(new1[-1]), last[-1])
    # the stored state (sampler scale) is the last retained draw (native kappa)
    kap <- fit$scale$xmin[2] + (fit$scale$xmax[2] - fit$scale$xmin[2]) * last[1]
    expect_equal(unname(fit$Phi[fit$chain == k, ][100, 1]), kap)
  }
})

test_that("update() keeps a blocked run's adapted joint proposal", {
  fit <- small_fit(nChains = 2, blockSim = TRUE)
  sim <- unlist(fit$indices[c("thetaS", "alphaS")], use.names = FALSE)
  b1 <- fit$state$chains[[1]]$block
  expect_identical(b1$index, sim)
  expect_true(b1$shaped)  # 100 burn-in sweeps shaped it to the draws' covariance
  # no longer diagonal: the shape came from the burn-in draws
  expect_gt(sum(abs(b1$chol[lower.tri(b1$chol)])), 0)
  set.seed(3)
  up <- update(fit, nMCMC = 40)
  expect_true(up$settings$blockSim)
  for (k in 1:2) {
    # frozen: the same factor and scale as the original run, not restarted
    expect_identical(up$state$chains[[k]]$block$chol, fit$state$chains[[k]]$block$chol)
    expect_identical(up$state$chains[[k]]$block$logscale, fit$state$chains[[k]]$block$logscale)
    acc <- up$state$chains[[k]]$acceptance[sim]
    expect_length(unique(acc), 1)
  }
  expect_equal(as.vector(table(up$chain)), c(120, 120))
})

test_that("update() checks its arguments", {
  fit <- small_fit(nChains = 1)
  expect_snapshot(error = TRUE, update(fit, nMCMC = 1))
  expect_snapshot(error = TRUE, update(fit, nMCMC = -3))
})
