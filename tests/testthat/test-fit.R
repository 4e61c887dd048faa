# The fit object (R/fit.R): constructor, validator, version and the upgrade
# of fits and checkpoints written by earlier versions. The old objects in
# fixtures/ were written by those versions themselves (see
# fixtures/make-old-fits.R): ff9b582 (the first calibrate(), one chain),
# 2617448 (FBC 0.1.0), fa818f9 (just before the kernels merge, with a
# checkpoint directory). Each is a run of the ball data with set.seed(7),
# nMCMC = 300, nBurn = 100, thinning = 2 (two chains but for ff9b582).

old_fit <- function(commit) readRDS(test_path("fixtures", sprintf("fit-%s.rds", commit)))

# The fixtures were made on the reference BLAS: draws equal to the bit only
# there (an optimized BLAS rounds sums differently, and a chain drifts).
skip_if_not_reference_blas <- function() {
  testthat::skip_if_not(FBC:::blas_kind() == "reference",
                        "draws to the bit need the reference BLAS the fixtures were made with")
}
# (with FBC 0.1.0's kernels and noise prior, as the fixtures were made)
old_args <- c(list(nMCMC = 300, nBurn = 100, thinning = 2, nChains = 2), defaults_010)
# calibrate(ballSim, ballField, <old_args>, ...) as those versions ran it:
# without kappa's jump move (no_jump(), helper-fit.R)
old_run <- function(...) {
  m <- no_jump(do.call(calibrate, c(list(ballSim, ballField, fit = FALSE), defaults_010)))
  calibrate(m, nMCMC = 300, nBurn = 100, thinning = 2, nChains = 2, ...)
}

# The simulator algebra as formats 3 to 5 kept it beside the choice (the
# retired sim_algebra_info()): name capitalised, the product design's dims.
old_sim_algebra <- function(a) {
  switch(a$name, kronecker = list(name = "Kronecker", dims = a$dims),
         vecchia = list(name = "Vecchia", dims = NULL, k = a$neighbours),
         list(name = a$name, dims = NULL))
}

# A current fit as formats 3 to 6 wrote it: with copies of the model's
# data, scale and spec beside the model.
with_copies <- function(fit, format) {
  fit[c("data", "scale", "spec")] <- fit$model[c("data", "scale", "spec")]
  fit$version$format <- format
  fit
}

# A current fit as format 3 wrote it: no model object, the model's choices
# among the settings.
as_format_3 <- function(fit) {
  m <- fit$model
  fit <- with_copies(fit, 3L)
  fit$settings <- c(fit$settings[c("nMCMC", "nBurn", "thinning", "nChains", "nugget")],
                    list(sampler = m$sampler, moves = m$moves, time = fit$settings$time,
                         checkpoint = fit$settings$checkpoint, algebra = m$options$algebra,
                         simAlgebra = old_sim_algebra(m$algebra), kernelS = m$kernelS, kernelB = m$kernelB,
                         discrepancy = m$discrepancy, output = m$options$output,
                         source = m$options$source, sourceBias = m$options$sourceBias))
  fit$model <- NULL
  fit$version$format <- 3L
  fit
}

test_that("a fresh fit carries the current version and its copies of the model description", {
  set.seed(2)
  fit <- calibrate(ballSim, ballField, nMCMC = 60, nBurn = 20, nChains = 2)
  expect_identical(fit$version, list(fbc = as.character(packageVersion("FBC")), format = 7L))
  expect_identical(FBC:::validate_fbc(fit), fit)
  # a current fit passes the gate untouched
  expect_identical(FBC:::upgrade_fbc(fit), fit)
  # the user-facing copies come from spec
  expect_identical(fit$vars, colnames(fit$Phi))
  expect_identical(fit$indices, FBC:::phi_indices(fit$model$spec))
  expect_identical(fit$priors, fit$model$spec$priors)
  expect_identical(fit$priorFns, fit$model$spec$fns)
  # update() rebuilds it through the same constructor
  up <- update(fit, nMCMC = 20)
  expect_identical(up$version, fit$version)
  expect_identical(up$Phi[up$chain == 1, ][1:20, ], fit$Phi[fit$chain == 1, ])
})

