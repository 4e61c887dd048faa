# Adding runs to a fit (R/update_runs.R): update(fit, sim =) with a warm
# start, the reweighting, the continuation and the refit.

test_that("update(fit, sim =) gives the posterior of a fit on all runs (grid)", {
  pb <- sinus_problem(m = 20)
  first <- pb
  first$sim <- pb$sim[1:12, ]
  fit <- sinus_fit(first)
  fit2 <- update(fit, sim = pb$sim[13:20, ], nMCMC = 4200)
  # the model is the one calibrate() builds on all runs
  all <- calibrate(pb$sim, pb$field, discrepancy = "none", hypers = sinus_hypers(), fit = FALSE)
  expect_identical(fit2$model$data, all$data)
  expect_identical(fit2$model$spec$table, all$spec$table)
  expect_true(fit2$settings$warmStart)
  # the refit's warm-up is the adaptive one (nBurn = NULL): its length is the
  # data's, and the draws kept are the sweeps after it
  w <- fit2$settings$warmup
  expect_true(w >= 200 && w < 4200)
  expect_equal(nrow(fit2$Phi), (4200 - w) / fit2$settings$thinning)
  # kappa's draws against the grid posterior on all 20 runs; 8 runs more
  # move it (the 12-run posterior is not the reference's)
  expect_kappa_grid(fit2, sinus_loglik(fit2$model$data))
  expect_gt(abs(mean(fit2$Phi[, 1]) - mean(fit$Phi[, 1])) / sd(fit2$Phi[, 1]), 0.1)
})

test_that("update(fit, sim =) carries the states to the new scaling", {
  pb <- sinus_problem(m = 20)
  old <- calibrate(pb$sim[1:12, ], pb$field, fit = FALSE)
  new <- calibrate(pb$sim, pb$field, fit = FALSE)
  phi <- old$spec$init
  ix <- FBC:::param_indices(1, 1, "gp")
  phi[ix$kappa] <- 0.3
  phi[ix$thetaS] <- c(2, 3)
  phi[ix$sigma2S] <- 1.5
  phi[ix$muB] <- 0.2
  out <- FBC:::warm_phi(phi, old, new)
  so <- old$scale
  sn <- new$scale
  # kappa in its own units, theta d^2 and the variances in the data's units kept
  expect_equal(sn$xmin[2] + (sn$xmax[2] - sn$xmin[2]) * out[ix$kappa],
               so$xmin[2] + (so$xmax[2] - so$xmin[2]) * 0.3)
  expect_equal(out[ix$thetaS] / (sn$xmax - sn$xmin)^2, c(2, 3) / (so$xmax - so$xmin)^2)
  expect_equal(out[ix$sigma2S] * sn$ysd^2, 1.5 * so$ysd^2)
  expect_equal(out[ix$muB] * sn$ysd + sn$ymean, 0.2 * so$ysd + so$ymean)
})

