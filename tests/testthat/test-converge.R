# Runs that stop when converged (R/converge.R).

# A short problem that meets this rule after a few checks: the ball data
# with Matern 5/2 GPs (no smoothness to mix), 2 chains. With seed 5 the rule
# is first met at 900 sweeps per chain (the 6th check), measured when the
# test was written; the tests below check what that means, not the number.
cv_args <- list(nMCMC = 400, nBurn = 300, nChains = 2, kernelS = "matern52",
                kernelB = "matern52")
cv_rule <- until_converged(rhat = 1.05, ess = 100, every = 100, maxMCMC = 1500)
cv_seed <- 5L
cv_fit <- local({
  fit <- NULL
  function() {
    if (is.null(fit)) {
      set.seed(cv_seed)
      fit <<- do.call(calibrate, c(list(ballSim, ballField, converge = cv_rule), cv_args))
    }
    fit
  }
})

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

test_that("bad rules are refused, naming the argument", {
  expect_snapshot(error = TRUE, until_converged(rhat = 1))
  expect_snapshot(error = TRUE, until_converged(every = 10))
  expect_snapshot(error = TRUE, until_converged(ess = "400"))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, converge = "yes"))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, nMCMC = 2000, nBurn = 1000,
                                          converge = until_converged(maxMCMC = 1000)))
  expect_snapshot(until_converged())
})
