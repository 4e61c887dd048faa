# Runs that stop when converged (R/converge.R).

# A short problem that meets this rule after a few checks: the ball data
# with Matern 5/2 GPs (no smoothness to mix), 2 chains. With seed 5 the rule
# is first met at 900 sweeps per chain (the 6th check), measured when the
# test was written; the tests below check what that means, not the number.
cv_args <- list(nMCMC = 400, nBurn = 300, nChains = 2, kernelS = "matern52",
                kernelB = "matern52")
cv_rule <- until_converged(rhat = 1.05, ess = 100, every = 100, maxMCMC = 1500)
cv_seed <- 5L
# The ball fit under `rule` with `args` after set.seed(seed), made at the
# first call and kept for the tests that share it.
cached_fit <- function(seed, rule, args) {
  force(seed); force(rule); force(args)
  fit <- NULL
  function() {
    if (is.null(fit)) {
      set.seed(seed)
      fit <<- do.call(calibrate, c(list(ballSim, ballField, converge = rule), args))
    }
    fit
  }
}
cv_fit <- cached_fit(cv_seed, cv_rule, cv_args)

test_that("a run under a rule stops at the first check that meets it", {
  skip_if_not_slow()
  fit <- cv_fit()
  cv <- fit$settings$converge
  expect_true(cv$converged)
  expect_gt(cv$checks, 1L)  # the first stretch alone did not meet it
  expect_identical(cv$sweeps, fit$settings$nMCMC)
  expect_identical(cv$sweeps, 400L + (cv$checks - 1L) * 100L)
  # the draws meet the rule ...
  est <- fit$estimates
  expect_true(all(est$rhat < 1.05 & est$ess >= 100))
  # ... and are those of one plain run of that length (the chains continue
  # their streams across checks), whose one check shorter did not
  set.seed(cv_seed)
  plain <- do.call(calibrate, c(list(ballSim, ballField), modifyList(cv_args, list(nMCMC = cv$sweeps))))
  expect_identical(plain$Phi, fit$Phi)
  expect_identical(plain$logPost, fit$logPost)
  set.seed(cv_seed)
  shorter <- do.call(calibrate, c(list(ballSim, ballField),
                                  modifyList(cv_args, list(nMCMC = cv$sweeps - 100L))))
  expect_false(meets_rule(shorter, cv_rule))
  expect_output(print(fit), sprintf("met at %d sweeps per chain", cv$sweeps))
})

test_that("a rule that is not met stops at the ceiling and says so", {
  set.seed(cv_seed)
  rule <- until_converged(ess = 1e6, every = 100, maxMCMC = 600)
  fit <- do.call(calibrate, c(list(ballSim, ballField, converge = rule), cv_args))
  expect_false(fit$settings$converge$converged)
  expect_identical(fit$settings$nMCMC, 600L)
  expect_identical(fit$settings$converge$checks, 3L)  # at 400, 500 and 600 sweeps
  expect_identical(nrow(fit$Phi), 2L * (600L - 300L) %/% 2L)
  expect_output(print(fit), "not met by 600 sweeps per chain \\(3 checks\\)")
})

test_that("an interrupted run under a rule resumes to the same end and draws", {
  skip_if_not_slow()
  ref <- cv_fit()
  dir <- tempfile("cv-")
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  # pieces of 50 sweeps: calls 1-8 are chain 1's first stretch, 9-16 chain
  # 2's; call 17 is chain 1's first piece after the first check
  old <- options(FBC.sampler = interrupt_at_call(17))
  set.seed(cv_seed)
  expect_warning(
    part <- do.call(calibrate, c(list(ballSim, ballField, converge = cv_rule, checkpoint = dir),
                                 cv_args)),
    "Resume it with the same"
  )
  options(old)
  expect_true(part$state$interrupted)
  expect_equal(ck_iter(dir, 1), 450)
  expect_equal(ck_iter(dir, 2), 400)
  set.seed(999)  # the streams are in the checkpoint
  expect_message(
    fit <- do.call(calibrate, c(list(ballSim, ballField, converge = cv_rule, checkpoint = dir),
                                cv_args)),
    "Resuming"
  )
  expect_same_draws(fit, ref)
  expect_identical(fit$settings$converge, ref$settings$converge)
  # the rule is part of the run: another rule is another run
  expect_error(
    do.call(calibrate, c(list(ballSim, ballField, converge = until_converged(ess = 200),
                              checkpoint = dir), cv_args)),
    "holds another run"
  )
})

