# Choosing new runs (R/propose_runs.R): the look-ahead criterion against
# plain-R references, batches, the plug-in and the joint criterion.

test_that("the look-ahead weights give the posterior of a refit with the fantasised run", {
  pb <- sinus_problem()
  fit <- sinus_fit(pb, nMCMC = 6200)
  d <- fit$model$data
  sc <- fit$model$scale
  # a run at x = 0.48, u = 0.58 returning the simulator's value there
  run <- c(x = 0.48, u = 0.58)
  ystar <- sin(10 * run[["u"]] * run[["x"]])
  cs <- FBC:::scale_inputs(matrix(run, 1), sc, 1:2)
  ys <- (ystar - sc$ymean) / sc$ysd
  phis <- FBC:::sampler_draws(fit)
  sys <- FBC:::.design_systems(d$Xf, d$yf, d$Xs, d$ys, phis, cs, matrix(0, 0, 1), fbc_nugget,
                                fit$model$spec$model)
  w <- stats::dnorm(ys, drop(sys$mu), sqrt(drop(sys$v)))
  w <- w / sum(w)
  k <- fit$Phi[, "kappa1"]
  m1 <- sum(w * k)
  s1 <- sqrt(sum(w * (k - m1)^2))
  # brute force: the grid posterior with the run added (plain-R dense
  # likelihood, the same scaling), Beta(1.1, 1.1) prior
  u <- seq(0, 1, length.out = 401)
  phi <- fit$state$chains[[1]]$last
  lp <- vapply(u, function(a) {
    phi[1] <- a
    dense_loglik(d$Xf, d$yf, rbind(d$Xs, cs), c(d$ys, ys), phi, fbc_nugget, "matern52",
                 "matern52", discrepancy = "none")
  }, numeric(1)) + stats::dbeta(u, 1.1, 1.1, log = TRUE)
  g <- exp(lp - max(lp))
  g <- g / sum(g)
  kg <- sc$xmin[2] + (sc$xmax[2] - sc$xmin[2]) * u
  mg <- sum(g * kg)
  sg <- sqrt(sum(g * (kg - mg)^2))
  # the run moves the posterior (by 1.5 of its new sd, and shrinks it to
  # 0.4 of the old: else the check would be empty) ...
  expect_gt(abs(mg - mean(k)) / sg, 1)
  expect_lt(sg / sd(k), 0.6)
  # ... and the reweighted draws follow it within Monte Carlo error
  # (effective sample size 1 / sum(w^2) ~ 1500 of 3000 draws: errors
  # ~ 0.03 sd; 0.02 measured on writing this)
  expect_gt(1 / sum(w^2), 500)
  expect_lt(abs(m1 - mg) / sg, 0.1)
  expect_lt(abs(s1 / sg - 1), 0.1)
})

test_that("the look-ahead's particles are distinct draws weighted by their repeats", {
  pb <- sinus_problem()
  fit <- short_fit(pb, nChains = 2, seed = 3)
  # the reference: runs of equal consecutive draws within a chain (an MCMC
  # sweep that moved nothing repeats a draw)
  runs <- rle(paste(fit$chain, apply(fit$Phi, 1, paste, collapse = " ")))$lengths
  parts <- FBC:::design_particles(fit, 1000, "joint")
  expect_equal(nrow(parts$phi), length(runs))
  expect_equal(exp(parts$lw0), runs)
  # fewer particles than draws: evenly spaced ones
  expect_equal(nrow(FBC:::design_particles(fit, 50, "joint")$phi), 50)
  # each draw three times in a row, as a reweighted fit's resampled draws
  # repeat (update_runs()): the same particles, each of three times the weight
  rep3 <- fit
  rep3$Phi <- fit$Phi[rep(seq_len(nrow(fit$Phi)), each = 3), ]
  rep3$chain <- rep(fit$chain, each = 3)
  parts3 <- FBC:::design_particles(rep3, 1000, "joint")
  expect_identical(parts3$phi, parts$phi)
  expect_equal(parts3$lw0, parts$lw0 + log(3))
  # a draw at the end of chain 1 repeated at the start of chain 2 is two
  last <- max(which(fit$chain == 1))
  rep1 <- fit
  rep1$Phi[last + 1, ] <- fit$Phi[last, ]
  expect_equal(nrow(FBC:::design_particles(rep1, 1000, "joint")$phi),
               length(rle(paste(rep1$chain, apply(rep1$Phi, 1, paste, collapse = " ")))$lengths))
  expect_equal(sum(exp(FBC:::design_particles(rep1, 1000, "joint")$lw0)), nrow(fit$Phi))
})

test_that("proposed runs lie in the design's ranges and away from the runs", {
  pb <- sinus_problem()
  fit <- sinus_fit(pb, nMCMC = 1200)
  set.seed(5)
  pr <- propose_runs(fit, n = 3, ndraws = 60, nfantasy = 30, ncandidates = 200)
  expect_named(pr, c("x", "u", "gain"))
  expect_equal(nrow(pr), 3)
  # (the runs' ranges, x's widened to the field's inputs: here within them)
  rng <- apply(pb$sim[, c("x", "u")], 2, range)
  expect_true(min(pb$sim$x) < 0.1 && max(pb$sim$x) > 0.9)
  for (v in c("x", "u")) {
    expect_true(all(pr[[v]] >= rng[1, v] & pr[[v]] <= rng[2, v]))
  }
  U <- FBC:::scale_inputs(as.matrix(pr[c("x", "u")]), fit$model$scale, 1:2)
  dist <- apply(U, 1, function(u) min(sqrt(colSums((t(fit$model$data$Xs) - u)^2))))
  expect_true(all(dist > 1e-3))
  expect_true(all(pr$gain > 0))
  # the existing runs as candidates are left out
  cand <- rbind(pb$sim[, c("x", "u")], data.frame(x = c(0.3, 0.6), u = c(0.6, 0.65)))
  pr2 <- propose_runs(fit, n = 2, candidates = cand, ndraws = 60, nfantasy = 30)
  expect_equal(sort(pr2$x), c(0.3, 0.6))
  # a look-ahead over 5e7 numbers is refused, naming the sizes: 60 draws x
  # 17 rows (12 runs and the field's 5 inputs; its 10 rows are replicates,
  # which enter through their means) x 50,000 candidates; 40,000 pass
  expect_equal(nrow(fit$model$data$Xs), 12)
  expect_equal(sum(!duplicated(fit$model$data$Xf)), 5)
  set.seed(7)  # (the candidates within 1e-3 of a run are left out first)
  big <- data.frame(x = stats::runif(50000), u = stats::runif(50000))
  expect_snapshot(error = TRUE, propose_runs(fit, candidates = big, ndraws = 60))
  ok <- data.frame(x = stats::runif(40000), u = stats::runif(40000))
  expect_silent(asNamespace("FBC")$check_look_ahead_size(60, fit$model,
                                                          as.matrix(ok), matrix(0, 0, 1)))
})

