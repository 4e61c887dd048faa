# Fake draws put into a real fbc object, so each check sees a known situation.
with_draws <- function(fit, Phi, chain) {
  fit <- fit_with_draws(fit, Phi, chain, logPost = rep_len(fit$logPost, nrow(Phi)))
  fit$estimates <- estimate_table(Phi, chain)
  fit
}
iid_draws <- function(fit, nChains, n) {
  sup <- param_support(fit)
  d <- length(fit$vars)
  Phi <- vapply(seq_len(d), function(j) {
    lo <- if (is.finite(sup[j, 1])) sup[j, 1] else -5
    hi <- if (is.finite(sup[j, 2])) sup[j, 2] else lo + 10
    # mid-support, away from both bounds
    lo + (hi - lo) * stats::runif(nChains * n, 0.3, 0.7)
  }, numeric(nChains * n))
  colnames(Phi) <- fit$vars
  Phi
}

test_that("no message for well-mixed independent chains", {
  fit <- small_fit(nChains = 2)
  set.seed(1)
  x <- with_draws(fit, iid_draws(fit, 4, 500), rep(1:4, each = 500))
  expect_equal(convergence_messages(x), character())
})

test_that("chains that disagree give an R-hat message, too few draws an ESS message", {
  fit <- small_fit(nChains = 2)
  set.seed(1)
  Phi <- iid_draws(fit, 4, 500)
  Phi[1:500, "thetaB1"] <- Phi[1:500, "thetaB1"] + 5 # chain 1 elsewhere
  x <- with_draws(fit, Phi, rep(1:4, each = 500))
  expect_gt(x$estimates["thetaB1", "rhat"], 1.01)
  msg <- convergence_messages(x)
  expect_length(grep("R-hat above 1.01 for thetaB1 ", msg), 1)
  expect_length(grep("update\\(fit", msg), 2) # R-hat and ESS both say what to do

  y <- with_draws(fit, iid_draws(fit, 4, 50), rep(1:4, each = 50))
  msg <- convergence_messages(y)
  expect_length(grep("Bulk ESS below 400", msg), 1)
})

test_that("a joint move far from its target acceptance, with slow parameters, asks for a longer burn-in", {
  fit <- small_fit(nChains = 2)
  # set each chain's retained acceptance of the simulator block by hand
  with_acceptance <- function(fit, rates) {
    for (k in seq_along(rates)) {
      mv <- fit$state$chains[[k]]$sampler$moves
      i <- match("sim", mv$name)
      mv$accepted[i] <- rates[k] * mv$tries[i]
      fit$state$chains[[k]]$sampler$moves <- mv
    }
    fit
  }
  mv <- fit$state$chains[[1]]$sampler$moves
  simPars <- strsplit(mv$params[match("sim", mv$name)], ",", fixed = TRUE)[[1]]
  expect_true("thetaS1" %in% simPars)

  bad <- with_acceptance(fit, c(0.25, 0.62))
  msg <- shape_messages(bad, "thetaS1")
  expect_length(msg, 1)
  expect_match(msg, "accepted 25%, 62% of its proposals", fixed = TRUE)
  expect_match(msg, "100 burn-in sweeps", fixed = TRUE)
  expect_match(msg, "nBurn = 3000", fixed = TRUE)
  # too low is as bad as too high
  expect_length(shape_messages(with_acceptance(fit, c(0.05, 0.2)), "sigma2S"), 1)
  # on target, or its parameters converged: nothing to say
  good <- with_acceptance(fit, c(0.22, 0.3))
  expect_identical(shape_messages(good, "thetaS1"), character())
  expect_identical(shape_messages(bad, character()), character())
  expect_identical(shape_messages(bad, "kappa1"), character())
  # and convergence_messages() passes on the slow parameters it found
  set.seed(1)
  y <- with_draws(bad, iid_draws(bad, 4, 50), rep(1:4, each = 50))
  expect_length(grep("joint move of thetaS1, ", convergence_messages(y), fixed = TRUE), 1)
  # the single-site sampler has no joint move
  single <- small_fit(nChains = 2, sampler = "single")
  expect_identical(shape_messages(single, single$vars), character())
})

