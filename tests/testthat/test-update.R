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
                   hypers = hyp, kernelS = "powexp", kernelB = "powexp")
  up <- update(fit, nMCMC = 5)
  for (k in 1:2) {
    last <- fit$state$chains[[k]]$last
    new1 <- up$Phi[up$chain == k, ][101, ]
    expect_equal(unname(new1[-1]), last[-1])
    # the stored state (sampler scale) is the last retained draw (native kappa)
    kap <- fit$model$scale$xmin[2] + (fit$model$scale$xmax[2] - fit$model$scale$xmin[2]) * last[1]
    expect_equal(unname(fit$Phi[fit$chain == k, ][100, 1]), kap)
  }
})

test_that("update() keeps the adapted joint proposals and goes on as one run", {
  # the default sampler: joint moves (the power exponential: the simulator
  # block's indices in Phi and in the sampler's vector agree)
  fit <- small_fit(nChains = 2, kernelS = "powexp", kernelB = "powexp")
  sim <- unlist(fit$indices[c("thetaS", "alphaS", "sigma2S")], use.names = FALSE)
  blocks <- fit$state$chains[[1]]$sampler$blocks
  b1 <- blocks[vapply(blocks, function(b) sim[1] %in% b$index, logical(1))][[1]]
  expect_identical(b1$index, sim)
  expect_true(b1$shaped)  # 100 burn-in sweeps shaped it to the draws' covariance
  # no longer diagonal: the shape came from the burn-in draws
  expect_gt(sum(abs(b1$chol[lower.tri(b1$chol)])), 0)
  set.seed(3)
  up <- update(fit, nMCMC = 40)
  expect_identical(up$model$sampler, "blocks")
  for (k in 1:2) {
    # frozen: the same factor and scale as the original run, not restarted
    for (b in seq_along(fit$state$chains[[k]]$sampler$blocks)) {
      old <- fit$state$chains[[k]]$sampler$blocks[[b]]
      new <- up$state$chains[[k]]$sampler$blocks[[b]]
      expect_identical(new[c("chol", "logscale", "shaped")], old[c("chol", "logscale", "shaped")])
    }
    expect_identical(up$state$chains[[k]]$sampler$scaleLogsd, fit$state$chains[[k]]$sampler$scaleLogsd)
    acc <- up$state$chains[[k]]$acceptance[sim]
    expect_length(unique(acc), 1)
  }
  expect_equal(as.vector(table(up$chain)), c(120, 120))
})

test_that("a run split by update() gives the same draws as one run", {
  # The sampler's state goes in and comes out whole, so with the same RNG
  # stream, sweeps run in two pieces equal sweeps run at once (calibrate()
  # and update() draw fresh streams per call, so call the sampler directly).
  set.seed(11)
  first <- calibrate(ballSim, ballField, nMCMC = 200, nBurn = 100, thinning = 2, nChains = 1)
  st <- first$state$chains[[1]]$sampler
  moves <- first$model$moves
  set.seed(12)
  a <- FBC:::sample_chain(first$model$data, first$model$spec, st, moves, 100L, 100L, 2L, FALSE)
  set.seed(12)
  b1 <- FBC:::sample_chain(first$model$data, first$model$spec, st, moves, 40L, 100L, 2L, FALSE)
  b2 <- FBC:::sample_chain(first$model$data, first$model$spec, b1$state, moves, 60L, 100L, 2L, FALSE)
  expect_identical(rbind(b1$draws[seq_len(b1$kept), ], b2$draws[seq_len(b2$kept), ]),
                   a$draws[seq_len(a$kept), ])
  expect_identical(b2$state, a$state)
  # a burn-in split in two pieces adapts exactly as in one piece
  sp <- first$model$spec
  st0 <- FBC:::initial_state(sp$init, sp)
  set.seed(13)
  a <- FBC:::sample_chain(first$model$data, sp, st0, moves, 160L, 120L, 1L, FALSE)
  set.seed(13)
  b1 <- FBC:::sample_chain(first$model$data, sp, st0, moves, 73L, 120L, 1L, FALSE)
  b2 <- FBC:::sample_chain(first$model$data, sp, b1$state, moves, 87L, 120L, 1L, FALSE)
  expect_identical(b2$draws, a$draws)
  expect_identical(b2$state, a$state)
})