test_that("the default candidates: half at kappa's posterior draws and the field's inputs, half uniform", {
  pb <- sinus_problem()
  fit <- sinus_fit(pb, nMCMC = 1200)
  kap <- FBC:::sampler_draws(fit)[, 1, drop = FALSE]
  held <- pmin(pmax(kap[, 1], 0), 1)
  set.seed(2)
  U <- FBC:::design_candidates(NULL, fit$model$scale, 400, fit$model$data$Xs, 0, kappa = kap)
  expect_equal(dim(U), c(400, 2))
  expect_true(all(U >= 0 & U <= 1))
  # the first half's kappa are draws (held to the design's range), spread as
  # the draws are; the rest, and the experimental input, uniform (KS tests,
  # fixed seed)
  expect_true(all(U[1:200, 2] %in% held))
  expect_gt(suppressWarnings(stats::ks.test(U[1:200, 2], held))$p.value, 0.01)
  expect_gt(stats::ks.test(U[201:400, 2], "punif")$p.value, 0.01)
  expect_gt(stats::ks.test(U[, 1], "punif")$p.value, 0.01)
  # the draws are narrower than the range: the uniform half is not like them
  expect_lt(diff(stats::quantile(kap, c(0.05, 0.95))), 0.5)
  expect_lt(suppressWarnings(stats::ks.test(U[201:400, 2], held))$p.value, 1e-6)
  # propose_runs()'s default candidates are these (the same seed, the same picks)
  set.seed(9)
  U <- FBC:::design_candidates(NULL, fit$model$scale, 200, fit$model$data$Xs, 1e-3, kappa = kap, Xf = fit$model$data$Xf)
  given <- stats::setNames(as.data.frame(FBC:::unscale_inputs(U, fit$model$scale, 1:2)), c("x", "u"))
  p2 <- propose_runs(fit, n = 2, candidates = given, ndraws = 60, nfantasy = 30)
  set.seed(9)
  p1 <- propose_runs(fit, n = 2, ndraws = 60, nfantasy = 30, ncandidates = 200)
  attr(p2, "time") <- attr(p1, "time")
  expect_equal(p1, p2, tolerance = 1e-12)
  # runs in x of 0.3-0.7, the field's inputs 0.1-0.9: the default candidates'
  # x reach the field's, their kappa stay in the runs' range
  narrow <- pb
  narrow$sim$x <- 0.3 + 0.4 * pb$sim$x
  narrow$sim$y <- sin(10 * narrow$sim$u * narrow$sim$x)
  fitN <- suppressWarnings(sinus_fit(narrow, nMCMC = 600))
  set.seed(3)
  U <- FBC:::design_candidates(NULL, fitN$model$scale, 400, fitN$model$data$Xs, 0,
                               kappa = FBC:::sampler_draws(fitN)[, 1, drop = FALSE], Xf = fitN$model$data$Xf)
  X <- FBC:::unscale_inputs(U, fitN$model$scale, 1:2)
  expect_true(all(X[, 1] >= 0.1 - 1e-12 & X[, 1] <= 0.9 + 1e-12))
  # the first half at the field's inputs, the rest uniform over 0.1-0.9
  expect_equal(sort(unique(round(X[1:200, 1], 12))), seq(0.1, 0.9, length.out = 5))
  expect_gt(stats::ks.test((X[201:400, 1] - 0.1) / 0.8, "punif")$p.value, 0.01)
  expect_lt(min(X[201:400, 1]), 0.12)
  expect_gt(max(X[201:400, 1]), 0.88)
  expect_true(all(X[, 2] >= min(narrow$sim$u) - 1e-12 & X[, 2] <= max(narrow$sim$u) + 1e-12))
  set.seed(4)
  prN <- propose_runs(fitN, n = 3, ndraws = 40, nfantasy = 20, ncandidates = 200)
  expect_true(all(prN$x >= 0.1 - 1e-12 & prN$x <= 0.9 + 1e-12))
})

test_that("a batch conditions on its pending points; single picks repeat", {
  pb <- sinus_problem()
  fit <- sinus_fit(pb, nMCMC = 1200)
  cand <- data.frame(x = c(0.45, 0.45, 0.8, 0.2, 0.6), u = c(0.6, 0.6, 0.62, 0.64, 0.3))
  one <- function() {
    set.seed(9)
    propose_runs(fit, n = 1, candidates = cand, ndraws = 80, nfantasy = 40)
  }
  a <- one()
  b <- one()
  # nothing changed between two single picks: the same point twice
  expect_identical(a[c("x", "u")], b[c("x", "u")])
  set.seed(9)
  two <- propose_runs(fit, n = 2, candidates = cand, ndraws = 80, nfantasy = 40)
  expect_equal(two[1, c("x", "u")], a[1, c("x", "u")])
  # the second point is not the first again: re-running the same input of
  # a deterministic simulator is worth nothing once it is pending
  expect_false(isTRUE(all.equal(unlist(two[2, c("x", "u")]), unlist(two[1, c("x", "u")]))))
  # a candidate at a pending point (row 2 is row 1 again), given that
  # point, has no variance left in any draw: it can gain nothing
  U <- FBC:::scale_inputs(as.matrix(cand), fit$model$scale, 1:2)
  parts <- FBC:::design_particles(fit, 80, "joint")
  # (the plain-R reference, helper-design.R, which the C++ equals: below)
  sys <- lapply(seq_len(nrow(parts$phi)), function(s) draw_system(parts$phi[s, ], fit$model, U))
  cond <- pending_conditionals(sys, U, 1L, matrix(stats::rnorm(40), 40, 1))
  v2 <- vapply(sys, function(y) y$v[2], numeric(1))
  expect_lt(max(cond$cv[, 2] / v2), 1e-3)
  expect_gt(min(cond$cv[, 3:5] / t(vapply(sys, function(y) y$v[3:5], numeric(3)))), 1e-3)
})

test_that("a look-ahead's first step alone is its batch's first step, and resumes to the batch", {
  pb <- sinus_problem()
  fit <- short_fit(pb)
  U <- matrix(stats::runif(60), 30, 2)
  for (method in c("joint", "plugin")) {
    parts <- FBC:::design_particles(fit, 40, method)
    set.seed(13)
    random <- FBC:::look_ahead_random(3, 25)
    batch <- FBC:::look_ahead(parts, U, fit$model, 3, 25, entropy = method == "plugin",
                              random = random)
    one <- FBC:::look_ahead(parts, U, fit$model, 1, 25, entropy = method == "plugin",
                            random = FBC:::first_random(random, 1L))
    expect_identical(one$chosen, batch$chosen[1])
    expect_identical(one$gain, batch$gain[1])
    expect_identical(one$variance, batch$variance)
    expect_identical(one$scores[, 1], batch$scores[, 1])
    # the batch begun with one step and resumed: the batch's results
    begun <- FBC:::look_ahead(parts, U, fit$model, 3, 25, entropy = method == "plugin",
                              random = random, steps = 1L)
    expect_identical(begun$chosen, batch$chosen[1])
    expect_identical(begun$scores, batch$scores[, 1, drop = FALSE])
    expect_identical(FBC:::look_ahead_resume(begun), batch)
    expect_error(FBC:::look_ahead_resume(begun), "already finished")
    # the random numbers drawn inside are the same as given
    set.seed(13)
    expect_identical(FBC:::look_ahead(parts, U, fit$model, 3, 25, entropy = method == "plugin"), batch)
  }
})

test_that("look_ahead()'s order gives the gains of given points in that order", {
  pb <- sinus_problem()
  fit <- short_fit(pb)
  U <- matrix(stats::runif(60), 30, 2)
  parts <- FBC:::design_particles(fit, 40, "joint")
  set.seed(11)
  greedy <- FBC:::look_ahead(parts, U, fit$model, 2, 25)
  # the greedy's first pick, then another candidate: with the same random
  # numbers step 1 is the greedy's, and step 2 that candidate's score given
  # the first (the greedy's scores at step 2)
  other <- setdiff(order(greedy$scores[, 2], decreasing = TRUE), greedy$chosen)[3]
  set.seed(11)
  fixed <- FBC:::look_ahead(parts, U, fit$model, 2, 25, order = c(greedy$chosen[1], other))
  expect_identical(fixed$chosen, c(greedy$chosen[1], as.integer(other)))
  expect_identical(fixed$gain[1], greedy$gain[1])
  expect_identical(fixed$gain[2], greedy$scores[other, 2])
  expect_lt(fixed$gain[2], greedy$gain[2])
  expect_error(FBC:::look_ahead(parts, U, fit$model, 2, 25, order = c(1, 1)), "repeat")
  expect_error(FBC:::look_ahead(parts, U, fit$model, 2, 25, order = c(1, 31)), "index")
})