test_that("a single chain is pointed out", {
  fit <- small_fit(nChains = 1)
  set.seed(1)
  x <- with_draws(fit, iid_draws(fit, 1, 2000), rep(1L, 2000))
  expect_match(convergence_messages(x), "Only one chain", all = FALSE)
})

test_that("draws piling up at a bound are reported with a hint", {
  fit <- small_fit(nChains = 2, kernelS = "powexp", kernelB = "powexp")  # with smoothness parameters
  set.seed(1)
  Phi <- iid_draws(fit, 4, 500)
  Phi[, "alphaS1"] <- 2 - stats::runif(2000, 0, 1e-3)
  # kappa: the ball simulator design spans g in [6.044, 13.959]
  Phi[1:600, "kappa1"] <- 13.959 - stats::runif(600, 0, 0.01)
  x <- with_draws(fit, Phi, rep(1:4, each = 500))
  pile <- bound_piling(x)
  expect_equal(pile$var, c("kappa1", "alphaS1"))
  expect_equal(pile$bound, c(13.959, 2))
  expect_equal(pile$share, c(0.3, 1))
  msg <- convergence_messages(x)
  expect_match(msg, "100% of the draws of alphaS1 lie at its bound 2.*alphaSDist = \"fixed\"", all = FALSE)
  # at 2 the smooth families are the first advice
  expect_snapshot(writeLines(strwrap(grep("alphaS1", msg, value = TRUE), 78)))
  expect_match(msg, "30% of the draws of kappa1 lie at its bound 13.959", all = FALSE)
})

test_that("supports follow the priors: stretched beta and uniform kappa, [1, 2] alpha", {
  fit <- small_fit(nChains = 1, kernelS = "powexp", kernelB = "powexp")
  sup <- param_support(fit)
  expect_equal(unname(sup[1, ]), c(6.044, 13.959))
  expect_equal(unname(sup[match("alphaB1", fit$vars), ]), c(1, 2))
  expect_equal(unname(sup[match("sigma2E", fit$vars), ]), c(0, Inf))
  fit2 <- small_fit(nChains = 1, kappaDist = "uniform", kappaP1 = 7, kappaP2 = 12, kappaInit = 9)
  expect_equal(unname(param_support(fit2)[1, ]), c(7, 12))
})

test_that("R-hat and ESS use chains cut to a common length", {
  set.seed(2)
  x <- c(rnorm(300), rnorm(200))
  chain <- rep(1:2, c(300, 200))
  d <- chain_diagnostics(cbind(a = x), chain)
  m <- cbind(x[1:200], x[301:500])
  expect_equal(d$rhat, posterior::rhat(m))
  expect_equal(d$ess, posterior::ess_bulk(m))
  # a fixed parameter has none
  expect_true(all(is.na(unlist(chain_diagnostics(cbind(b = rep(1, 500)), chain)))))
})

test_that("an antithetic short chain's ESS is posterior's capped one, without its warning", {
  # alternating draws: the raw bulk ESS exceeds S log10(S), S = 60 draws in
  # all, and posterior caps it there (from 1.4, with a warning each time)
  set.seed(1)
  x <- rep(c(1, -1), 30) + rnorm(60, 0, 0.1)
  chain <- rep(1:2, each = 30)
  expect_no_warning(d <- chain_diagnostics(cbind(a = x), chain))
  ref <- suppressWarnings(posterior::ess_bulk(cbind(x[1:30], x[31:60])))
  expect_equal(d$ess, ref)
  if (utils::packageVersion("posterior") >= "1.4.0") expect_equal(d$ess, 60 * log10(60))
})

test_that("convergence_messages() wants an fbc object", {
  expect_snapshot(error = TRUE, convergence_messages(list()))
})