test_that("update() checks its arguments", {
  fit <- small_fit(nChains = 1)
  expect_snapshot(error = TRUE, update(fit, nMCMC = 1))
  expect_snapshot(error = TRUE, update(fit, nMCMC = -3))
})

test_that("update() refuses arguments it does not use", {
  fit <- small_fit(nChains = 1)
  # `field` cannot be changed by update(): refit with calibrate() (new runs: `sim =`)
  expect_snapshot(error = TRUE, update(fit, nMCMC = 100, field = ballField))
  expect_snapshot(error = TRUE, update(fit, nmcmc = 100))
  # `reweight` is for new runs: without them it would be ignored
  expect_snapshot(error = TRUE, update(fit, nMCMC = 100, reweight = FALSE))
})

test_that("update() refuses run lengths whose draws cannot be stored", {
  fit <- small_fit(nChains = 2)
  withr_opts <- options(FBC.memory_limit = 8e9)
  on.exit(options(withr_opts))
  expect_snapshot(error = TRUE, {
    update(fit, nMCMC = 2^31)
    update(fit, nMCMC = .Machine$integer.max - 100)
    update(fit, nMCMC = 1e9)
  })
})

test_that("update() under a rule whose maxMCMC leaves no room says both numbers", {
  fit <- small_fit(nChains = 2)
  # the chains have run fit$settings$nMCMC sweeps; 100 more pass maxMCMC
  expect_snapshot(error = TRUE,
                  update(fit, nMCMC = 100, converge = until_converged(maxMCMC = fit$settings$nMCMC + 50)))
  expect_snapshot(error = TRUE,
                  update(fit, nMCMC = 100, converge = until_converged(maxMCMC = fit$settings$nMCMC)))
})

test_that("update(fit, nMCMC =) on a reweighted fit warns when its proposals are stale", {
  # the reweighted, continued fit of test-design.R's stale-proposal test:
  # its proposals, adapted at the fit on 12 runs, suit the posterior on 16
  # (no warning); made 400 times too long (as after several reweighted
  # steps) the continuation accepts almost nothing, and update() says which
  # moves (update_runs()'s own continuation refits instead)
  pb <- sinus_problem(m = 18)
  set.seed(3)
  fit <- suppressWarnings(calibrate(pb$sim[1:12, ], pb$field, discrepancy = "none", nChains = 2,
                                    showProgress = FALSE))
  set.seed(4)
  ok <- update(fit, sim = pb$sim[13:16, ])
  expect_true(ok$settings$reweight$used)
  expect_no_warning(more <- update(ok, nMCMC = 300))
  expect_equal(more$settings$nMCMC, ok$settings$nMCMC + 300)
  w <- expect_warning(update(stale_proposals(ok), nMCMC = 300), class = "fbc_stale_proposals")
  expect_match(conditionMessage(w), "kappa1")
  expect_match(conditionMessage(w), "calibrate(fit$model)", fixed = TRUE)
  set.seed(5)
  expect_snapshot(stale <- update(stale_proposals(ok), nMCMC = 300))
  # a fit that was not reweighted keeps its own proposals: never checked
  expect_no_warning(update(stale_proposals(fit), nMCMC = 300))
})

test_that("update(fit, sim = ) with runs the fit already has says so once", {
  pb <- sinus_problem()
  fit <- short_fit(pb)
  said <- character()
  up <- withCallingHandlers(
    update(fit, sim = pb$sim[1:2, ], nMCMC = 300, reweight = FALSE),
    message = function(m) {
      said <<- c(said, conditionMessage(m))
      invokeRestart("muffleMessage")
    })
  expect_length(grep("duplicated run", said), 1L)
  expect_match(said[grep("duplicated run", said)], "rows 1 and 13; 2 and 14")
})