test_that("a gain estimated below 0 is reported as 0, the estimate kept", {
  pb <- sinus_problem()
  fit <- short_fit(pb, nChains = 2)
  # the fourth of six plug-in picks is worth about nothing by the joint
  # look-ahead: its Monte Carlo estimate falls below 0
  set.seed(1)
  cand <- data.frame(x = stats::runif(60), u = stats::runif(60))
  pr <- suppressMessages(propose_runs(fit, n = 6, candidates = cand, method = "plugin",
                                      ndraws = 40, nfantasy = 30))
  est <- attr(pr, "gainEstimate")
  expect_true(any(est < 0))
  expect_gt(min(est), -0.05)
  expect_true(all(pr$gain >= 0))
  expect_identical(pr$gain, pmax(est, 0))
})

test_that("propose_runs(method = \"plugin\") reports the joint look-ahead's gains at its picks", {
  pb <- sinus_problem()
  fit <- short_fit(pb, nChains = 2)
  cand <- data.frame(x = stats::runif(60), u = stats::runif(60))
  set.seed(12)
  pr <- propose_runs(fit, n = 3, candidates = cand, method = "plugin", ndraws = 40, nfantasy = 30)
  # the same steps by hand, the same random numbers: the plug-in's greedy
  # picks, then the joint particles' gains at them in that order
  sc <- fit$model$scale
  U <- FBC:::scale_inputs(as.matrix(cand), sc, 1:2)
  set.seed(12)
  plug <- FBC:::look_ahead(FBC:::design_particles(fit, 40, "plugin"), U, fit$model, 3, 30,
                           entropy = TRUE)
  joint <- FBC:::look_ahead(FBC:::design_particles(fit, 40, "joint"), U[plug$chosen, ], fit$model,
                            3, 30, order = 1:3)
  expect_equal(as.matrix(pr[c("x", "u")]), as.matrix(cand[plug$chosen, ]), ignore_attr = TRUE)
  expect_identical(attr(pr, "gainEstimate"), joint$gain / joint$variance)
  expect_identical(pr$gain, pmax(joint$gain / joint$variance, 0))
  # (its own gains: the entropy's expected reductions as the variance
  # fraction they mean for a normal posterior)
  expect_identical(attr(pr, "pluginGain"), -expm1(-2 * plug$gain))
  expect_identical(attr(pr, "variance"), joint$variance)
  expect_identical(attr(pr, "method"), "plugin")
  # the plug-in is the default
  set.seed(12)
  def <- propose_runs(fit, n = 3, candidates = cand, ndraws = 40, nfantasy = 30)
  attr(def, "time") <- attr(pr, "time")  # CPU time, measured
  expect_identical(def, pr)
  # the joint criterion's own picks carry no plug-in gains
  pj <- propose_runs(fit, n = 1, candidates = cand, ndraws = 40, method = "joint")
  expect_null(attr(pj, "pluginGain"))
  expect_identical(attr(pj, "method"), "joint")
})

test_that("the plug-in's kappa values of no weight are left out, the criterion unchanged", {
  pb <- sinus_problem(m = 20)
  fit <- short_fit(pb, nChains = 2)
  all <- FBC:::design_particles(fit, 100, "plugin", prune = FALSE)
  pruned <- FBC:::design_particles(fit, 100, "plugin")
  expect_identical(pruned$phi, all$phi)
  # the weights (likelihood x prior at the MAP hyperparameters) of the
  # full grid, the likelihood from the plain-R dense one (helper-dense.R):
  # the look-ahead scores those within 1e10 of the largest
  d <- fit$model$data
  ll <- apply(all$phi, 1, function(phi) {
    dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, fbc_nugget, "matern52", "matern52",
                 discrepancy = "none")
  })
  lw <- all$lw0 + ll
  U <- matrix(stats::runif(200), 100, 2)
  set.seed(3)
  a <- FBC:::look_ahead(all, U, fit$model, 3, 30)
  set.seed(3)
  b <- FBC:::look_ahead(pruned, U, fit$model, 3, 30)
  expect_identical(a$kept, 1:100)
  expect_identical(b$kept, which(lw >= max(lw) - log(1e10)))
  expect_lt(length(b$kept), 60)  # measured: 38 of 100 at 20 runs
  # the same picks and gains (the left-out weights are < 1e-8 in all)
  expect_identical(a$chosen, b$chosen)
  expect_equal(a$gain, b$gain, tolerance = 1e-8)
  expect_equal(a$variance, b$variance, tolerance = 1e-8)
  expect_equal(a$scores, b$scores, tolerance = 1e-8)
})

test_that("where the plug-in and the joint look-ahead disagree about its pick, the joint criterion picks", {
  pb <- sinus_problem()
  fit <- short_fit(pb, nChains = 2)
  set.seed(5)
  U <- matrix(stats::runif(120), 60, 2)
  noTarget <- matrix(0, 0, 1)
  joint <- FBC:::design_particles(fit, 40, "joint")
  # a plug-in whose kappa is wrong (the draws' shifted by 0.6 of the
  # range, wrapped: about 0.11-0.29 where the posterior is 0.51-0.69) picks
  # runs at its kappa (by its entropy, as the plug-in does), which the joint
  # look-ahead finds worth under 1% (measured: 0.9% and 1.5%) where the
  # joint criterion's first pick is worth 35%
  wrong <- joint
  wrong$kappa <- (joint$kappa + 0.6) %% 1
  wrong$phi[, 1] <- wrong$kappa
  set.seed(12)
  pk <- FBC:::pick_runs(wrong, joint, U, fit$model, 2, 30, noTarget)
  after <- stats::runif(1)
  # the same steps by hand, the same random numbers (pick_runs() runs the
  # plug-in's first step alone, and no more of it once the joint criterion
  # takes over, but draws its random numbers as these do)
  set.seed(12)
  mine <- FBC:::look_ahead(wrong, U, fit$model, 2, 30, entropy = TRUE)
  honest <- FBC:::look_ahead(joint, U[mine$chosen, ], fit$model, 2, 30, order = 1:2)
  alt <- FBC:::look_ahead(joint, U, fit$model, 2, 30)
  expect_identical(stats::runif(1), after)
  expect_true(all(U[mine$chosen, 2] < 0.3))
  # the two disagree: the plug-in expects its first pick to be worth more
  # than 1% (of the variance, as its entropy's reduction means), the joint
  # look-ahead less
  expect_gt(-expm1(-2 * mine$gain[1]), 0.01)
  expect_lt(honest$gain[1] / honest$variance, 0.01)
  expect_gt(alt$gain[1] / alt$variance, 0.1)
  expect_identical(pk$method, "joint")
  expect_identical(pk$chosen, alt$chosen)
  expect_identical(pk$gain, alt$gain)
  expect_null(pk$own)
  # where the joint criterion's best is worth under the limit too (its
  # 35% under a limit of 50%; the plug-in's pick 83% by its own, 0.9% by
  # the joint look-ahead), the plug-in's picks stand: the same numbers and
  # random stream as the steps by hand above
  set.seed(12)
  pk <- FBC:::pick_runs(wrong, joint, U, fit$model, 2, 30, noTarget, limit = 0.5)
  expect_identical(stats::runif(1), after)
  expect_lt(alt$gain[1] / alt$variance, 0.5)
  expect_gte(-expm1(-2 * mine$gain[1]), 0.5)
  honest$chosen <- mine$chosen
  expect_identical(pk, c(honest, method = "plugin", list(own = -expm1(-2 * mine$gain))))
  # the fit's own plug-in picks are worth something: they stand
  set.seed(12)
  pk <- FBC:::pick_runs(FBC:::design_particles(fit, 40, "plugin"), joint, U, fit$model, 2, 30,
                        noTarget)
  expect_identical(pk$method, "plugin")
  expect_gt(pk$gain[1] / pk$variance, 0.01)
  expect_length(pk$own, 2)
})