test_that("update(fit, sim =) carries each output's parameters to the new scaling", {
  # independent outputs: a copy of thetaS, alphaS and sigma2S per output,
  # each output standardised by its own runs' sd; new runs that stretch
  # the inputs' ranges and change each output's sd by its own ratio (the
  # copies beyond the first were left NA, and the refit failed)
  po <- two_outputs(m = 12)
  f1 <- function(x, t) 5 * exp(-t * x)
  f2 <- function(x, t) 2 * t * x
  extra <- data.frame(x = c(-0.3, 1.4), t = c(0.3, 3.5))
  more <- rbind(data.frame(y = f1(extra$x, extra$t), x = extra$x, out = "conc", t = extra$t),
                data.frame(y = f2(extra$x, extra$t), x = extra$x, out = "rate", t = extra$t))
  args <- list(output = "out", outputs = "independent", kernelS = "powexp", fit = FALSE)
  old <- do.call(calibrate, c(list(po$sim, po$field), args))
  # (two runs at the corners make x and t look related among 14: the
  # wide-format check's warning, not this test's subject)
  new <- suppressWarnings(do.call(calibrate, c(list(rbind(po$sim, more), po$field), args)))
  so <- old$scale
  sn <- new$scale
  expect_gt(abs(log((sn$ysd[1] / so$ysd[1]) / (sn$ysd[2] / so$ysd[2]))), 0.05)
  ix <- FBC:::param_indices(2, 1, "gp", noise = 2L, outputs = 2L)
  phi <- old$spec$init
  phi[ix$thetaS] <- 1:6
  phi[ix$alphaS] <- c(1.5, 1.8, 1.9, 1.2, 1.6, 1.7)
  phi[ix$sigma2S] <- c(1.5, 0.7)
  phi[ix$sigma2E] <- c(0.01, 0.02)
  phi[ix$sigma2B] <- c(0.3, 0.4)
  phi[ix$muB] <- c(0.2, -0.1)
  out <- FBC:::warm_phi(phi, old, new)
  # per output: theta d^alpha in the inputs' own units kept, the
  # variances and the bias mean in the output's own units
  # (the output's indicator column's thetaS and alphaS are fixed)
  fixed <- old$spec$table$family == FBC:::prior_families[["fixed"]]
  th <- setdiff(ix$thetaS, which(fixed))
  expect_length(th, 4)
  r <- rep((sn$xmax - sn$xmin) / (so$xmax - so$xmin), 2)
  expect_equal(out[th], phi[th] * r[th - 1]^phi[th + 6])
  expect_true(all(is.finite(out)))
  expect_equal(out[ix$sigma2S] * sn$ysd^2, phi[ix$sigma2S] * so$ysd^2)
  expect_equal(out[ix$sigma2B] * sn$ysd^2, phi[ix$sigma2B] * so$ysd^2)
  expect_equal(out[ix$sigma2E] * sn$ysd^2, phi[ix$sigma2E] * so$ysd^2)
  expect_equal(out[ix$muB] * sn$ysd + sn$ymean, phi[ix$muB] * so$ysd + so$ymean)
  # the Jacobian (reweight_log_jacobian()) against central differences of
  # warm_phi() over the length-scales and smoothnesses
  free <- c(th, th + 6)
  log_det <- function(x) {
    T <- function(v) FBC:::warm_phi(replace(x, free, v), old, new)[free]
    J <- vapply(seq_along(free), function(j) {
      h <- 1e-6 * max(1, abs(x[free[j]]))
      e <- replace(numeric(length(free)), j, h)
      (T(x[free] + e) - T(x[free] - e)) / (2 * h)
    }, numeric(length(free)))
    determinant(J)$modulus[1]
  }
  phi2 <- replace(phi, ix$alphaS, 2 - phi[ix$alphaS] / 4)
  jac <- FBC:::reweight_log_jacobian(rbind(phi, phi2), old, new)
  expect_equal(unname(jac[1] - jac[2]), log_det(phi) - log_det(phi2), tolerance = 1e-6)
})