test_that("a fit of format 1 (before the discrepancy models) upgrades to the bias GP", {
  set.seed(2)
  fit <- calibrate(ballSim, ballField, nMCMC = 60, nBurn = 20, nChains = 2)
  old <- as_format_3(fit)
  old$version$format <- 1L
  old$settings$discrepancy <- NULL
  old$spec$model$discrepancy <- NULL
  up <- FBC:::upgrade_fbc(old)
  expect_identical(up$model$discrepancy, "gp")
  expect_identical(up$model$spec$model, fit$model$spec$model)
  expect_identical(up$Phi, fit$Phi)
  expect_identical(up$version$format, 7L)
  # a fit without a bias validates; its layout is the "none" one
  set.seed(2)
  none <- calibrate(ballSim, ballField, nMCMC = 100, nBurn = 40, nChains = 2,
                    discrepancy = "none")
  expect_identical(FBC:::validate_fbc(none), none)
  expect_identical(none$model$spec$model,  # Matérn 5/2
                   FBC:::compiled_model(1, 1, 4L, 4L, discrepancy = "none", Xf = none$model$data$Xf))
  other <- none
  other$model$spec$model$discrepancy <- 0L
  expect_error(FBC:::validate_fbc(other), "layout of phi for p = 1, q = 1 and discrepancy \"gp\"")
  other$model$spec$model$discrepancy <- 5L
  dm <- FBC:::discrepancy_models  # each model by its code
  expect_error(FBC:::validate_fbc(other), sprintf("must be a discrepancy code (%s)",
                                                  paste(dm$code, "for", dm$name, collapse = ", ")),
               fixed = TRUE)
})

test_that("validate_fbc() refuses broken objects, naming what is wrong", {
  set.seed(2)
  fit <- calibrate(ballSim, ballField, nMCMC = 60, nBurn = 20, nChains = 2)
  short <- fit
  short$chain <- short$chain[-1]
  short$logLik <- short$logLik[-(1:2)]
  expect_snapshot(error = TRUE, FBC:::validate_fbc(short))
  gone <- fit
  gone[c("logLik", "version")] <- NULL
  expect_snapshot(error = TRUE, FBC:::validate_fbc(gone))
  cols <- fit
  cols$Phi <- cols$Phi[, -4]
  cols$state$chains[[2]]$kept <- 3L
  expect_snapshot(error = TRUE, FBC:::validate_fbc(cols))
  nospec <- fit
  nospec$model$spec$model <- NULL
  expect_snapshot(error = TRUE, FBC:::validate_fbc(nospec))
  state <- fit
  state$state$chains[[1]]$sampler$logsd <- 1
  expect_snapshot(error = TRUE, FBC:::validate_fbc(state))
  renum <- fit
  renum$chain[renum$chain == 2] <- 3L
  expect_snapshot(error = TRUE, FBC:::validate_fbc(renum))
  # a layout of phi other than the model description's for these data
  moved <- fit
  moved$model$spec$model$offset[["muB"]] <- 0L
  expect_error(FBC:::validate_fbc(moved), "layout of phi for p = 1, q = 1 and discrepancy \"gp\"")
  # a fit from a newer FBC is refused by the gate of every entry point
  newer <- fit
  newer$version <- list(fbc = "9.0.0", format = 99L)
  expect_snapshot(error = TRUE, summary(newer), transform = function(x) {
    gsub("this is FBC [0-9.]+", "this is FBC <version>", x)
  })
})