test_that("the C++ look-ahead equals the plain-R one (helper-design.R)", {
  pb <- sinus_problem()
  # with the bias GP (KOH), the S-GaSP and without, joint and plug-in
  # particles
  for (disc in c("none", "gp", "sgasp")) {
    fit <- short_fit(pb, discrepancy = disc)
    U <- matrix(stats::runif(60), 30, 2)
    for (method in c("joint", "plugin")) {
      parts <- FBC:::design_particles(fit, 40, method)
      set.seed(11)
      cpp <- FBC:::look_ahead(parts, U, fit$model, 3, 25)
      set.seed(11)
      sys <- lapply(seq_len(nrow(parts$phi)), function(s) draw_system(parts$phi[s, ], fit$model, U))
      ref <- look_ahead_r(sys, parts, U, fit$model, 3, 25)
      expect_identical(cpp$chosen, as.integer(ref$chosen))
      expect_equal(cpp$variance, ref$variance, tolerance = 1e-8)
      expect_equal(cpp$gain, ref$gain, tolerance = 1e-8)
      # every candidate's gain at every step (the picks' -Inf included)
      expect_equal(cpp$scores, ref$scores, tolerance = 1e-8)
      expect_gt(max(cpp$scores[, 1]), 0)
      if (method == "plugin") {
        # the plug-in's criterion for kappa (propose_runs()'s picks): the
        # entropy of its kappa values' weights
        set.seed(11)
        cpp <- FBC:::look_ahead(parts, U, fit$model, 3, 25, entropy = TRUE)
        set.seed(11)
        ref <- look_ahead_r(sys, parts, U, fit$model, 3, 25, entropy = TRUE)
        expect_identical(cpp$chosen, as.integer(ref$chosen))
        expect_equal(cpp$variance, ref$variance, tolerance = 1e-8)
        expect_equal(cpp$gain, ref$gain, tolerance = 1e-8)
        expect_equal(cpp$scores, ref$scores, tolerance = 1e-8)
        expect_gt(max(cpp$scores[, 1]), 0)
      }
      # a prediction target (two field inputs): the calibrated prediction's
      # integrated variance, the draws reweighted and each draw's
      # predictive mean and variance moved by the fantasised run
      XT <- matrix(c(0.2, 0.7), 2, 1)
      set.seed(11)
      cpp <- FBC:::look_ahead(parts, U, fit$model, 3, 25, XT)
      set.seed(11)
      sys <- lapply(seq_len(nrow(parts$phi)), function(s) draw_system(parts$phi[s, ], fit$model, U, XT))
      ref <- look_ahead_r(sys, parts, U, fit$model, 3, 25)
      expect_identical(cpp$chosen, as.integer(ref$chosen))
      expect_equal(cpp$variance, ref$variance, tolerance = 1e-8)
      expect_equal(cpp$scores, ref$scores, tolerance = 1e-8)
      expect_gt(max(cpp$scores[, 1]), 0)
      # each draw's system (the C++ one by blocks, the simulator rows'
      # shared by the plug-in's particles, the field's 10 rows reduced to
      # their 5 inputs' means): the log-likelihood of every row (with its
      # constant), the candidates' means and variances
      d <- fit$model$data
      ds <- FBC:::.design_systems(d$Xf, d$yf, d$Xs, d$ys, parts$phi, U, XT, fbc_nugget,
                                  fit$model$spec$model)
      N <- nrow(d$Xs) + nrow(d$Xf)
      expect_equal(drop(ds$ll), vapply(sys, `[[`, 1, "ll") - N / 2 * log(2 * pi), tolerance = 1e-10)
      expect_equal(ds$mu, vapply(sys, `[[`, numeric(30), "mu"), tolerance = 1e-8)
      expect_equal(ds$v, vapply(sys, `[[`, numeric(30), "v"), tolerance = 1e-8)
      expect_equal(ds$mT, vapply(sys, `[[`, numeric(2), "mT"), tolerance = 1e-8)
      expect_equal(ds$VT, vapply(sys, `[[`, numeric(2), "VT"), tolerance = 1e-8)
    }
    # each draw's target mean and variance are predict(type = "mean")'s
    # (its compiled per-draw conditional, src/predict.cpp)
    phis <- FBC:::sampler_draws(fit, 1:5)
    pr <- FBC:::at_draws(fit, FBC:::.fbc_predict, phis, Xnew = XT,
                         type = FBC:::predict_type_codes[["mean"]], block = 500L,
                         noise = integer(), source = integer())
    d <- fit$model$data
    ds <- FBC:::.design_systems(d$Xf, d$yf, d$Xs, d$ys, phis, U, XT, fbc_nugget, fit$model$spec$model)
    expect_equal(ds$mT, pr$mean, tolerance = 1e-8)
    expect_equal(ds$VT, pr$var, tolerance = 1e-8)
  }
})

test_that("the plug-in's entropy gain is the mutual information of kappa and the run (quadrature)", {
  # The expected reduction of kappa's entropy on the plug-in's kappa grid
  # by a run at a candidate is the mutual information of kappa and the
  # run's value y: I = H(y) - sum_k p_k log(2 pi e v_k) / 2, y given grid
  # point k N(mu_k, v_k), p_k the grid's weights. H(y), the entropy of that
  # mixture of normals, by quadrature (integrate()); the look-ahead's by
  # its fantasies (stratified): within their Monte Carlo error.
  pb <- sinus_problem()
  fit <- short_fit(pb)
  parts <- FBC:::design_particles(fit, 50, "plugin", prune = FALSE)
  U <- matrix(c(0.3, 0.55, 0.8, 0.6, 0.6, 0.2), 3, 2)  # (x, u) scaled
  d <- fit$model$data
  ds <- FBC:::.design_systems(d$Xf, d$yf, d$Xs, d$ys, parts$phi, U, matrix(0, 0, 1), fbc_nugget,
                              fit$model$spec$model)
  lw <- parts$lw0 + drop(ds$ll)
  p <- exp(lw - max(lw))
  p <- p / sum(p)
  mi <- vapply(1:3, function(c) {
    mu <- ds$mu[c, ]
    sdv <- sqrt(ds$v[c, ])
    f <- function(y) colSums(p * stats::dnorm(matrix(y, length(p), length(y), byrow = TRUE), mu, sdv))
    hy <- stats::integrate(function(y) { fy <- f(y); ifelse(fy > 0, -fy * log(fy), 0) },
                           min(mu - 8 * sdv), max(mu + 8 * sdv), subdivisions = 2000L,
                           rel.tol = 1e-10)$value
    hy - sum(p * log(2 * pi * exp(1) * sdv^2)) / 2
  }, numeric(1))
  set.seed(2)
  la <- FBC:::look_ahead(parts, U, fit$model, 1, 4000, entropy = TRUE)
  # (the three differ: a run where the grid's predictions part says more)
  expect_gt(diff(range(mi)), 0.2)
  # (measured: I = 0.200, 0.567, 0.0025; over seeds 1-5 each candidate's
  # estimate within 0.1-2.1% of it, all.equal()'s mean relative
  # difference 0.6-1.1%; 0.6% with this seed)
  expect_equal(drop(la$scores), mi, tolerance = 0.03)
  # the entropy before: -sum p log p over the grid
  expect_equal(la$variance, -sum(ifelse(p > 0, p * log(p), 0)), tolerance = 1e-10)
})