test_that("the reweighting's weights are the new posterior over the old (plain-R dense)", {
  # the power exponential with alphaS sampled, and new runs that stretch the
  # design's ranges and the response's sd: every part of the map T and its
  # Jacobian is exercised
  pb <- sinus_problem(m = 14)
  pb$sim$x[13:14] <- c(-0.2, 1.3)
  pb$sim$y[13:14] <- sin(10 * pb$sim$u[13:14] * pb$sim$x[13:14]) * 1.5
  set.seed(4)
  fit <- calibrate(pb$sim[1:12, ], pb$field, discrepancy = "none", kernelS = "powexp",
                   nMCMC = 400, nBurn = 200, nChains = 2, showProgress = FALSE)
  new <- calibrate(pb$sim, pb$field, discrepancy = "none", kernelS = "powexp", fit = FALSE)
  expect_true(all(new$scale$xmax - new$scale$xmin != fit$model$scale$xmax - fit$model$scale$xmin))
  rows <- round(seq(3, nrow(fit$Phi), length.out = 6))
  lw <- FBC:::reweight_log_weights(fit, new, rows)
  # the reference: the new model's log posterior at T(phi) (plain-R dense
  # likelihood, the spec's prior functions in reported units), plus
  # log |det dT/dphi| by central differences over the free parameters,
  # minus the old fit's logPost
  tab <- new$spec$table
  free <- which(tab$family != FBC:::prior_families[["fixed"]])
  phis <- FBC:::sampler_draws(fit, rows)
  ref <- vapply(seq_along(rows), function(r) {
    phi <- phis[r, ]
    T <- function(v) {
      x <- phi
      x[free] <- v
      FBC:::warm_phi(x, fit$model, new)[free]
    }
    J <- vapply(seq_along(free), function(j) {
      h <- 1e-6 * max(1, abs(phi[free[j]]))
      e <- replace(numeric(length(free)), j, h)
      (T(phi[free] + e) - T(phi[free] - e)) / (2 * h)
    }, numeric(length(free)))
    out <- FBC:::warm_phi(phi, fit$model, new)
    reported <- out
    reported[1] <- new$scale$xmin[2] + (new$scale$xmax[2] - new$scale$xmin[2]) * out[1]
    lp <- sum(vapply(free, function(j) new$spec$fns[[j]](reported[j]), numeric(1)))
    ll <- dense_loglik(new$data$Xf, new$data$yf, new$data$Xs, new$data$ys, out, fbc_nugget,
                       "powexp", "powexp", discrepancy = "none")
    ll + lp + determinant(J)$modulus - fit$logPost[rows[r]]
  }, numeric(1))
  # equal up to one constant (the weights' normalisation)
  expect_lt(max(abs((lw - ref) - mean(lw - ref))), 1e-5)
  expect_gt(sd(ref), 0.1)
  expect_equal(attr(lw, "logLik") + attr(lw, "logPrior") - as.vector(lw),
               fit$logPost[rows] - FBC:::reweight_log_jacobian(phis, fit$model, new))
})

test_that("update(fit, sim =) reweights the old draws when they suffice (grid)", {
  # 8 runs more that move kappa's posterior by half its sd
  pb <- sinus_problem(m = 20)
  first <- pb
  first$sim <- pb$sim[1:12, ]
  fit <- sinus_fit(first)
  fit2 <- update(fit, sim = pb$sim[13:20, ])
  expect_gt(abs(mean(fit2$Phi[, 1]) - mean(fit$Phi[, 1])) / sd(fit2$Phi[, 1]), 0.5)
  rw <- fit2$settings$reweight
  expect_true(rw$used)
  expect_equal(rw$runs, 12)
  expect_equal(rw$draws, 2000)  # every draw (fbc_reweight_draws)
  expect_gte(rw$ess, 400)
  expect_true(fit2$settings$warmStart)
  # the model is calibrate()'s on all runs; the draws are its posterior
  all <- calibrate(pb$sim, pb$field, discrepancy = "none", hypers = sinus_hypers(), fit = FALSE)
  expect_identical(fit2$model$data, all$data)
  expect_equal(nrow(fit2$Phi), 2000)
  expect_kappa_grid(fit2, sinus_loglik(fit2$model$data))
  expect_equal(fit2$estimates["kappa1", "ess"], rw$ess)
  # the draws and their log densities are the new model's
  phi <- FBC:::sampler_draws(fit2, 1:3)
  expect_equal(fit2$logLik[1:3], apply(phi, 1, sinus_loglik(fit2$model$data)), tolerance = 1e-8)
  expect_output(print(fit2), "reweighted")
  # the chains go on from the reweighted draws
  fit3 <- update(fit2, nMCMC = 200)
  expect_equal(nrow(fit3$Phi), 2100)  # thinning 2
  expect_equal(fit3$Phi[1:2000, ], fit2$Phi)
  # without reweighting, a refit
  set.seed(5)
  fit4 <- update(fit, sim = pb$sim[13:20, ], reweight = FALSE)
  expect_null(fit4$settings$reweight)
  expect_gt(nrow(fit4$Phi), 400)
})