test_that("Ctrl-C in a later stretch keeps every chain's draws up to its last completed stretch", {
  # no checkpoint, the sequential plan: call 17 is chain 1's first piece
  # after the first check (see above); chain 2 waits for its turn
  old <- options(FBC.sampler = interrupt_at_call(17))
  on.exit(options(old), add = TRUE)
  set.seed(cv_seed)
  w <- NULL
  part <- withCallingHandlers(
    do.call(calibrate, c(list(ballSim, ballField, converge = cv_rule), cv_args)),
    warning = function(e) { w <<- conditionMessage(e); invokeRestart("muffleWarning") }
  )
  options(old)
  expect_true(part$state$interrupted)
  # both chains kept: chain 1 to 450 sweeps, chain 2 to the first check's 400
  expect_identical(sort(unique(part$chain)), 1:2)
  expect_identical(as.vector(table(part$chain)), c(75L, 50L))
  expect_match(w, "Chain 2 was waiting for its turn", fixed = TRUE)
  expect_match(w, "Keeping 2 of 2 chains with 125 retained draws.", fixed = TRUE)
  expect_snapshot(cat(w))
  # chain 2's draws are those of the uninterrupted run's first stretch
  ref <- cv_fit()
  expect_identical(part$Phi[part$chain == 2L, ], ref$Phi[ref$chain == 2L, ][1:50, ])
})

test_that("update() continues under a rule as one longer update", {
  skip_if_not_slow()
  set.seed(cv_seed)
  fit0 <- do.call(calibrate, c(list(ballSim, ballField), cv_args))
  set.seed(8)
  up <- update(fit0, converge = cv_rule)
  cv <- up$settings$converge
  expect_true(cv$converged)
  expect_identical(up$settings$nMCMC, cv$sweeps)
  # nMCMC defaults to the rule's `every` for the first stretch
  expect_identical((cv$sweeps - 400L) %% 100L, 0L)
  set.seed(8)
  plain <- update(fit0, nMCMC = cv$sweeps - 400L)
  expect_identical(plain$Phi, up$Phi)
  expect_true(meets_rule(up, cv_rule))
  expect_null(plain$settings$converge)
})

