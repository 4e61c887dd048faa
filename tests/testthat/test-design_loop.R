# The design loop (R/design_loop.R): runs proposed, run and added.

test_that("design_loop() runs a function simulator through futures and adds runs", {
  f <- function(x, kappa) sin(10 * kappa[["u"]] * x$x)
  pb <- sinus_problem()
  set.seed(2)
  out <- design_loop(f, pb$field, lower = c(x = 0, u = 0), upper = c(x = 1, u = 1), n0 = 8,
                     batch = 2, budget = 3, discrepancy = "none", hypers = sinus_hypers(),
                     nMCMC = 600, nBurn = 200, nChains = 1,
                     design = list(ndraws = 40, nfantasy = 20, target = data.frame(x = 0.5)))
  # 8 initial runs, then a batch of 2 and the last 1 of the budget (chosen
  # for a prediction target, passed through `design`)
  expect_equal(out$history$runs, c(8, 10, 11))
  expect_equal(nrow(out$sim), 11)
  expect_equal(out$fit$model$dims$m, 11)
  # the responses are the simulator's at the runs' inputs
  expect_equal(out$sim$y, sin(10 * out$sim$u * out$sim$x))
  expect_true(all(out$sim$x >= 0 & out$sim$x <= 1 & out$sim$u >= 0 & out$sim$u <= 1))
  # its candidates stay in `lower`-`upper` where the field's inputs
  # (0.1-0.9) go beyond them: the half at the field's inputs held there
  set.seed(3)
  cand <- FBC:::loop_candidates(out$fit, pb$field, c(x = 0.3, u = 0.2), c(x = 0.7, u = 0.8),
                                list(), "u", "x")
  expect_equal(nrow(cand), 200)
  expect_true(all(cand$x >= 0.3 & cand$x <= 0.7 & cand$u >= 0.2 & cand$u <= 0.8))
  # the first half at the field's inputs 0.3, 0.5, 0.7 (0.1 and 0.9 held
  # to 0.3 and 0.7)
  expect_setequal(unique(round(cand$x[1:100], 12)), c(0.3, 0.5, 0.7))
  expect_snapshot(error = TRUE, design_loop(f, pb$field, lower = c(x = 0), upper = c(x = 1)))
  expect_snapshot(error = TRUE, design_loop(f, pb$field, lower = c(x = 0, u = 0), upper = c(x = 1, u = 1),
                                            output = "out"))
})

test_that("propose_runs() and design_loop() give runs of every output", {
  po <- two_outputs(m = 16)
  set.seed(1)
  fit <- calibrate(po$sim, po$field, output = "out", discrepancy = "none", nMCMC = 600,
                   nBurn = 200, nChains = 1, showProgress = FALSE)
  set.seed(5)
  pr <- propose_runs(fit, n = 3, ndraws = 40, nfantasy = 20, ncandidates = 100)
  # a run: its inputs, no output column
  expect_two_output_runs(pr, po$sim)
  expect_true(all(pr$gain > 0))
  # given candidates are runs too (an output column refused)
  cand <- data.frame(x = c(0.1, 0.5, 0.9), t = 1.7)
  set.seed(5)
  pr2 <- propose_runs(fit, n = 3, candidates = cand, ndraws = 40, nfantasy = 20)
  expect_setequal(pr2$x, cand$x)
  expect_snapshot(error = TRUE, propose_runs(fit, candidates = transform(cand, out = "conc")))
  # a target names its output
  set.seed(5)
  pt <- propose_runs(fit, n = 1, target = data.frame(x = 0.5, out = "rate"), ndraws = 40,
                     nfantasy = 20, ncandidates = 100)
  expect_named(pt, c("x", "t", "gain"))
  # without the output column a target is every output at its inputs (a
  # data frame or numeric)
  both <- data.frame(x = c(0.5, 0.5, 0.8, 0.8), out = c("conc", "rate", "conc", "rate"))
  set.seed(5)
  p1 <- propose_runs(fit, n = 2, target = both, ndraws = 40, nfantasy = 20, ncandidates = 100)
  for (tg in list(data.frame(x = c(0.5, 0.8)), c(0.5, 0.8))) {
    set.seed(5)
    p2 <- propose_runs(fit, n = 2, target = tg, ndraws = 40, nfantasy = 20, ncandidates = 100)
    attr(p2, "time") <- attr(p1, "time")
    expect_identical(p2, p1)
  }
  expect_equal(nrow(FBC:::design_target(data.frame(x = c(0.5, 0.8)), fit$model$scale)), 4)
  # the size limit counts a run's rows, and says so
  U <- FBC:::design_candidates(NULL, fit$model$scale, 300, fit$model$data$Xs, 1e-3)
  expect_snapshot(error = TRUE, FBC:::check_look_ahead_size(1e4, fit$model, U, matrix(0, 0, 2)))
  # the runs go back in with update(), each as its two rows
  f1 <- function(x, t) 5 * exp(-t * x)
  f2 <- function(x, t) 2 * t * x
  new <- rbind(data.frame(y = f1(pr$x, pr$t), x = pr$x, out = "conc", t = pr$t),
               data.frame(y = f2(pr$x, pr$t), x = pr$x, out = "rate", t = pr$t))
  fit2 <- update(fit, sim = new, nMCMC = 300)
  expect_equal(fit2$model$dims$m, 32 + 6)
  # design_loop(): one call of f per run, on the run's rows at each output
  two_output_loop(po$field)
  # f must give a run's every output
  field <- po$field[po$field$x > 0.1 & po$field$x < 0.9, ]
  expect_snapshot(error = TRUE, design_loop(function(x, kappa) 1, field, lower = c(x = 0, t = 0.5),
                                            upper = c(x = 1, t = 3), output = "out"))
})