test_that("update(fit, sim =) continues reweighted draws short of the rule", {
  # one run more that moves kappa's posterior: the weights' Kish share
  # (0.13) leaves 178 of the rule's 400 effective draws, so the resampled
  # chains go on from their last draws (resample-move)
  pb <- sinus_problem(m = 13)
  first <- pb
  first$sim <- pb$sim[1:12, ]
  fit <- sinus_fit(first)
  fit2 <- update(fit, sim = pb$sim[13, ])
  rw <- fit2$settings$reweight
  expect_true(rw$used)
  expect_gte(rw$ess, 100)
  expect_lt(rw$ess, 400)
  expect_gt(rw$topUp, 0)
  # the resampled draws first, then the continuation's (thinning 2)
  expect_equal(nrow(fit2$Phi), rw$draws + rw$topUp / 2)
  expect_equal(fit2$settings$nMCMC, fit$settings$nMCMC + rw$topUp)
  expect_true(fit2$settings$converge$converged)
  expect_gte(min(fit2$estimates$ess, na.rm = TRUE), 400)
  expect_kappa_grid(fit2, sinus_loglik(fit2$model$data))
  expect_output(print(fit2), "then continued")
  # chains with many sweeps since their last refit (a loop's reweighted
  # steps add up): the rule's ceiling (maxMCMC, 50,000) counts from here
  # (it was an error), and the checks come every 500 sweeps, not when half
  # the chains' sweeps again have passed (25,650 sweeps here)
  old <- fit
  old$state$chains[[1]]$sampler$iter <- 49950L
  fit3 <- update(old, sim = pb$sim[13, ])
  expect_true(fit3$settings$converge$converged)
  expect_gt(fit3$settings$reweight$topUp, 0)
  expect_lte(fit3$settings$reweight$topUp, 5000)
})

test_that("update(fit, sim =) refits when the continuation's proposals are stale", {
  # four runs more leave the reweighted draws 219 of the rule's 400
  # effective draws, so the chains go on with the proposals adapted at the
  # last fit (500 sweeps suffice here). Made stale (every step 400 times
  # too long, as after several reweighted steps whose runs narrowed the
  # posterior), the continuation's first stretch accepts almost nothing and
  # the model is refitted with fresh proposals (such continuations ran to
  # the rule's 50,000-sweep ceiling before: bench/design.R
  # --problem=three)
  pb <- sinus_problem(m = 18)
  set.seed(3)
  fit <- suppressWarnings(calibrate(pb$sim[1:12, ], pb$field, discrepancy = "none", nChains = 2,
                                    showProgress = FALSE))
  stale <- stale_proposals(fit)
  set.seed(4)
  ok <- update(fit, sim = pb$sim[13:16, ])
  expect_true(ok$settings$reweight$used)
  expect_gt(ok$settings$reweight$topUp, 0)
  expect_lt(ok$settings$reweight$topUp, FBC:::fbc_topup_max)
  expect_length(ok$settings$reweight$stale, 0)
  set.seed(4)
  re <- update(stale, sim = pb$sim[13:16, ])
  rw <- re$settings$reweight
  expect_false(rw$used)
  expect_equal(rw$ess, ok$settings$reweight$ess)  # the same weights
  expect_equal(rw$topUp, FBC:::fbc_first_check)
  expect_true(all(c("kappa1", "sim") %in% rw$stale))
  expect_true(re$settings$converge$converged)
  # a refit: its own adaptive warm-up (fresh proposals) in every chain
  expect_length(re$settings$warmup, 2)
  expect_true(all(re$settings$warmup >= 200))
  expect_true(all(FBC:::move_report(re)$acceptance > 0.02))
  # the same posterior as the continued fit's (kappa's mean within 4 Monte
  # Carlo sds)
  mc <- sqrt(var(ok$Phi[, 1]) / ok$estimates["kappa1", "ess"] +
             var(re$Phi[, 1]) / re$estimates["kappa1", "ess"])
  expect_lt(abs(mean(re$Phi[, 1]) - mean(ok$Phi[, 1])), 4 * mc)
  expect_output(print(re), "refitted; the fit on 12 runs reweighted was tried, but their continuation's proposals were stale \\(kappa1")
  expect_output(print(ok), "reweighted by the new runs and resampled")
})