test_that("field data sets with noise variances of their own: the look-ahead is the dense plain-R one", {
  pb <- sinus_problem()
  # the sinusoid's 5 field inputs measured by two data sets, b 3x noisier
  # than a, and one more row of each: b's at 0.1 (a replicate within b and
  # an input a has too, a group of its own: a different noise) and a's at
  # 0.3 (a replicate within a)
  set.seed(2)
  xf <- c(rep(seq(0.1, 0.9, length.out = 5), 2), 0.1, 0.3)
  lab <- c(rep("a", 5), rep("b", 5), "b", "a")
  field <- data.frame(y = sin(10 * pi / 5 * xf) + stats::rnorm(12, 0, ifelse(lab == "a", 0.1, 0.3)),
                      x = xf, lab = lab)
  # no bias, one bias, a bias per data set (correlated by rhoD); KOH and
  # S-GaSP
  for (model in list(c("none", "shared"), c("gp", "shared"), c("gp", "own"), c("sgasp", "shared"),
                     c("sgasp", "own"))) {
    disc <- model[1]
    set.seed(4)
    fit <- calibrate(pb$sim, field, source = "lab", sourceBias = model[2], discrepancy = disc,
                     nMCMC = 600, nBurn = 200, nChains = 1, showProgress = FALSE)
    expect_equal(fit$model$dims$noise, 2L)
    expect_equal(fit$model$dims$sources, if (model[2] == "own") 1L else 0L)
    U <- matrix(stats::runif(60), 30, 2)
    for (method in c("joint", "plugin")) {
      parts <- FBC:::design_particles(fit, 40, method)
      # each draw's system against the dense Gaussian on every row, each
      # row's noise variance its data set's (helper-design.R)
      sys <- lapply(seq_len(nrow(parts$phi)), function(s) draw_system(parts$phi[s, ], fit$model, U))
      d <- fit$model$data
      ds <- FBC:::.design_systems(d$Xf, d$yf, d$Xs, d$ys, parts$phi, U, matrix(0, 0, 1),
                                  fbc_nugget, fit$model$spec$model)
      N <- nrow(d$Xs) + nrow(d$Xf)
      expect_equal(drop(ds$ll), vapply(sys, `[[`, 1, "ll") - N / 2 * log(2 * pi), tolerance = 1e-10)
      expect_equal(ds$mu, vapply(sys, `[[`, numeric(30), "mu"), tolerance = 1e-8)
      expect_equal(ds$v, vapply(sys, `[[`, numeric(30), "v"), tolerance = 1e-8)
      # (the data sets' noise variances differ in every draw: using one for
      # the other would show above)
      ix <- FBC:::param_indices(1, 1, disc, noise = 2L, sources = fit$model$dims$sources)
      expect_gt(min(abs(parts$phi[, ix$sigma2E[1]] - parts$phi[, ix$sigma2E[2]])), 0)
      # (and the data sets' biases are neither one bias nor independent)
      if (model[2] == "own") {
        expect_gt(mean(abs(parts$phi[, ix$rhoD])), 0.1)
        expect_lt(mean(abs(parts$phi[, ix$rhoD])), 0.99)
      }
      set.seed(11)
      cpp <- FBC:::look_ahead(parts, U, fit$model, 3, 25)
      set.seed(11)
      ref <- look_ahead_r(sys, parts, U, fit$model, 3, 25)
      expect_identical(cpp$chosen, as.integer(ref$chosen))
      # (the gains, differences of variances near 1e-5, amplify the
      # systems' rounding: with the S-GaSP and a bias each, correlated near
      # 1, the plug-in's differ by up to 1e-8 of the largest gain, 1e-13
      # elsewhere; measured)
      expect_equal(cpp$scores, ref$scores, tolerance = 1e-6)
      expect_gt(max(cpp$scores[, 1]), 0)
    }
    set.seed(5)
    pr <- propose_runs(fit, n = 2, ndraws = 40, nfantasy = 20, ncandidates = 100)
    expect_named(pr, c("x", "u", "gain"))
    expect_equal(nrow(pr), 2)
  }
  # with a bias per data set, a prediction target's bias would be none of
  # theirs
  expect_snapshot(error = TRUE, propose_runs(fit, target = data.frame(x = 0.5)))
  # design_loop(): the data sets' column is not an input of the simulator
  f <- function(x, kappa) sin(10 * kappa[["u"]] * x$x)
  set.seed(3)
  out <- design_loop(f, field, lower = c(x = 0, u = 0), upper = c(x = 1, u = 1), n0 = 8,
                     batch = 2, budget = 2, discrepancy = "none", source = "lab", nMCMC = 400,
                     nBurn = 200, nChains = 1, design = list(ndraws = 40, nfantasy = 20))
  expect_equal(out$history$runs, c(8, 10))
  expect_named(out$sim, c("y", "x", "u"))
  expect_equal(out$fit$model$dims$noise, 2L)
})