test_that("next_check() puts the next check 70% of the way to where the draws predict the rule is met", {
  rule <- until_converged()  # R-hat < 1.01, bulk ESS >= 400
  chk <- function(rhat, ess) list(rhat = rhat, ess = ess)
  # ESS 300 at 1000 retained sweeps predicts 400 / 300 x 1000 = 1333.3;
  # 70% of the way: 1000 + 0.7 x 333.3 = 1233.3, rounded up to 1250
  # (R-hat asks for sqrt(0.008 / 0.01) = 0.894 times, less)
  expect_identical(next_check(1000, rule, chk(1.008, 300)), 1250L)
  # R-hat 1.015 at 800 with ESS 500: sqrt(0.015 / 0.01) x 800 = 979.8,
  # 800 + 0.7 x 179.8 = 925.9, so 950 (ESS alone would have stopped at once)
  expect_identical(next_check(800, rule, chk(1.015, 500)), 950L)
  # a near miss (ESS 399 at 2000: 2005, 2003.5, 2050) waits at least 5%
  # more: 2100
  expect_identical(next_check(2000, rule, chk(1.005, 399)), 2100L)
  # and at least one piece of 50 sweeps: at 500, 5% is 25
  expect_identical(next_check(500, rule, chk(1.005, 399)), 550L)
  # a far miss (ESS 200 at 500: 1000, 850) waits no longer than the
  # geometric step, 1.5 x 500 = 750; 1.5 x 750 = 1125 rounds up to 1150
  expect_identical(next_check(500, rule, chk(1.005, 200)), 750L)
  expect_identical(next_check(750, rule, chk(1.2, 20)), 1150L)
  # without a finite check (no sampled parameter), the geometric step
  expect_identical(next_check(750, rule), 1150L)
  expect_identical(next_check(750, rule, chk(-Inf, Inf)), 1150L)
  # the rule's own targets: R-hat < 1.05 and ESS >= 100 (ESS 80 at 400:
  # 500, 400 + 0.7 x 100 = 470, so 500; R-hat 1.03 asks for sqrt(0.6) =
  # 0.77 times)
  expect_identical(next_check(400, until_converged(rhat = 1.05, ess = 100), chk(1.03, 80)), 500L)
  # `every` checks at fixed steps whatever the draws say
  expect_identical(next_check(700, until_converged(every = 100), chk(1.5, 3)), 800L)
})

# The check points of a run under `rule` whose first check came `first`
# retained sweeps a chain after the burn-in, replayed on the prefixes of
# its chains' draws (the draws do not depend on when the rule checks): the
# retained sweeps a chain at each check up to the first that meets it.
replay_checks <- function(fit, rule, first) {
  idx <- split(seq_along(fit$chain), fit$chain)
  th <- fit$settings$thinning
  posts <- first
  repeat {
    post <- posts[length(posts)]
    r <- post / th
    stopifnot(r <= min(lengths(idx)))
    est <- chain_diagnostics(fit$Phi[unlist(lapply(idx, utils::head, r)), , drop = FALSE],
                             rep(seq_along(idx), each = r))
    check <- list(rhat = max(est$rhat, na.rm = TRUE), ess = min(est$ess, na.rm = TRUE))
    if (check$rhat < rule$rhat && check$ess >= rule$ess) return(posts)
    posts <- c(posts, next_check(post, rule, check))
  }
}

# A run under the predicting schedule (every = NULL): burn-in 200, a first
# check at 400 retained sweeps, then where next_check() puts them. With
# seed 3 the checks at the time of writing fell at 400, 600 (the geometric
# step), 700 (a prediction), 750 and 800 (least steps); the tests check
# what the replay gives, not these numbers.
pr_args <- list(nMCMC = 600, nBurn = 200, nChains = 2, kernelS = "matern52",
                kernelB = "matern52")
pr_rule <- until_converged(rhat = 1.02, ess = 150, maxMCMC = 2000)
pr_seed <- 3L
pr_fit <- cached_fit(pr_seed, pr_rule, pr_args)

test_that("a run checks where the draws so far predict the rule is met, and stops at the first check that meets it", {
  fit <- pr_fit()
  cv <- fit$settings$converge
  posts <- replay_checks(fit, pr_rule, 400L)
  expect_true(cv$converged)
  expect_identical(cv$checks, length(posts))
  expect_identical(cv$sweeps, 200L + posts[length(posts)])
  expect_identical(nrow(fit$Phi), 2L * posts[length(posts)] %/% 2L)
  expect_gt(cv$checks, 2L)  # more than the first stretch and one step
  # every step is one of the three: at most the geometric step, at least
  # the least step
  steps <- diff(posts)
  expect_true(all(posts[-1] <= ceiling(1.5 * posts[-length(posts)] / 50) * 50))
  expect_true(all(steps >= pmax(50, ceiling(0.05 * posts[-length(posts)] / 50) * 50)))
  est <- fit$estimates
  expect_true(all(est$rhat[!is.na(est$rhat)] < 1.02 & est$ess[!is.na(est$ess)] >= 150))
})