test_that("a chain that never moves a sampled parameter is reported, a fixed parameter is not", {
  fit <- small_fit(nChains = 2, hypers = set_hyperPriors(alphaSDist = "fixed", alphaSInit = 2),
                   kernelS = "powexp", kernelB = "powexp")
  set.seed(1)
  Phi <- iid_draws(fit, 4, 500)
  Phi[, c("alphaS1", "alphaS2")] <- 2  # fixed: constant in every chain
  x <- with_draws(fit, Phi, rep(1:4, each = 500))
  expect_equal(nrow(FBC:::stuck_chains(x)), 0)
  expect_equal(convergence_messages(x), character())
  # chain 3 stuck at its start for kappa1 and thetaS1
  Phi[1001:1500, "kappa1"] <- 9.5
  Phi[1001:1500, "thetaS1"] <- 0.25
  y <- with_draws(fit, Phi, rep(1:4, each = 500))
  st <- FBC:::stuck_chains(y)
  expect_equal(st$var, c("kappa1", "thetaS1"))
  expect_equal(st$chain, c(3, 3))
  expect_equal(st$value, c(9.5, 0.25))
  msg <- convergence_messages(y)
  expect_snapshot(writeLines(strwrap(grep("never moved", msg, value = TRUE), 78)))
  # all chains stuck: R-hat and ESS are NA, as for a fixed parameter, but the
  # message says it
  Phi[, "sigma2E"] <- 0.3
  z <- with_draws(fit, Phi, rep(1:4, each = 500))
  expect_true(is.na(z$estimates["sigma2E", "rhat"]))
  expect_length(grep("^Chain [1-4] never moved .*sigma2E", convergence_messages(z)), 4)
})

test_that("a chain in a local mode is reported, and the advice is not to run longer", {
  fit <- small_fit(nChains = 2)
  set.seed(4)
  Phi <- iid_draws(fit, 4, 500)
  chain <- rep(1:4, each = 500)
  sup <- param_support(fit)
  k <- match("kappa1", colnames(Phi))
  # chain 3 sits elsewhere in kappa1 (R-hat fails), its log posterior 6
  # units below the others' (the log posterior's sd within a chain: 1.2)
  Phi[chain == 3, k] <- Phi[chain == 3, k] + 0.25 * (sup[k, 2] - sup[k, 1])
  lp <- stats::rnorm(2000, -40, 1.2)
  lp[chain == 3] <- lp[chain == 3] - 6
  local <- function(lp) {
    x <- fit_with_draws(fit, Phi, chain, logPost = lp)
    x$estimates <- estimate_table(Phi, chain)
    x
  }
  x <- local(lp)
  expect_gt(x$estimates["kappa1", "rhat"], 1.01)
  m <- FBC:::local_mode_chains(x)
  best <- which.max(tapply(lp, chain, median))
  expect_equal(m$chain, 3)
  expect_equal(m$best, unname(best))
  expect_equal(m$var, "kappa1")
  expect_equal(m$value, median(Phi[chain == 3, k]))
  expect_equal(m$bestValue, median(Phi[chain == best, k]))
  expect_equal(m$logPost, median(lp[chain == 3]))
  expect_equal(m$draws, 500)
  msg <- convergence_messages(x)
  expect_length(grep("local mode", msg), 3)  # R-hat's, ESS's (if low) and its own
  expect_length(grep("update\\(fit", msg), 0)
  expect_snapshot(writeLines(strwrap(grep("^Chain 3 sits", msg, value = TRUE), 78)))
  # the same draws with the chains' log posteriors alike: the R-hat message
  # advises a longer run, and no chain is in a local mode
  y <- local(stats::rnorm(2000, -40, 1.2))
  expect_equal(nrow(FBC:::local_mode_chains(y)), 0)
  expect_length(grep("R-hat above 1.01 for kappa1.*Run longer", convergence_messages(y)), 1)
  # a lower chain 1.5 units down (within fbc_mode_gap): not a local mode
  lp2 <- stats::rnorm(2000, -40, 1.2)
  lp2[chain == 3] <- lp2[chain == 3] - 1.5
  expect_equal(nrow(FBC:::local_mode_chains(local(lp2))), 0)
  # a chain climbing from 12 units down to the others' level (still in its
  # warm-up): its second half is not low, so not a mode; run longer
  lp3 <- stats::rnorm(2000, -40, 1.2)
  lp3[chain == 3] <- lp3[chain == 3] - seq(12, 0, length.out = 500)
  z <- local(lp3)
  expect_equal(nrow(FBC:::local_mode_chains(z)), 0)
  expect_length(grep("Run longer", convergence_messages(z)), 2)
  # a chain 6 units down while every R-hat is fine: nothing to explain
  ok <- fit_with_draws(fit, iid_draws(fit, 4, 500), chain, logPost = lp)
  ok$estimates <- estimate_table(ok$Phi, chain)
  expect_equal(nrow(FBC:::local_mode_chains(ok)), 0)
})