test_that("fits of earlier versions upgrade, validate and keep their draws", {
  for (commit in c("ff9b582", "2617448", "fa818f9")) {
    old <- old_fit(commit)
    expect_null(old$version)
    fit <- FBC:::upgrade_fbc(old)
    expect_identical(fit$version$format, 7L)
    expect_identical(FBC:::validate_fbc(fit), fit)
    # the fit holds its model only: the data are the model's
    expect_false(any(c("data", "scale", "spec") %in% names(fit)))
    expect_identical(fit$model$data, old$data)
    expect_identical(fit$Phi, old$Phi)
    expect_identical(fit$logPost, old$logPost)
    expect_identical(fit$logLik, old$logLik)
    # the power exponential on both GPs, the design's algebra, and the one
    # layout of phi there was (the ball data: p = q = 1)
    expect_identical(fit$model$spec$model, FBC:::compiled_model(1, 1, 1L, 1L, 0L, Xf = old$data$Xf))
    expect_identical(fit$model[c("kernelS", "kernelB", "discrepancy")],
                     list(kernelS = "powexp", kernelB = "powexp", discrepancy = "gp"))
    expect_identical(fit$settings$nugget, 1e-6)
    # every chain continues from where it stopped: iteration 300
    for (st in fit$state$chains) {
      expect_identical(st$sampler$iter, 300L)
      expect_identical(st$sampler$phi, unname(st$last))
    }
  }
  # the first version: one chain and no R-hat; its state becomes chain 1's
  first <- FBC:::upgrade_fbc(old_fit("ff9b582"))
  expect_identical(first$chain, rep(1L, 100))
  expect_identical(first$state$chains[[1]]$kept, 100L)
  expect_identical(first$state$chains[[1]]$postDone, 200)
  expect_identical(first$estimates[, 1:8], old_fit("ff9b582")$estimates)
  expect_equal(first$estimates$ess, FBC:::chain_diagnostics(first$Phi, first$chain)$ess)
  # before the sampler state (0.1.0) the run was single-site
  expect_identical(FBC:::upgrade_fbc(old_fit("2617448"))$model$moves,
                   list(blocks = list(), repeats = integer(), scale = FALSE, gibbsMuB = FALSE,
                        params = FBC:::param_names(1, 1)))
  # a fit with a sampler state keeps its moves and adapted blocks
  b <- old_fit("fa818f9")
  # (their parameters now named, for the per-move report)
  expect_identical(FBC:::upgrade_fbc(b)$model$moves,
                   c(b$settings$moves, list(params = FBC:::param_names(1, 1))))
  expect_identical(FBC:::upgrade_fbc(b)$state$chains[[2]]$sampler, b$state$chains[[2]]$sampler)
})

test_that("a format 2 fit (before the S-GaSP class) upgrades, and the KOH draws are unchanged", {
  # fit-1150ae6.rds: made by FBC at 1150ae6 (make-old-fits.R, seed 7), the
  # last commit before the S-GaSP scale joined the model description with
  # length 0 under the KOH bias
  old <- old_fit("1150ae6")
  expect_identical(old$version$format, 2L)
  expect_false("lambdaZ" %in% names(old$spec$model$offset))
  fit <- FBC:::upgrade_fbc(old)
  expect_identical(fit$version$format, 7L)
  expect_identical(fit$model$spec$model, FBC:::compiled_model(1, 1, 1L, 1L, 0L, Xf = old$data$Xf))
  expect_identical(fit$Phi, old$Phi)
  expect_equal(predict(fit, c(1, 2.5, 4), method = "MAP"),
               readRDS(test_path("fixtures", "predict-1150ae6.rds"))$map, tolerance = 1e-10)
  # the same call and seed today: the same draws but for rounding (the
  # ball's repeated field rows are factored on the distinct rows since the
  # fixture was made; on the BLAS it was made with: another rounds
  # differently)
  skip_if_not_reference_blas()
  expect_equal(predict(fit, c(1, 2.5, 4), method = "MAP"),
               readRDS(test_path("fixtures", "predict-1150ae6.rds"))$map, tolerance = 1e-12)
  set.seed(7)
  now <- old_run()
  expect_equal(now$Phi, old$Phi, tolerance = 1e-10)
  expect_equal(now$logPost, old$logPost, tolerance = 1e-10)
  # the adapted state as it was (today's state adds the adaptive warm-up's
  # bookkeeping, unused under a fixed nBurn)
  was <- old$state$chains[[2]]$sampler
  expect_equal(now$state$chains[[2]]$sampler[names(was)], was, tolerance = 1e-10)
})