test_that("a categorical input: the look-ahead is the dense plain-R one, and runs come with levels", {
  # the sinusoid with a categorical input `type` (levels a, b, c; c shifts
  # the response) in the runs and the field (b not measured)
  set.seed(6)
  m <- 18
  u <- (sample(m) - stats::runif(m)) / m
  x <- (sample(m) - stats::runif(m)) / m
  type <- rep(c("a", "b", "c"), 6)
  eta <- function(x, u, type) sin(10 * u * x) + 0.5 * (type == "c") * x
  sim <- data.frame(y = eta(x, u, type), x = x, type = type, u = u)
  xf <- rep(seq(0.1, 0.9, length.out = 5), 2)
  tf <- rep(c("a", "c"), each = 5)
  field <- data.frame(y = eta(xf, pi / 5, tf) + stats::rnorm(10, 0, 0.1), x = xf, type = tf)
  for (disc in c("none", "gp")) {
    set.seed(4)
    fit <- suppressWarnings(calibrate(sim, field, discrepancy = disc, nMCMC = 600, nBurn = 200,
                                      nChains = 1, showProgress = FALSE))
    expect_equal(fit$model$dims$levels, 3L)  # 3 levels: 3 partial correlations
    nm <- c(fit$model$scale$names$inputs, fit$model$scale$names$calibration)
    # candidates with every level (indicator columns, scaled units)
    set.seed(8)
    U <- FBC:::design_candidates(NULL, fit$model$scale, 30, fit$model$data$Xs, 1e-3)
    expect_setequal(FBC:::indicator_codes(U[, match(fit$model$scale$factors$type$columns, nm)]), 1:3)
    XT <- FBC:::design_target(data.frame(x = c(0.2, 0.7), type = c("b", "c")), fit$model$scale)
    for (method in c("joint", "plugin")) {
      parts <- FBC:::design_particles(fit, 40, method)
      sys <- lapply(seq_len(nrow(parts$phi)), function(s) draw_system(parts$phi[s, ], fit$model, U, XT))
      d <- fit$model$data
      ds <- FBC:::.design_systems(d$Xf, d$yf, d$Xs, d$ys, parts$phi, U, XT, fbc_nugget,
                                  fit$model$spec$model)
      N <- nrow(d$Xs) + nrow(d$Xf)
      expect_equal(drop(ds$ll), vapply(sys, `[[`, 1, "ll") - N / 2 * log(2 * pi), tolerance = 1e-10)
      expect_equal(ds$mu, vapply(sys, `[[`, numeric(nrow(U)), "mu"), tolerance = 1e-8)
      expect_equal(ds$v, vapply(sys, `[[`, numeric(nrow(U)), "v"), tolerance = 1e-8)
      expect_equal(ds$mT, vapply(sys, `[[`, numeric(2), "mT"), tolerance = 1e-8)
      expect_equal(ds$VT, vapply(sys, `[[`, numeric(2), "VT"), tolerance = 1e-8)
      # a batch of 3 (the pending points' kernel has the levels too)
      set.seed(11)
      cpp <- FBC:::look_ahead(parts, U, fit$model, 3, 25)
      set.seed(11)
      ref <- look_ahead_r(lapply(seq_len(nrow(parts$phi)), function(s) draw_system(parts$phi[s, ], fit$model, U)),
                          parts, U, fit$model, 3, 25)
      expect_identical(cpp$chosen, as.integer(ref$chosen))
      expect_equal(cpp$scores, ref$scores, tolerance = 1e-8)
    }
    # (the levels are correlated, not one and not independent)
    ix <- FBC:::param_indices(4, 1, disc, levels = 3L)
    expect_gt(mean(abs(parts$phi[, ix$rhoS])), 0.05)
  }
  # propose_runs(): the categorical input as a column of its levels; given
  # candidates by level (an unknown level refused), a target by level
  set.seed(5)
  pr <- propose_runs(fit, n = 2, ndraws = 40, nfantasy = 20, ncandidates = 100)
  expect_named(pr, c("x", "type", "u", "gain"))
  expect_s3_class(pr$type, "factor")
  expect_identical(levels(pr$type), c("a", "b", "c"))
  cand <- data.frame(x = c(0.3, 0.5, 0.5), type = c("b", "b", "c"), u = c(0.6, 0.6, 0.6))
  set.seed(5)
  pr2 <- propose_runs(fit, n = 3, candidates = cand, ndraws = 40, nfantasy = 20)
  expect_equal(sort(paste(pr2$x, pr2$type)), c("0.3 b", "0.5 b", "0.5 c"))
  expect_snapshot(error = TRUE, propose_runs(fit, candidates = transform(cand, type = "d")))
  set.seed(5)
  pr3 <- propose_runs(fit, n = 1, target = data.frame(x = 0.5, type = "b"), ndraws = 40,
                      nfantasy = 20, ncandidates = 100)
  expect_true(pr3$type %in% c("a", "b", "c"))
  # the new runs go back in with update(): the fit has them
  new <- data.frame(y = eta(pr$x, pr$u, as.character(pr$type)), x = pr$x, type = as.character(pr$type), u = pr$u)
  fit2 <- suppressWarnings(update(fit, sim = new, nMCMC = 300))
  expect_equal(fit2$model$dims$m, m + 2)
  # design_loop(): a categorical input of the field runs at its levels
  f <- function(x, kappa) eta(x$x, kappa[["u"]], x$type)
  set.seed(3)
  out <- design_loop(f, field, lower = c(x = 0, u = 0), upper = c(x = 1, u = 1), n0 = 8,
                     batch = 2, budget = 2, discrepancy = "none", nMCMC = 400, nBurn = 200,
                     nChains = 1, design = list(ndraws = 40, nfantasy = 20))
  expect_equal(out$history$runs, c(8, 10))
  expect_named(out$sim, c("y", "x", "type", "u"))
  expect_equal(sort(out$sim$type[1:8]), rep(c("a", "c"), each = 4))
  expect_true(all(out$sim$type %in% c("a", "c")))
  expect_equal(out$sim$y, eta(out$sim$x, out$sim$u, out$sim$type))
})

test_that("a prediction target draws the runs to its inputs", {
  pb <- sinus_problem()
  fit <- sinus_fit(pb, nMCMC = 1200)
  set.seed(7)
  cand <- data.frame(x = stats::runif(200), u = stats::runif(200))
  picks <- lapply(c(0.15, 0.85), function(x0) {
    set.seed(8)
    propose_runs(fit, n = 5, candidates = cand, target = data.frame(x = x0), ndraws = 60,
                 nfantasy = 30)
  })
  # measured (the default, plug-in picks): the batch for x0 =
  # 0.15 at x = 0.17, 0.48, 0.19, 0.16, 0.18 (first gain 87% of the
  # prediction's variance), for x0 = 0.85 at 0.84, 0.48, 0.84, 0.80, 0.46;
  # for kappa (the default target) the same call puts them at x = 0.28-0.90
  # (the joint criterion's picks: 0.16, 0.44, 0.19, 0.18, 0.90 and 0.84,
  # 0.48, 0.80, 0.84, 0.51)
  near <- function(pr, x0) stats::median(abs(pr$x - x0))
  expect_lt(abs(picks[[1]]$x[1] - 0.15), 0.05)
  expect_lt(abs(picks[[2]]$x[1] - 0.85), 0.05)
  expect_lt(near(picks[[1]], 0.15), 0.1)
  expect_lt(near(picks[[2]], 0.85), 0.1)
  expect_gt(near(picks[[1]], 0.85), 0.5)
  expect_gt(near(picks[[2]], 0.15), 0.5)
  # and near kappa's posterior (u = 0.54-0.65, 90%)
  expect_lt(abs(picks[[1]]$u[1] - 0.6), 0.1)
  expect_gt(picks[[1]]$gain[1], 0.2)
  expect_snapshot(error = TRUE, propose_runs(fit, target = "x"))
  expect_snapshot(error = TRUE, propose_runs(fit, target = data.frame(x = "a")))
})

test_that("propose_runs() says when new runs cannot shrink kappa's posterior", {
  # field data so noisy (sigma2E fixed at 50, scaled: sd 7 of the
  # response's) that kappa's posterior is about its prior: the emulator's
  # error is not what limits it. Measured: the best gain 0.02% of the
  # variance (the message's threshold is 1%).
  pb <- sinus_problem(m = 20)
  noisy <- set_hyperPriors(thetaSDist = "fixed", thetaSInit = c(8, 8), sigma2SDist = "fixed",
                           sigma2SInit = 1, sigma2EDist = "fixed", sigma2EInit = 50)
  set.seed(3)
  fit <- calibrate(pb$sim, pb$field, discrepancy = "none", hypers = noisy, nMCMC = 1200,
                   nBurn = 200, nChains = 1, showProgress = FALSE)
  set.seed(8)
  expect_message(pr <- propose_runs(fit, ndraws = 60, nfantasy = 30, ncandidates = 200),
                 "limited by something new runs cannot change")
  expect_lt(pr$gain, 0.01)
  expect_snapshot({
    message(FBC:::design_limited_message(0.0023, target = FALSE))
    message(FBC:::design_limited_message(0.0023, target = TRUE))
    message(FBC:::design_limited_message(-0.00015, target = FALSE))
  })
  # with the field's noise known (sd 0.14), a run can halve kappa's variance: no message
  fit <- sinus_fit(pb, nMCMC = 1200)
  set.seed(8)
  expect_silent(pr <- propose_runs(fit, ndraws = 60, nfantasy = 30, ncandidates = 200))
  expect_gt(pr$gain, 0.1)
  # a loop says it once, not at every step
  f <- function(x, kappa) sin(10 * kappa[["u"]] * x$x)
  set.seed(4)
  msgs <- character()
  withCallingHandlers(
    design_loop(f, pb$field, lower = c(x = 0, u = 0), upper = c(x = 1, u = 1), n0 = 8,
                batch = 1, budget = 3, discrepancy = "none", hypers = noisy, nMCMC = 600,
                nBurn = 200, nChains = 1, design = list(ndraws = 40, nfantasy = 20),
                showProgress = FALSE),
    message = function(m) {
      msgs <<- c(msgs, conditionMessage(m))
      invokeRestart("muffleMessage")
    })
  expect_equal(sum(grepl("limited by something", msgs)), 1)
})

test_that("propose_runs() refuses models it does not handle", {
  pb <- sinus_problem()
  # a simulator function has no runs to add to (R/simulator_function.R)
  f <- function(x, kappa) sin(10 * kappa[["u"]] * x$x)
  set.seed(1)
  ffit <- calibrate(f, pb$field, kappaDist = "uniform", kappaP1 = c(u = 0),
                    kappaP2 = c(u = 1), discrepancy = "none", nMCMC = 200, nBurn = 100,
                    nChains = 1, showProgress = FALSE)
  expect_snapshot(error = TRUE, propose_runs(ffit))
  expect_snapshot(error = TRUE, update(ffit, sim = pb$sim))
})