test_that("set.seed() reproduces a run of predicted length on sequential and multisession plans", {
  skip_if_not_slow()
  ref <- pr_fit()
  set.seed(pr_seed)
  again <- do.call(calibrate, c(list(ballSim, ballField, converge = pr_rule), pr_args))
  expect_identical(again$Phi, ref$Phi)
  expect_identical(again$settings$converge, ref$settings$converge)
  skip_if_not_installed("future")
  old <- future::plan(future::multisession, workers = 2)
  on.exit(future::plan(old), add = TRUE)
  set.seed(pr_seed)
  multi <- do.call(calibrate, c(list(ballSim, ballField, converge = pr_rule), pr_args))
  expect_same_draws(multi, ref)
  expect_identical(multi$settings$converge, ref$settings$converge)
})

test_that("a run of predicted length interrupted after a predicted check resumes to the same end and draws", {
  skip_if_not_slow()
  ref <- pr_fit()
  posts <- replay_checks(ref, pr_rule, 400L)
  skip_if(length(posts) < 5L, "the run has fewer than 5 checks")
  # pieces of 50 sweeps on the sequential plan, chain 1 then chain 2 in
  # each stretch: interrupt chain 1 in its first piece of the fourth
  # stretch, after the checks at posts[1:3] (which placed posts[3] and
  # posts[4] from the draws)
  pieces <- c(200L + posts[1], diff(posts[1:3])) %/% 50L
  call <- 2L * sum(pieces) + 1L
  dir <- tempfile("cv-")
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  old <- options(FBC.sampler = interrupt_at_call(call))
  set.seed(pr_seed)
  expect_warning(
    part <- do.call(calibrate, c(list(ballSim, ballField, converge = pr_rule, checkpoint = dir),
                                 pr_args)),
    "Resume it with the same"
  )
  options(old)
  expect_true(part$state$interrupted)
  expect_equal(ck_iter(dir, 1), 200 + posts[3] + 50)
  expect_equal(ck_iter(dir, 2), 200 + posts[3])
  set.seed(999)  # the streams are in the checkpoint
  expect_message(
    fit <- do.call(calibrate, c(list(ballSim, ballField, converge = pr_rule, checkpoint = dir),
                                pr_args)),
    "Resuming"
  )
  expect_same_draws(fit, ref)
  expect_identical(fit$settings$converge, ref$settings$converge)
})

test_that("a far miss waits the geometric step, up to the ceiling", {
  # ESS 1e6 is never near: from the first check at 100 retained sweeps
  # (nMCMC 400, burn-in 300) each check comes at 1.5 times the sweeps,
  # rounded up to 50: 150, 250 (225), 400 (375), then the ceiling's 500
  # (800 sweeps in all, not 300 + 600)
  set.seed(cv_seed)
  rule <- until_converged(ess = 1e6, maxMCMC = 800)
  fit <- do.call(calibrate, c(list(ballSim, ballField, converge = rule), cv_args))
  expect_false(fit$settings$converge$converged)
  expect_identical(fit$settings$converge$checks, 5L)  # at 400, 450, 550, 700, 800 sweeps
  expect_identical(fit$settings$nMCMC, 800L)
  expect_identical(nrow(fit$Phi), 2L * (800L - 300L) %/% 2L)
})

test_that("bad rules are refused, naming the argument", {
  expect_snapshot(error = TRUE, until_converged(rhat = 1))
  expect_snapshot(error = TRUE, until_converged(every = 10))
  expect_snapshot(error = TRUE, until_converged(ess = "400"))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, converge = "yes"))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, nMCMC = 2000, nBurn = 1000,
                                          converge = until_converged(maxMCMC = 1000)))
  expect_snapshot(until_converged())
  expect_snapshot(until_converged(rhat = 1.05, ess = 100, every = 200, maxMCMC = 3000))
})