test_that("a format 3 fit (before the model object) upgrades, predicts, resumes, and its draws are today's", {
  # fit-3f92546.rds: made by FBC at 3f92546 (make-old-fits.R, seed 7), the
  # last commit that wrote format 3 (the model's choices among the settings)
  old <- old_fit("3f92546")
  expect_identical(old$version$format, 3L)
  expect_null(old$model)
  fit <- FBC:::upgrade_fbc(old)
  expect_identical(fit$version$format, 7L)
  expect_s3_class(fit$model, "fbc_model")
  expect_identical(fit$model$moves, old$settings$moves)
  expect_identical(fit$model$algebra$dims, old$settings$simAlgebra$dims)
  expect_identical(fit$model$algebra$name, tolower(old$settings$simAlgebra$name))
  expect_identical(fit$model[c("kernelS", "kernelB", "discrepancy", "sampler")],
                   old$settings[c("kernelS", "kernelB", "discrepancy", "sampler")])
  expect_identical(names(fit$settings),
                   c("nMCMC", "nBurn", "thinning", "nChains", "nugget", "time", "checkpoint"))
  expect_identical(fit$Phi, old$Phi)
  # the spec as it was, its compiled model completed (the classes' roles,
  # the field rows' grouping)
  expect_identical(fit$model$spec[names(fit$model$spec) != "model"], old$spec[names(old$spec) != "model"])
  expect_identical(fit$model$spec$model, FBC:::complete_compiled_model(old$spec$model, old$data$Xf))
  h <- c(1, 2.5, 4)
  ref <- readRDS(test_path("fixtures", "predict-3f92546.rds"))
  expect_equal(predict(old, h, method = "MAP"), ref$map, tolerance = 1e-10)
  # it resumes: every chain goes on from iteration 300
  set.seed(3)
  up <- update(old, nMCMC = 100)
  expect_identical(vapply(up$state$chains, function(st) st$sampler$iter, integer(1)), c(400L, 400L))
  expect_identical(unname(up$Phi[up$chain == 1, ][1:100, ]), unname(old$Phi[old$chain == 1, ]))
  # a current fit written as format 3 upgrades to the same fit
  set.seed(7)
  now <- old_run()
  back <- FBC:::upgrade_fbc(as_format_3(now))
  # (settings$warmup, each chain's warm-up, is newer than format 3)
  expect_identical(back$settings, now$settings[setdiff(names(now$settings), "warmup")])
  expect_identical(back$model[c("spec", "moves", "kernelS", "discrepancy", "dims", "classes")],
                   now$model[c("spec", "moves", "kernelS", "discrepancy", "dims", "classes")])
  keep <- c("name", "code", "neighbours", "dims")
  expect_identical(back$model$algebra[keep], now$model$algebra[keep])
  expect_identical(back$model$spec$model$fieldRows, now$model$spec$model$fieldRows)
  # the same call and seed today: the same draws but for rounding (repeated
  # field rows factored on the distinct rows since; on the BLAS the fixture
  # was made with)
  skip_if_not_reference_blas()
  expect_equal(predict(old, h, method = "MAP"), ref$map, tolerance = 1e-12)
  expect_equal(now$Phi, old$Phi, tolerance = 1e-10)
  expect_equal(now$logPost, old$logPost, tolerance = 1e-10)
  # the adapted state as it was (today's state adds the adaptive warm-up's
  # bookkeeping, unused under a fixed nBurn)
  was <- old$state$chains[[2]]$sampler
  expect_equal(now$state$chains[[2]]$sampler[names(was)], was, tolerance = 1e-10)
})