test_that("a posterior pressing against its prior's bound is reported", {
  fit <- small_fit(nChains = 1, kappaDist = "uniform", kappaP1 = 7, kappaP2 = 12, kappaInit = 9)
  set.seed(3)
  Phi <- iid_draws(fit, 4, 500)
  chain <- rep(1:4, each = 500)
  # falling away from 12 with scale 0.5: its density is highest at 12 (2, against
  # a flat 0.2 over [7, 12]); only 5% of the draws within 0.5% of the range
  Phi[, "kappa1"] <- 12 - stats::rexp(2000, 2)
  x <- with_draws(fit, Phi, chain)
  expect_equal(nrow(FBC:::bound_piling(x)), 0)
  expect_equal(FBC:::bound_pressing(x), data.frame(var = "kappa1", bound = 12))
  msg <- convergence_messages(x)
  expect_snapshot(writeLines(strwrap(grep("presses", msg, value = TRUE), 78)))
  # near the bound but not against it, and flat over the range: no message
  Phi[, "kappa1"] <- stats::rnorm(2000, 11, 0.2)
  expect_equal(nrow(FBC:::bound_pressing(with_draws(fit, Phi, chain))), 0)
  Phi[, "kappa1"] <- stats::runif(2000, 7, 12)
  expect_equal(nrow(FBC:::bound_pressing(with_draws(fit, Phi, chain))), 0)
  # a variance falling from 0, its domain's bound, is not the prior's doing
  Phi[, "sigma2E"] <- stats::rexp(2000, 20)
  expect_equal(nrow(FBC:::bound_pressing(with_draws(fit, Phi, chain))), 0)
})

test_that("sigma2E held at a uniform prior's lower edge: ppc_field()'s hint and convergence_messages() agree", {
  fit <- small_fit(nChains = 1, hypers = set_hyperPriors(
    sigma2EDist = "uniform", sigma2EP1 = 0.5, sigma2EP2 = 1, sigma2EInit = 0.7))
  expect_output(print(ppc_field(fit)), "see convergence_messages")
  expect_equal(FBC:::bound_pressing(fit), data.frame(var = "sigma2E", bound = 0.5))
  expect_match(convergence_messages(fit),
               "The posterior of sigma2E presses against its prior's bound 0.5", all = FALSE)
})

test_that("calibration inputs that trade off: named, with what the data identify", {
  set.seed(1)
  s <- rnorm(4000, 0.9, 0.03)          # identified: kappa1 + kappa2
  k1 <- runif(4000, 0.05, 0.85)
  Phi <- cbind(kappa1 = k1, kappa2 = s - k1, kappa3 = runif(4000), sigma2E = rexp(4000))
  fit <- list(Phi = Phi, chain = rep(1:4, each = 1000))
  r <- FBC:::kappa_ridge(fit, c("kappa2", "sigma2E"))
  expect_length(r$groups, 1L)
  g <- r$groups[[1]]
  expect_identical(g$vars, c("kappa1", "kappa2"))
  expect_equal(g$coef, c(1, 1), tolerance = 0.03)
  expect_equal(g$sd, 0.03, tolerance = 0.05)
  expect_identical(r$vars, "kappa2")  # flagged and in a group
  expect_snapshot(cat(FBC:::ridge_messages(r)))
  # the R-hat / ESS message points at them instead of "run longer"
  est <- data.frame(rhat = c(1.2, 1.3, 1, 1), ess = c(50, 40, 900, 900),
                    row.names = colnames(Phi))
  msg <- FBC:::mixing_messages(est, 1:2, 1:2, data.frame(), r, 4L)
  expect_true(all(grepl("Calibration inputs that trade off (below) are the cause", msg, fixed = TRUE)))
  # independent kappas: none
  fit$Phi[, "kappa2"] <- runif(4000)
  expect_length(FBC:::kappa_ridge(fit)$groups, 0L)
})