test_that("stale_moves() names the adapted moves accepting under a quarter of their target", {
  # the continuation's counts are after minus before; targets 0.44 (walks,
  # single sites, the scale move, a one-parameter block) and 0.234 (a block
  # of several): thresholds 0.11 and 0.0585; jumps and Gibbs moves are not
  # adapted
  moves <- function(acc, tries) {
    list(name = c("kappa1", "sim", "one", "sigma2E", "scale", "kappa1 jump", "muB"),
         kind = c("walk", "joint", "joint", "single", "scale", "jump", "gibbs"),
         params = c("kappa1", "thetaS1,thetaS2,sigma2S", "thetaB1", "sigma2E",
                    "sigma2S,sigma2E", "kappa1", "muB"),
         accepted = acc, tries = tries)
  }
  fit_with <- function(...) list(state = list(chains = lapply(list(...), function(m) list(sampler = list(moves = m)))))
  before <- fit_with(moves(rep(50, 7), rep(100, 7)), moves(rep(50, 7), rep(100, 7)))
  # pooled over two chains, 200 tries each: rates 0.10, 0.06, 0.10, 0.12,
  # 0.50, 0.01, 1
  gained <- c(20, 12, 20, 24, 100, 2, 200)
  after <- fit_with(moves(50 + gained / 2, rep(200, 7)), moves(50 + gained / 2, rep(200, 7)))
  expect_identical(FBC:::stale_moves(before, after), c("kappa1", "one"))
  # the block at 0.05 is under its 0.0585
  gained[2] <- 10
  after <- fit_with(moves(50 + gained / 2, rep(200, 7)), moves(50 + gained / 2, rep(200, 7)))
  expect_identical(FBC:::stale_moves(before, after), c("kappa1", "sim", "one"))
  # no tries in the stretch: not stale
  expect_identical(FBC:::stale_moves(before, before), character())
})

test_that("update(fit, sim =) refits when the reweighted draws fall short", {
  # from 6 runs to 40 kappa's posterior moves 10 sds: the old draws cannot
  # carry it
  pb <- sinus_problem(m = 40)
  first <- pb
  first$sim <- pb$sim[1:6, ]
  fit <- suppressWarnings(sinus_fit(first))  # (6 runs do not span the field's x)
  # (a stricter rule than the default for the grid check's sake)
  fit2 <- update(fit, sim = pb$sim[7:40, ], converge = until_converged(ess = 1500))
  rw <- fit2$settings$reweight
  expect_false(rw$used)
  expect_lt(rw$ess, 1500 / 4)  # below a quarter of the rule's: no continuation
  expect_output(print(fit2), sprintf("refitted; the fit on 6 runs reweighted was tried, but they held %.0f of the rule's effective draws", rw$ess))
  expect_true(fit2$settings$warmStart)
  expect_true(fit2$settings$warmup >= 200)
  # (kappa's sd is 0.01 of its range: a grid finer than the default's)
  expect_kappa_grid(fit2, sinus_loglik(fit2$model$data), u = seq(0.5, 0.75, length.out = 501))
})

test_that("update(fit, sim =) checks the new runs", {
  pb <- sinus_problem()
  fit <- sinus_fit(pb, nMCMC = 400)
  expect_snapshot(error = TRUE, update(fit, sim = pb$sim[, c("y", "x")]))
  expect_snapshot(error = TRUE, update(fit, sim = "runs"))
})

test_that("runs added by update_runs() are never taken for an output in wide format", {
  pb <- sinus_problem()
  fit <- short_fit(pb)
  # 30 runs on the diagonal x = u: given to calibrate() with the others,
  # x looks set by u (61% of its variation), as a second output would be
  v <- seq(0.05, 0.95, length.out = 30)
  more <- data.frame(y = sin(10 * v * v), x = v, u = v)
  expect_warning(FBC:::warn_wide_outputs(as.matrix(rbind(pb$sim, more)), 1),
                 class = "fbc_wide_outputs")
  # the fit's columns were judged when it was made: adding runs keeps them
  expect_no_warning(up <- update_runs(fit, more, nMCMC = 300, nBurn = 100, converge = FALSE))
  expect_identical(nrow(up$model$options$args$sim), 42L)
})