test_that("print, summary, predict, plot and update work on the fits of earlier versions", {
  for (commit in c("ff9b582", "2617448", "fa818f9")) {
    old <- old_fit(commit)
    out <- capture.output(print(old))
    expect_match(out[1], "<fbc>", fixed = TRUE)
    expect_true("  kernels: simulator powexp, bias powexp" %in% out)
    expect_true("  algebra: dense" %in% out)
    expect_s3_class(summary(old), "summary.fbc")
    expect_identical(rownames(summary(old)), colnames(old$Phi))
    expect_identical(coef(old), stats::setNames(old$estimates$mean, colnames(old$Phi)))
    expect_s3_class(plot(old), "ggplot")
    expect_s3_class(plot(old, "thetaS", type = "trace"), "ggplot")
    expect_s3_class(plot(old, type = "fits"), "ggplot")
    expect_equal(nrow(posterior::as_draws_df(old)), nrow(old$Phi))
    expect_type(convergence_messages(old), "character")
    expect_equal(dim(ppc_field(old, ndraws = 5)$yrep), c(5L, nrow(ballField)))
    set.seed(3)
    up <- update(old, nMCMC = 100)
    expect_identical(up$version$format, 7L)
    K <- length(unique(up$chain))
    expect_equal(nrow(up$Phi), nrow(old$Phi) + 50 * K)
    expect_identical(up$settings$nMCMC, 400L)
    for (k in seq_len(K)) {
      expect_identical(unname(up$Phi[up$chain == k, ][1:100, ]),
                       unname(old$Phi[FBC:::upgrade_fbc(old)$chain == k, ]))
      expect_identical(up$state$chains[[k]]$sampler$iter, 400L)
    }
  }
  # predictions of an old fit are the old version's own (its predict(),
  # saved by make-old-fits.R; ff9b582 had no predict())
  for (commit in c("2617448", "fa818f9")) {
    old <- old_fit(commit)
    ref <- readRDS(test_path("fixtures", sprintf("predict-%s.rds", commit)))
    h <- c(1, 2.5, 4)
    map <- predict(old, h, method = "MAP")
    expect_equal(map[c("pred", "se", "lower", "upper")], ref$map[c("pred", "se", "lower", "upper")],
                 tolerance = 1e-10)
    bayes <- predict(old, h)
    expect_equal(bayes[c("pred", "se")], ref$bayes[c("pred", "se")], tolerance = 1e-10)
    expect_equal(bayes[c("lower", "upper")], ref$bayes[c("lower", "upper")], tolerance = 1e-6)
  }
})

test_that("a checkpoint written before the kernels resumes to the draws of an uninterrupted run", {
  dir <- tempfile("ck-old-")
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  dir.create(dir)
  file.copy(list.files(test_path("fixtures", "checkpoint-fa818f9"), full.names = TRUE), dir)
  # chain 1 was stopped at iteration 150; chain 2 had not started
  expect_equal(ck_iter(dir, 1), 150)
  expect_false(file.exists(file.path(dir, "chain-2.rds")))
  set.seed(999)  # the checkpoint has the streams
  expect_message(
    fit <- old_run(checkpoint = dir),
    "iterations 150 and 0"
  )
  # chain 1 resumed after burn-in, where nothing adapts any more: its draws
  # are those of that version's uninterrupted run with the same seed (7,
  # make-old-fits.R)
  old <- FBC:::upgrade_fbc(old_fit("fa818f9"))
  one <- fit$chain == 1L
  if (FBC:::blas_kind() == "reference") {  # the BLAS the fixture was made with
    # (but for rounding: repeated field rows are factored on the distinct
    # rows since)
    expect_equal(fit$Phi[one, ], old$Phi[old$chain == 1L, ], tolerance = 1e-10)
    expect_equal(fit$logPost[one], old$logPost[old$chain == 1L], tolerance = 1e-10)
  } else {
    expect_equal(fit$Phi[one, ][1:20, ], old$Phi[old$chain == 1L, ][1:20, ], tolerance = 1e-8)
  }
  # chain 2 started from the checkpoint's start and stream under this
  # version's adaptation rule (one rule for every move): its
  # draws are those of this version's uninterrupted run with the same seed
  set.seed(7)
  now <- old_run()
  expect_identical(fit$Phi[!one, ], now$Phi[now$chain == 2L, ])
  expect_identical(fit$logLik[!one], now$logLik[now$chain == 2L])
  expect_identical(fit$state$chains[[2]]$sampler, now$state$chains[[2]]$sampler)
  expect_identical(fit$version$format, 7L)
  # a checkpoint file of a newer format is refused, nothing changed
  run <- readRDS(file.path(dir, "run.rds"))
  run$format <- FBC:::fbc_checkpoint_format + 1L
  saveRDS(run, file.path(dir, "run.rds"))
  expect_error(do.call(calibrate, c(list(ballSim, ballField, checkpoint = dir), old_args)),
               "written by another version of FBC")
})