test_that("kappa's draws with two modes are said, with their shares; one mode is not", {
  set.seed(2)
  two <- c(rnorm(2400, 0.54, 0.04), rnorm(1600, -0.18, 0.03))
  fit <- list(Phi = cbind(kappa1 = two), chain = rep(1:4, 1000))
  m <- FBC:::kappa_modes(fit)
  expect_equal(nrow(m), 2L)
  expect_equal(sort(m$at), c(-0.18, 0.54), tolerance = 0.03)
  expect_equal(m$share[order(m$at)], c(0.4, 0.6), tolerance = 0.01)
  expect_identical(m$chains, c(4L, 4L))
  expect_snapshot(cat(FBC:::kappa_modes_messages(fit)))
  # the mode near -0.18 only chain 3 visited, the other chains 1, 2 and 4
  fit$chain <- c(rep(c(1L, 2L, 4L), 800), rep(3L, 1600))
  expect_match(FBC:::kappa_modes_messages(fit),
               "Not every chain visited every mode (of the 4 chains: 1 near -0.1777, 3 near 0.5405)",
               fixed = TRUE)
  # unimodal shapes: a Gaussian, a skewed beta piled at a bound, a uniform
  for (d in list(rnorm(4000), rbeta(4000, 1, 8), runif(4000), rgamma(4000, 2))) {
    expect_null(FBC:::kappa_modes(list(Phi = cbind(kappa1 = d), chain = rep(1:4, 1000))))
  }
})

test_that("the field data's pull on the emulator: flagged above 3 runs-only sd, said with where to add runs", {
  fp <- list(pull = c(rep(3.4, 18), rep(2, 12)), rows = 1:30,
             kappa = cbind(kappa1 = c(rep(0.54, 18), rep(-0.18, 12)) + seq(0, 0.029, by = 0.001)))
  expect_snapshot(cat(FBC:::field_pull_text(fp)))
  fp$pull <- c(rep(2.9, 18), rep(3.5, 12))
  expect_length(FBC:::field_pull_text(fp), 0L)
  expect_length(FBC:::field_pull_text(NULL), 0L)
})

test_that("the field data's pull equals the plain-R conditionals at a draw", {
  fit <- small_fit(nChains = 1)
  fp <- FBC:::field_pull(fit)
  expect_length(fp$pull, 30L)
  d <- fit$model$data
  p <- ncol(d$Xf); q <- ncol(d$Xs) - p
  i <- 7L
  phi <- FBC:::sampler_draws(fit, fp$rows[i])[1, ]
  th <- unpack_phi(phi, p, q, fit$model$discrepancy)
  Z <- cbind(d$Xf, matrix(th$kappa, nrow(d$Xf), q, byrow = TRUE))
  # runs only: eta(Z) | ys
  K <- th$sigma2S * (dense_corr(d$Xs, d$Xs, th$thetaS, th$alphaS, "matern52") + 1e-6 * diag(nrow(d$Xs)))
  k <- th$sigma2S * dense_corr(d$Xs, Z, th$thetaS, th$alphaS, "matern52")
  mRuns <- drop(crossprod(k, solve(K, d$ys)))
  vRuns <- th$sigma2S - colSums(k * solve(K, k))
  # runs and field: eta(Z) | ys, yf
  joint <- dense_predict(d$Xf, d$yf, d$Xs, d$ys, phi, d$Xf, "simulator", kernS = "matern52",
                         kernB = "matern52", discrepancy = fit$model$discrepancy)
  expect_equal(fp$pull[i], max(abs(joint$mean - mRuns) / sqrt(vRuns)), tolerance = 1e-4)
})