test_that("propose_runs() refuses beyond 3000 runs and distinct field inputs", {
  pb <- sinus_problem()
  fit <- sinus_fit(pb, nMCMC = 300)
  model <- fit$model
  # the field's 10 rows are 5 inputs x 2 replicates: 5 rows of the
  # look-ahead's system (the runs' count set by hand: no 3000-run fit)
  expect_equal(FBC:::design_rows(model), c(12, 5))
  model$dims$m <- 2995L
  expect_silent(FBC:::check_design_model(model))
  model$dims$m <- 2996L
  expect_snapshot(error = TRUE, FBC:::check_design_model(model))
  # independent outputs: each output's system is its own, the largest
  # counts (conc 12 runs + 8 field inputs, rate 9 + 10); shared outputs:
  # one system of all runs and field inputs
  po <- two_outputs(m = 12)
  sim <- po$sim[-(22:24), ]
  field <- po$field[-(1:2), ]
  ind <- calibrate(sim, field, output = "out", outputs = "independent", fit = FALSE)
  expect_equal(FBC:::design_rows(ind), c(12, 8))
  expect_equal(FBC:::design_rows(calibrate(sim, field, output = "out", fit = FALSE)), c(21, 18))
})

test_that("the look-ahead with a single draw is the plain-R one, batches included", {
  # every unknown at one draw (KOH-IMSPE's plug-in, bench/design.R's
  # "imspe"): the draws' A were kept only for more than one draw, and a
  # batch's pending points read one draw's uninitialised (picks that
  # changed from call to call, or solve() failing)
  pb <- sinus_problem()
  fit <- short_fit(pb)
  U <- matrix(stats::runif(60), 30, 2)
  XT <- matrix(c(0.2, 0.5, 0.7), 3, 1)
  phi <- FBC:::sampler_draws(fit, which.max(fit$logPost))
  one <- list(phi = phi, lw0 = 0, kappa = phi[, 1, drop = FALSE], plugin = TRUE)
  set.seed(11)
  cpp <- FBC:::look_ahead(one, U, fit$model, 3, 25, XT)
  set.seed(11)
  sys <- list(draw_system(phi[1, ], fit$model, U, XT))
  ref <- look_ahead_r(sys, one, U, fit$model, 3, 25)
  expect_identical(cpp$chosen, as.integer(ref$chosen))
  expect_equal(cpp$scores, ref$scores, tolerance = 1e-8)
  # (one draw: no reweighting, each step's gain the GP update's reduction
  # of the targets' variance, smaller once a pick is pending)
  expect_gt(min(cpp$scores[, 1]), -1e-12)
  expect_lt(max(cpp$scores[, 2], na.rm = TRUE), max(cpp$scores[, 1]))
  # and the same as two copies of the draw
  set.seed(11)
  two <- FBC:::look_ahead(list(phi = phi[c(1, 1), ], lw0 = c(0, 0), kappa = phi[c(1, 1), 1, drop = FALSE],
                               plugin = TRUE), U, fit$model, 3, 25, XT)
  expect_identical(two$chosen, cpp$chosen)
  expect_equal(two$scores, cpp$scores, tolerance = 1e-10)
})

test_that("runs of several outputs: the C++ look-ahead equals the plain-R one", {
  # two outputs sharing the rate t (helper-outputs.R), one simulator GP
  # (outputs = "shared"): a run gives both, so the look-ahead scores runs
  # of 2 rows, their 2 values fantasised jointly (look_ahead_runs_r())
  po <- two_outputs(m = 16)
  for (disc in c("none", "gp")) {
    set.seed(1)
    fit <- calibrate(po$sim, po$field, output = "out", discrepancy = disc, nMCMC = 600,
                     nBurn = 200, nChains = 1, showProgress = FALSE)
    set.seed(8)
    U <- FBC:::design_candidates(NULL, fit$model$scale, 10, fit$model$data$Xs, 1e-3)
    # 10 runs of 2 rows, alike but for the output's indicator column
    expect_equal(nrow(U), 20)
    j <- match(fit$model$scale$output$columns, c(fit$model$scale$names$inputs, fit$model$scale$names$calibration))
    expect_equal(FBC:::indicator_codes(U[, j, drop = FALSE]), rep(1:2, 10))
    expect_equal(U[c(TRUE, FALSE), -j], U[c(FALSE, TRUE), -j])
    XT <- FBC:::design_target(data.frame(x = c(0.2, 0.7), out = c("conc", "rate")), fit$model$scale)
    for (method in c("joint", "plugin")) {
      parts <- FBC:::design_particles(fit, 30, method)
      # kappa, the target XT and (the plug-in's criterion for kappa) kappa's
      # entropy
      cases <- list(list(NULL, FALSE), list(XT, FALSE))
      if (method == "plugin") cases <- c(cases, list(list(NULL, TRUE)))
      for (cs in cases) {
        tg <- cs[[1]]
        ent <- cs[[2]]
        set.seed(11)
        cpp <- if (is.null(tg)) FBC:::look_ahead(parts, U, fit$model, 3, 15, K = 2L, entropy = ent) else
          FBC:::look_ahead(parts, U, fit$model, 3, 15, tg, K = 2L)
        set.seed(11)
        sys <- lapply(seq_len(nrow(parts$phi)), function(s) draw_system(parts$phi[s, ], fit$model, U, tg))
        ref <- look_ahead_runs_r(sys, parts, U, fit$model, 3, 15, 2L, entropy = ent)
        expect_identical(cpp$chosen, as.integer(ref$chosen))
        expect_equal(cpp$variance, ref$variance, tolerance = 1e-8)
        expect_equal(cpp$gain, ref$gain, tolerance = 1e-8)
        expect_equal(cpp$scores, ref$scores, tolerance = 1e-8)
        expect_equal(dim(cpp$scores), c(10, 3))
        expect_gt(max(cpp$scores[, 1]), 0)
      }
    }
  }
  # (the outputs are correlated, rhoS away from 0: a run's 2 values are
  # not independent given a draw, and the joint fantasy matters)
  expect_gt(abs(mean(parts$phi[, FBC:::param_indices(2, 1, "gp", noise = 2L, levels = 1L)$rhoS])), 0.05)
  # a single draw (its A kept for the runs' factors, as for a batch): as
  # two copies of it
  one <- function(rows) list(phi = parts$phi[rows, , drop = FALSE], lw0 = rep(0, length(rows)),
                             kappa = parts$kappa[rows, , drop = FALSE], plugin = TRUE)
  set.seed(11)
  a <- FBC:::look_ahead(one(1), U, fit$model, 3, 15, XT, K = 2L)
  set.seed(11)
  b <- FBC:::look_ahead(one(c(1, 1)), U, fit$model, 3, 15, XT, K = 2L)
  expect_identical(a$chosen, b$chosen)
  expect_equal(a$scores, b$scores, tolerance = 1e-10)
  expect_true(all(is.finite(a$gain)))
})