test_that("a fit of format 5 is upgraded to one algebra record, the model it was", {
  # a product design: the Kronecker algebra, 5 x 5 settings
  g <- expand.grid(x = (1:5) / 6, t = seq(0.5, 3, length.out = 5))
  sim <- data.frame(y = exp(-g$t * g$x), x = g$x, t = g$t)
  field <- data.frame(y = exp(-1.7 * (1:4) / 5), x = (1:4) / 5)
  set.seed(1)
  fit <- calibrate(sim, field, nMCMC = 40, nBurn = 10, nChains = 1)
  expect_identical(fit$model$algebra[c("name", "dims")], list(name = "kronecker", dims = c(5L, 5L)))
  expect_null(fit$model$simAlgebra)
  # format 5 kept the algebra twice: the choice without dims, and what ran
  old <- with_copies(fit, 5L)
  old$model$simAlgebra <- list(name = "Kronecker", dims = c(5L, 5L))
  old$model$algebra$dims <- NULL
  up <- FBC:::upgrade_fbc(old)
  expect_identical(up$version$format, 7L)
  expect_identical(up$model, fit$model)
  expect_identical(unclass(up), unclass(fit))
  expect_output(print(up), "algebra: Kronecker, 5 x 5", fixed = TRUE)
})

test_that("a multi-output fit of format 4 is upgraded as outputs = \"shared\", the model it was", {
  set.seed(1)
  x <- runif(12); t <- runif(12, 0.5, 3)
  sim <- rbind(data.frame(y = exp(-t * x), x = x, out = "a", t = t),
               data.frame(y = t * x, x = x, out = "b", t = t))
  field <- rbind(data.frame(y = exp(-1.7 * (1:4) / 5), x = (1:4) / 5, out = "a"),
                 data.frame(y = 1.7 * (1:4) / 5, x = (1:4) / 5, out = "b"))
  fit <- calibrate(sim, field, output = "out", outputs = "shared", nMCMC = 60, nBurn = 20,
                   nChains = 1)
  old <- with_copies(fit, 4L)
  old$model$options$outputs <- NULL
  up <- FBC:::upgrade_fbc(old)
  expect_identical(up$version$format, 7L)
  expect_identical(up$model$options$outputs, "shared")
  expect_identical(up$call$outputs, "shared")
  expect_equal(predict(up, data.frame(x = 0.5, out = "a"))$pred,
               predict(fit, data.frame(x = 0.5, out = "a"))$pred)
})

test_that("a fit of format 6 upgrades to the fit holding its model only, with the same predictions", {
  set.seed(2)
  fit <- calibrate(ballSim, ballField, nMCMC = 60, nBurn = 20, nChains = 2)
  expect_false(any(c("data", "scale", "spec") %in% names(fit)))
  # format 6 kept copies of the model's data, scale and spec beside it
  old <- with_copies(fit, 6L)
  expect_identical(old$spec, fit$model$spec)
  up <- FBC:::upgrade_fbc(old)
  expect_identical(up$version$format, 7L)
  expect_identical(unclass(up), unclass(fit))
  # every function takes it through the gate: predictions and a
  # continuation identical to the bit
  h <- c(1, 2.5, 4)
  expect_identical(predict(old, h), predict(fit, h))
  expect_identical(predict(old, h, method = "MAP", type = "bias"),
                   predict(fit, h, method = "MAP", type = "bias"))
  set.seed(5)
  a <- update(old, nMCMC = 20)
  set.seed(5)
  b <- update(fit, nMCMC = 20)
  expect_identical(a$Phi, b$Phi)
  expect_identical(a$version$format, 7L)
  # a part the model lacks is taken from the fit's copy
  for (el in c("data", "scale", "spec")) {
    part <- old
    part$model[el] <- NULL
    whole <- FBC:::upgrade_fbc(part)
    expect_false(any(c("data", "scale", "spec") %in% names(whole)))
    expect_identical(whole$model[[el]], fit$model[[el]])
    expect_identical(predict(whole, h, method = "MAP"), predict(fit, h, method = "MAP"))
  }
  # a model whose sizes do not state the number of independent outputs
  # gets it
  few <- old
  few$model$dims$outputs <- NULL
  expect_identical(FBC:::upgrade_fbc(few)$model$dims$outputs, 1L)
  # a broken copy is not read: the model's own parts are kept
  wrong <- old
  wrong$scale$ysd <- 2 * wrong$scale$ysd
  expect_identical(FBC:::upgrade_fbc(wrong)$model$scale, fit$model$scale)
})