test_that("the reweighting's weights for a noisy simulator are the new posterior over the old (plain-R, every run)", {
  # eta = 5 exp(-t x) with noise sd 0.2 on 4 x 3 inputs, 3 replicates each;
  # the new runs are 3 more replicates of the inputs at x = 0, which move
  # the responses' mean and sd (every variance's map, sigma2R's included)
  set.seed(1)
  U <- expand.grid(x = seq(0, 3, length.out = 4), t = seq(0.5, 3, length.out = 3))
  X <- U[rep(seq_len(12), 6), ]
  sim <- unname(cbind(y = 5 * exp(-X$t * X$x) + stats::rnorm(72, 0, 0.2), x = X$x, t = X$t))
  colnames(sim) <- c("y", "x", "t")
  xf <- seq(0.1, 2.9, length.out = 4)
  field <- cbind(y = 5 * exp(-1.7 * xf) + stats::rnorm(4, 0, 0.05), x = xf)
  first <- sim[1:36, ]
  more <- sim[37:72, ][sim[37:72, "x"] == 0, ]
  all <- rbind(first, more)
  set.seed(2)
  fit <- calibrate(first, field, discrepancy = "none", nMCMC = 400, nBurn = 200, nChains = 2,
                   showProgress = FALSE)
  new <- calibrate(all, field, discrepancy = "none", fit = FALSE)
  expect_identical(new$design$simNoise$mode, fit$model$design$simNoise$mode)
  expect_gt(abs(log(new$scale$ysd / fit$model$scale$ysd)), 0.05)
  rows <- round(seq(3, nrow(fit$Phi), length.out = 5))
  lw <- FBC:::reweight_log_weights(fit, new, rows)
  # the reference: the new model's log posterior at T(phi) with the
  # likelihood of every run (each run of unique input i: the emulator's
  # eta_i plus its own noise sigma2R; plain R, dense), plus log |det dT/dphi|
  # by central differences, minus the old fit's logPost
  d <- new$data
  cls <- new$spec$classes
  iR <- which(cls == "sigma2R")
  tab <- new$spec$table
  free <- which(tab$family != FBC:::prior_families[["fixed"]])
  reps <- FBC:::sim_replicates(all)
  ys <- (all[, 1] - new$scale$ymean) / new$scale$ysd
  n <- nrow(d$Xf)
  m <- nrow(d$Xs)
  E <- rbind(cbind(diag(n), matrix(0, n, m)),
             cbind(matrix(0, length(ys), n), diag(m)[reps$group, , drop = FALSE]))
  phis <- FBC:::sampler_draws(fit, rows)
  ref <- vapply(seq_along(rows), function(r) {
    phi <- phis[r, ]
    T <- function(v) {
      x <- phi
      x[free] <- v
      FBC:::warm_phi(x, fit$model, new)[free]
    }
    J <- vapply(seq_along(free), function(j) {
      h <- 1e-6 * max(1, abs(phi[free[j]]))
      e <- replace(numeric(length(free)), j, h)
      (T(phi[free] + e) - T(phi[free] - e)) / (2 * h)
    }, numeric(length(free)))
    out <- FBC:::warm_phi(phi, fit$model, new)
    Cu <- dense_cov(d$Xf, d$Xs, out[-iR], FBC:::fbc_nugget, "matern52", "matern52", "none")
    C <- E %*% Cu %*% t(E) + diag(c(rep(0, n), rep(out[iR], length(ys))))
    L <- chol(C)
    a <- backsolve(L, c(d$yf, ys), transpose = TRUE)
    ll <- -0.5 * (length(a) * log(2 * pi) + 2 * sum(log(diag(L))) + sum(a^2))
    lp <- sum(vapply(free, function(j) FBC:::log_prior_row(tab, j, out[j]), numeric(1)))
    ll + lp + determinant(J)$modulus - fit$logPost[rows[r]]
  }, numeric(1))
  expect_lt(max(abs((lw - ref) - mean(lw - ref))), 1e-5)
  expect_gt(sd(ref), 0.1)
  # the map carries sigma2R to the new response's units
  expect_equal(attr(lw, "phi")[, iR], phis[, iR] * (fit$model$scale$ysd / new$scale$ysd)^2)
})