test_that("propose_runs() and design_loop() handle independent outputs", {
  po <- two_outputs(m = 16)
  set.seed(1)
  fit <- calibrate(po$sim, po$field, output = "out", outputs = "independent",
                   discrepancy = "gp", nMCMC = 600, nBurn = 200, nChains = 1,
                   showProgress = FALSE)
  set.seed(5)
  pr <- propose_runs(fit, n = 3, ndraws = 40, nfantasy = 20, ncandidates = 100)
  # runs: their inputs, in the design's ranges, distinct from the runs
  expect_two_output_runs(pr, po$sim)
  expect_true(all(is.finite(pr$gain)))
  # a target at one output
  set.seed(5)
  pt <- propose_runs(fit, n = 1, target = data.frame(x = 0.5, out = "rate"), ndraws = 40,
                     nfantasy = 20, ncandidates = 100)
  expect_named(pt, c("x", "t", "gain"))
  # a loop, one call of f per run (its refits through update(fit, sim =))
  out <- two_output_loop(po$field, outputs = "independent")
  expect_equal(out$fit$model$options$outputs, "independent")
})

test_that("design_loop() warns once, at the end, when its runs do not cover the field's inputs", {
  # runs in x <= 0.5 while the field's x reach 0.9 (sinus_problem()): every
  # fit of the loop extrapolates; the loop says so once, after its last fit
  f <- function(x, kappa) sin(10 * kappa[["u"]] * x$x)
  pb <- sinus_problem()
  set.seed(2)
  ws <- list()
  out <- withCallingHandlers(
    design_loop(f, pb$field, lower = c(x = 0, u = 0), upper = c(x = 0.5, u = 1), n0 = 8,
                batch = 1, budget = 2, discrepancy = "none", hypers = sinus_hypers(),
                nMCMC = 400, nBurn = 100, nChains = 1, design = list(ndraws = 40, nfantasy = 20),
                showProgress = FALSE),
    warning = function(w) {
      ws[[length(ws) + 1]] <<- w
      invokeRestart("muffleWarning")
    })
  expect_equal(nrow(out$history), 3)
  expect_length(ws, 1)
  expect_s3_class(ws[[1]], "fbc_extrapolation")
  expect_match(conditionMessage(ws[[1]]), "outside the range of the simulator design")
})

test_that("design_loop() records the runs where f fails and goes on", {
  # f errors where x + u > 1.4 and returns NaN where u < 0.08
  f <- function(x, kappa) {
    if (x$x + kappa[["u"]] > 1.4) stop("solver diverged at x = ", round(x$x, 3))
    if (kappa[["u"]] < 0.08) return(NaN)
    sin(10 * kappa[["u"]] * x$x)
  }
  pb <- sinus_problem()
  set.seed(4)
  out <- suppressWarnings(suppressMessages(
    design_loop(f, pb$field, lower = c(x = 0, u = 0), upper = c(x = 1, u = 1), n0 = 12,
                batch = 2, budget = 4, discrepancy = "none", hypers = sinus_hypers(),
                nMCMC = 400, nBurn = 200, nChains = 1,
                design = list(ndraws = 30, nfantasy = 10))))
  bad <- out$sim$x + out$sim$u > 1.4 | out$sim$u < 0.08
  expect_true(any(bad))
  expect_identical(out$failed$run, which(bad))
  expect_true(all(is.na(out$sim$y[bad])))
  expect_equal(out$sim$y[!bad], sin(10 * out$sim$u[!bad] * out$sim$x[!bad]))
  err <- out$sim$x + out$sim$u > 1.4
  expect_match(out$failed$condition[err[bad]], "^solver diverged at x = ")
  expect_match(out$failed$condition[!err[bad]], "not finite")
  expect_equal(out$fit$model$dims$m, sum(!bad))
  expect_identical(out$fit$model$design$failed$rows, which(bad))
  expect_equal(max(out$history$runs), 16)
})
