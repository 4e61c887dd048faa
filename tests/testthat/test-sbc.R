# Simulation-based calibration (Talts et al. 2018): if the sampler draws from
# the exact posterior, the rank of a parameter drawn from its prior among
# posterior draws given data simulated from it is uniform. sbc_ranks() and
# rank_chisq() are in helper-chains.R; the larger run is
# bench/validation/sbc.R (results in bench/validation/sbc-results.md).

test_that("SBC ranks of kappa, sigma2S, sigma2E and muB are uniform", {
  skip_if_not_slow()
  ranks <- sbc_ranks(L = 400, seed = 42, sampler = "single")
  expect_equal(dim(ranks), c(400, 4))
  expect_true(all(ranks >= 0 & ranks <= 99))
  pv <- suppressWarnings(rank_chisq(ranks))
  # four tests at a fixed seed; 0.01 each keeps a correct sampler's
  # false-alarm rate near 4%
  expect_true(all(pv > 0.01), label = paste("p-values", paste(signif(pv, 3), collapse = ", ")))
})

test_that("the same check rejects a posterior that is off (it has power)", {
  skip_if_not_slow()
  # data made with 2x the noise variance the model believes in: the true
  # sigma2E sits low among the posterior draws
  ranks <- sbc_ranks(L = 400, seed = 42, sigma2EFactor = 2, sampler = "single")
  pv <- suppressWarnings(rank_chisq(ranks))
  expect_lt(pv[3], 1e-4)
  expect_lt(mean(ranks[, 3]), 45) # 49.5 when uniform
})

test_that("SBC ranks are uniform under every joint move of the default sampler", {
  skip_if_not_slow()
  # thetaS and sigma2B sampled too: the (thetaS1, thetaS2, sigma2S) block with
  # its adapted proposal, the sigma2S/sigma2B/sigma2E scale move and the
  # exact muB draw all act (the vignette's one-at-a-time sampler: above)
  ranks <- sbc_ranks(L = 300, seed = 43, joint = TRUE)
  expect_equal(dim(ranks), c(300, 7))
  pv <- suppressWarnings(rank_chisq(ranks))
  # seven tests: 0.005 each keeps a correct sampler's false-alarm rate near 3.5%
  expect_true(all(pv > 0.005), label = paste("p-values", paste(signif(pv, 3), collapse = ", ")))
})