test_that("independent outputs: the C++ look-ahead equals the plain-R one, an output's system each", {
  # outputs = "independent": each output its own simulator GP and
  # hyperparameters, only kappa shared; a run's 2 values are independent
  # given a draw, each Gaussian given its own output's data and pending
  # rows (draw_system_outputs(): each output's dense system in plain R)
  po <- two_outputs(m = 16)
  for (disc in c("none", "gp")) {
    set.seed(1)
    fit <- calibrate(po$sim, po$field, output = "out", outputs = "independent",
                     discrepancy = disc, nMCMC = 600, nBurn = 200, nChains = 1,
                     showProgress = FALSE)
    set.seed(8)
    U <- FBC:::design_candidates(NULL, fit$model$scale, 10, fit$model$data$Xs, 1e-3)
    expect_equal(nrow(U), 20)
    # a target at one output and one at the other (and two of one output)
    XT <- FBC:::design_target(data.frame(x = c(0.2, 0.7, 0.5), out = c("conc", "rate", "rate")),
                              fit$model$scale)
    parts <- FBC:::design_particles(fit, 30, "joint")
    # the systems: the log-likelihood the sum of the outputs' (the fit's own,
    # .fbc_loglik()), the means and variances each output's
    sys <- lapply(seq_len(nrow(parts$phi)), function(s) draw_system_outputs(parts$phi[s, ], fit$model, U, XT))
    cs <- FBC:::.design_systems(fit$model$data$Xf, fit$model$data$yf, fit$model$data$Xs, fit$model$data$ys, parts$phi, U,
                                XT, FBC:::fbc_nugget, fit$model$spec$model)
    ll <- vapply(seq_len(nrow(parts$phi)), function(s) {
      FBC:::.fbc_loglik(fit$model$data$Xf, fit$model$data$yf, fit$model$data$Xs, fit$model$data$ys, parts$phi[s, ],
                        FBC:::fbc_nugget, model = fit$model$spec$model)
    }, 1)
    expect_equal(drop(cs$ll), ll, tolerance = 1e-8)
    # (draw_system()'s ll leaves out the normal's constant)
    expect_equal(drop(cs$ll) - vapply(sys, `[[`, 1, "ll"),
                 rep(-0.5 * (nrow(fit$model$data$Xs) + nrow(fit$model$data$Xf)) * log(2 * pi), nrow(parts$phi)),
                 tolerance = 1e-10)
    expect_equal(cs$mu, sapply(sys, `[[`, "mu"), tolerance = 1e-8)
    expect_equal(cs$v, sapply(sys, `[[`, "v"), tolerance = 1e-8)
    expect_equal(cs$mT, sapply(sys, `[[`, "mT"), tolerance = 1e-8)
    expect_equal(cs$VT, sapply(sys, `[[`, "VT"), tolerance = 1e-8)
    for (method in c("joint", "plugin")) {
      parts <- FBC:::design_particles(fit, 30, method)
      sysT <- lapply(seq_len(nrow(parts$phi)), function(s) draw_system_outputs(parts$phi[s, ], fit$model, U, XT))
      # kappa, the target XT and (the plug-in's criterion for kappa) kappa's
      # entropy
      cases <- list(list(NULL, FALSE), list(XT, FALSE))
      if (method == "plugin") cases <- c(cases, list(list(NULL, TRUE)))
      for (cs in cases) {
        tg <- cs[[1]]
        ent <- cs[[2]]
        sys <- if (is.null(tg)) lapply(sysT, function(y) y[setdiff(names(y), c("mT", "VT", "CTU"))]) else sysT
        set.seed(11)
        cpp <- if (is.null(tg)) FBC:::look_ahead(parts, U, fit$model, 3, 15, K = 2L, entropy = ent) else
          FBC:::look_ahead(parts, U, fit$model, 3, 15, tg, K = 2L)
        set.seed(11)
        ref <- look_ahead_runs_r(sys, parts, U, fit$model, 3, 15, 2L, entropy = ent)
        expect_identical(cpp$chosen, as.integer(ref$chosen))
        expect_equal(cpp$variance, ref$variance, tolerance = 1e-8)
        # (measured: within 2e-12 of each other, 2e-9 of kappa's variance;
        # the bias's gains are small, 1e-6 to 5e-5, so relative 1e-7)
        expect_equal(cpp$gain, ref$gain, tolerance = 1e-6)
        expect_equal(cpp$scores, ref$scores, tolerance = 1e-6)
        expect_gt(max(cpp$scores[, 1]), 0)
      }
    }
  }
})

test_that("the look-ahead's conditionals are the model's own on every algebra", {
  # a product design (the Kronecker algebra) against the dense algebra on
  # the same model and draws: the same conditionals to rounding; the
  # nearest-neighbour algebra with 20 of the 29 earlier runs as neighbours
  # within a few percent of the candidates' spread
  set.seed(21)
  g <- expand.grid(x = seq(0, 1, by = 0.25), u = seq(0, 1, by = 0.2))
  sim <- data.frame(y = sin(10 * g$u * g$x), g)[sample(nrow(g)), ]
  xf <- c(0.15, 0.4, 0.65, 0.9)
  field <- data.frame(y = sin(2 * pi * xf) + stats::rnorm(4, 0, 0.05), x = xf)
  set.seed(13)
  fit <- calibrate(sim, field, nMCMC = 60, nBurn = 20, nChains = 1, showProgress = FALSE)
  expect_identical(fit$model$algebra$name, "kronecker")
  d <- fit$model$data
  phis <- FBC:::sampler_draws(fit, 1:5)
  U <- matrix(stats::runif(20), 10, 2)
  XT <- matrix(c(0.2, 0.7), 2, 1)
  sys <- function(model) FBC:::.design_systems(d$Xf, d$yf, d$Xs, d$ys, phis, U, XT, fbc_nugget, model)
  dense_model <- fit$model$spec$model
  dense_model$algebra <- FBC:::.model_codes()$algebra[["dense"]]
  kron <- sys(fit$model$spec$model)
  dense <- sys(dense_model)
  for (k in c("mu", "v", "ll", "mT", "VT")) expect_equal(kron[[k]], dense[[k]], tolerance = 1e-8)
  set.seed(13)
  near <- calibrate(sim, field, nMCMC = 60, nBurn = 20, nChains = 1, showProgress = FALSE,
                    algebra = "vecchia", neighbours = 20)
  vec <- sys(near$model$spec$model)
  spread <- diff(range(dense$mu))
  expect_lt(max(abs(vec$mu - dense$mu)) / spread, 0.05)
  expect_lt(max(abs(vec$mT - dense$mT)) / spread, 0.05)
  expect_lt(max(abs(sqrt(pmax(vec$v, 0)) - sqrt(dense$v))) / spread, 0.05)
})

test_that("propose_runs() weighs each candidate's gain by its probability of succeeding", {
  pb <- sinus_problem(m = 20)
  sim <- pb$sim
  # runs fail for u above 0.6
  fails <- sim$u > 0.6
  sim$y[fails] <- NA
  set.seed(8)
  fit <- suppressMessages(calibrate(sim, pb$field, discrepancy = "none", hypers = sinus_hypers(),
                                    nMCMC = 600, nBurn = 200, nChains = 1, showProgress = FALSE))
  cand <- data.frame(x = rep(c(0.3, 0.6), 2), u = rep(c(0.3, 0.9), each = 2))
  model <- fit$model
  U <- FBC:::scale_inputs(as.matrix(cand), model$scale, seq_len(2))
  s <- FBC:::run_success(model, U)
  expect_equal(s, 1 - predict(fit, cand, type = "failure"))
  expect_true(all(s[cand$u > 0.6] < 0.5) && all(s[cand$u < 0.6] > 0.5))
  # the gains are the unweighted look-ahead's times the success probability
  parts <- FBC:::design_particles(fit, 30, "joint")
  r <- FBC:::look_ahead_random(1, 10)
  w <- FBC:::look_ahead(parts, U, model, 1L, 10L, random = r)
  model0 <- model
  model0$design$failed <- NULL
  u <- FBC:::look_ahead(parts, U, model0, 1L, 10L, random = r)
  expect_equal(w$scores[, 1], u$scores[, 1] * s)
  expect_equal(FBC:::run_success(model0, U), numeric())
})
