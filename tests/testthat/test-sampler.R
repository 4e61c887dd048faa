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
  expect_identical(rep$move, c("kappa1", "sim", "bias", "sigma2E", "muB", "scale"))
  expect_identical(rep$kind, c("walk", "joint", "joint", "single", "gibbs", "scale"))
  expect_identical(rep$parameters[2], "thetaS1,thetaS2,alphaS1,alphaS2,sigma2S")
  # tries: repeats x retained sweeps x chains
  ms <- lapply(fit$state$chains, function(s) s$sampler$moves)
  expect_identical(ms[[1]]$tries, c(3, 2, 2, 1, 1, 1) * 200)
  # a move's acceptance is the mean over chains of its parameters' acceptance
  # (equal tries per chain)
  expect_equal(rep$acceptance[rep$move == "sim"], mean(vapply(fit$state$chains,
    function(s) s$acceptance[["thetaS1"]], numeric(1))))
  expect_equal(rep$acceptance[rep$move == "muB"], 1)
  more <- update(fit, nMCMC = 100)
  ms2 <- lapply(more$state$chains, function(s) s$sampler$moves)
  expect_identical(ms2[[1]]$tries, c(3, 2, 2, 1, 1, 1) * 300)
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
