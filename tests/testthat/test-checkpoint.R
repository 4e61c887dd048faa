# Checkpoints, resume, interrupts and progress (R/checkpoint.R, R/run.R). The
# property tested throughout: a run stopped anywhere (imitated Ctrl-C,
# SIGKILL of the session or of a worker) and resumed from its checkpoint
# directory gives exactly the draws of an uninterrupted run with the same
# seed, on any plan.

test_that("a chain in pieces makes the draws of the uninterrupted chain", {
  skip_if_not_slow()
  # A checkpointed run (checkpoint after every piece) equals a plain one...
  ref <- ck_reference()
  dir <- tempfile("ck-")
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  set.seed(ck_seed)
  fit <- do.call(calibrate, c(list(ballSim, ballField, checkpoint = dir, checkpointEvery = 0), ck_args))
  expect_same_draws(fit, ref)
  expect_setequal(list.files(dir), c("run.rds", "chain-1.rds", "chain-2.rds"))
  ck <- readRDS(file.path(dir, "chain-2.rds"))
  expect_true(ck$start$finished)
  # its draws are chain 2's, on the sampler's scale (kappa in [0, 1]; the
  # columns of Phi: the Matérn has no smoothness column)
  expect_identical(ck$start$draws[, FBC:::phi_columns(ref$model$spec), drop = FALSE][, -1],
                   unname(ref$Phi[ref$chain == 2, -1]))
  # ...and the pieces are what makes it exact: the piece boundaries are
  # multiples of 50 sweeps from the chain's start, and a chain continued
  # from any boundary with its saved RNG state repeats the same sweeps
  sp <- fit$model$spec
  moves <- fit$model$moves
  st0 <- FBC:::initial_state(sp$init, sp)
  set.seed(5)
  one <- FBC:::sample_chain(fit$model$data, sp, st0, moves, 50L, 30L, 1L, FALSE)
  seed <- .Random.seed
  two <- FBC:::sample_chain(fit$model$data, sp, one$state, moves, 50L, 30L, 1L, FALSE)
  assign(".Random.seed", seed, envir = globalenv())
  again <- FBC:::sample_chain(fit$model$data, sp, one$state, moves, 50L, 30L, 1L, FALSE)
  expect_identical(again$draws, two$draws)
  expect_identical(again$state, two$state)
})

test_that("a relative checkpoint directory is kept as the absolute one used", {
  base <- tempfile("ck-wd-")
  dir.create(base)
  on.exit(unlink(base, recursive = TRUE), add = TRUE)
  old <- setwd(base)
  on.exit(setwd(old), add = TRUE)
  set.seed(ck_seed)
  fit <- do.call(calibrate, c(list(ballSim, ballField, checkpoint = "run1"), ck_args))
  # the same directory from anywhere: workers and later sessions may start
  # in another working directory
  expect_identical(fit$settings$checkpoint, normalizePath(file.path(base, "run1")))
  expect_true(file.exists(file.path(fit$settings$checkpoint, "run.rds")))
})

test_that("an interrupted run resumes from its checkpoint to the uninterrupted draws", {
  skip_if_not_slow()
  ref <- ck_reference()
  dir <- tempfile("ck-")
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  # imitated Ctrl-C in this session, 600 iterations (12 pieces) into chain 1
  old <- options(FBC.sampler = interrupt_at_call(12))
  set.seed(ck_seed)
  expect_warning(
    part <- do.call(calibrate, c(list(ballSim, ballField, checkpoint = dir), ck_args)),
    "Resume it with the same"
  )
  options(old)
  expect_true(part$state$interrupted)
  expect_equal(unique(part$chain), 1L)  # chain 2 never started
  expect_equal(ck_iter(dir, 1), 600)
  expect_false(file.exists(file.path(dir, "chain-2.rds")))
  set.seed(999)  # the session's RNG does not matter: the checkpoint has the streams
  expect_message(
    fit <- do.call(calibrate, c(list(ballSim, ballField, checkpoint = dir), ck_args)),
    "Resuming"
  )
  expect_same_draws(fit, ref)
  expect_false(fit$state$interrupted)
  # a finished run's directory gives the run back without sampling
  expect_message(
    back <- do.call(calibrate, c(list(ballSim, ballField, checkpoint = dir), ck_args)),
    "iterations 800 and 800"
  )
  expect_same_draws(back, ref)
  # update() goes on from a resumed fit as from any other
  set.seed(3)
  up <- update(fit, nMCMC = 100)
  expect_equal(as.vector(table(up$chain)), c(300, 300))
  expect_identical(up$Phi[up$chain == 2, ][1:250, ], ref$Phi[ref$chain == 2, ])
})

test_that("a session killed with SIGKILL mid-run resumes to the uninterrupted draws", {
  skip_if_not_slow()
  skip_on_cran()
  skip_if_not_installed("callr")
  ref <- ck_reference()
  dir <- tempfile("ck-")
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  child <- callr::r_bg(function(dir, args, seed, sampler) {
    library(FBC)
    options(FBC.sampler = sampler)
    set.seed(seed)
    do.call(calibrate, c(list(ballSim, ballField, checkpoint = dir, checkpointEvery = 0), args))
  }, args = list(dir = dir, args = ck_args, seed = ck_seed, sampler = slow_sampler(0.03)))
  on.exit(child$kill(), add = TRUE)
  # kill the session while chain 1 is past burn-in
  wait_until(function() ck_iter(dir, 1) >= 400, child)
  child$kill()  # SIGKILL
  expect_false(child$is_alive())
  at <- ck_iter(dir, 1)
  expect_gt(at, 300)
  expect_lt(at, 800)
  expect_message(
    fit <- do.call(calibrate, c(list(ballSim, ballField, checkpoint = dir), ck_args)),
    "Resuming"
  )
  expect_same_draws(fit, ref)
})

test_that("multisession: a worker killed mid-run loses nothing but time; the session goes on", {
  skip_if_not_slow()
  skip_on_cran()
  skip_if_not_installed("callr")
  ref <- ck_reference()
  dir <- tempfile("ck-")
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  child <- callr::r_bg(function(dir, args, seed, sampler) {
    library(FBC)
    future::plan(future::multisession, workers = 2)
    options(FBC.sampler = sampler)
    set.seed(seed)
    warn <- character()
    fit <- withCallingHandlers(
      do.call(calibrate, c(list(ballSim, ballField, checkpoint = dir, checkpointEvery = 0), args)),
      warning = function(w) {
        warn <<- c(warn, conditionMessage(w))
        invokeRestart("muffleWarning")
      }
    )
    options(FBC.sampler = NULL)
    # the plan's workers are usable at once
    again <- calibrate(ballSim, ballField, nMCMC = 200, nBurn = 100, nChains = 2)
    list(fit = fit, warn = warn, again = nrow(again$Phi))
  }, args = list(dir = dir, args = ck_args, seed = ck_seed, sampler = slow_sampler(0.05)))
  on.exit(child$kill(), add = TRUE)
  pidFile <- file.path(dir, "chain-2.pid")
  wait_until(function() file.exists(pidFile) && ck_iter(dir, 2) >= 400, child)
  pid <- as.integer(readLines(pidFile)[1])
  tools::pskill(pid, tools::SIGKILL)
  child$wait(120000)
  res <- child$get_result()
  expect_match(paste(res$warn, collapse = "\n"), "chain 2 stopped \\(killed or crashed\\)")
  part <- res$fit
  expect_true(part$state$interrupted)
  # chain 1 ran to its end, as in the sequential reference
  expect_identical(part$Phi[part$chain == 1, ], ref$Phi[ref$chain == 1, ])
  expect_lt(sum(part$chain == 2), sum(ref$chain == 2))
  expect_equal(res$again, 100)
  # resumed here, sequentially: the plan does not matter
  expect_message(
    fit <- do.call(calibrate, c(list(ballSim, ballField, checkpoint = dir), ck_args)),
    "Resuming"
  )
  expect_same_draws(fit, ref)
})

test_that("multisession: Ctrl-C returns the chains' draws and leaves the workers free", {
  skip_if_not_slow()
  skip_on_cran()
  skip_if_not_installed("callr")
  marker <- tempfile("started-")
  dir.create(marker)
  on.exit(unlink(marker, recursive = TRUE), add = TRUE)
  child <- callr::r_bg(function(sampler) {
    library(FBC)
    future::plan(future::multisession, workers = 2)
    options(FBC.sampler = sampler)
    set.seed(1)
    warn <- character()
    fit <- withCallingHandlers(
      calibrate(ballSim, ballField, nMCMC = 1e6, nBurn = 100, nChains = 2),
      warning = function(w) {
        warn <<- c(warn, conditionMessage(w))
        invokeRestart("muffleWarning")
      }
    )
    options(FBC.sampler = NULL)
    t0 <- proc.time()[["elapsed"]]
    again <- calibrate(ballSim, ballField, nMCMC = 200, nBurn = 100, nChains = 2)
    list(fit = fit, warn = warn, again = nrow(again$Phi),
         wait = proc.time()[["elapsed"]] - t0)
  }, args = list(sampler = slow_sampler(0, marker)))
  on.exit(child$kill(), add = TRUE)
  # both workers have run some pieces past burn-in
  wait_until(function() {
    calls <- sampler_calls(marker)
    length(calls) == 2 && all(calls >= 5)
  }, child, state = function() {
    calls <- sampler_calls(marker)
    sprintf("calls by process: %s", paste(names(calls), calls, sep = ": ", collapse = ", "))
  })
  # SIGINT to the session and its workers at once, as Ctrl-C in a terminal
  # does (the workers are in the session's process group)
  workers <- as.integer(names(sampler_calls(marker)))
  tools::pskill(c(child$get_pid(), workers), tools::SIGINT)
  child$wait(120000)
  res <- child$get_result()
  expect_match(paste(res$warn, collapse = "\n"), "Interrupted: chains 1 and 2 stopped")
  expect_true(res$fit$state$interrupted)
  expect_setequal(unique(res$fit$chain), 1:2)
  expect_true(all(is.finite(res$fit$Phi)))
  # the next run did not wait for chains of a million sweeps
  expect_equal(res$again, 100)
  expect_lt(res$wait, 60)
})

test_that("process_alive() sees a running process, and a killed one as gone even unreaped", {
  skip_on_os("windows")
  expect_true(FBC:::process_alive(Sys.getpid()))
  # a background sleep whose shell has exited: its parent is now PID 1, which
  # in a container may never reap it, leaving a zombie after the kill
  pid <- as.integer(system("sleep 30 >/dev/null 2>&1 & echo $!", intern = TRUE))
  on.exit(tools::pskill(pid, tools::SIGKILL), add = TRUE)
  expect_true(FBC:::process_alive(pid))
  tools::pskill(pid, tools::SIGKILL)
  t0 <- Sys.time()
  while (FBC:::process_alive(pid) && Sys.time() - t0 < 5) Sys.sleep(0.05)
  expect_false(FBC:::process_alive(pid))
})

test_that("multisession: a second Ctrl-C kills the workers and keeps the checkpoints", {
  skip_if_not_slow()
  skip_on_cran()
  skip_if_not_installed("callr")
  dir <- tempfile("ck-")
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  # after 12 quick pieces, each piece takes a minute: a stop request is not
  # seen in time
  sampler <- function(...) {
    n <<- n + 1L
    Sys.sleep(if (n > 12L) 60 else 0.01)
    FBC:::.fbc_sample(...)
  }
  environment(sampler) <- list2env(list(n = 0L), parent = globalenv())
  child <- callr::r_bg(function(dir, sampler) {
    library(FBC)
    future::plan(future::multisession, workers = 2)
    options(FBC.sampler = sampler)
    set.seed(1)
    warn <- character()
    fit <- withCallingHandlers(
      calibrate(ballSim, ballField, nMCMC = 1e5, nBurn = 100, nChains = 2,
                checkpoint = dir, checkpointEvery = 0),
      warning = function(w) {
        warn <<- c(warn, conditionMessage(w))
        invokeRestart("muffleWarning")
      }
    )
    options(FBC.sampler = NULL)
    again <- calibrate(ballSim, ballField, nMCMC = 200, nBurn = 100, nChains = 2)
    list(fit = fit, warn = warn, again = nrow(again$Phi))
  }, args = list(dir = dir, sampler = sampler))
  on.exit(child$kill(), add = TRUE)
  wait_until(function() ck_iter(dir, 1) >= 600 && ck_iter(dir, 2) >= 600 &&
               all(file.exists(file.path(dir, c("chain-1.pid", "chain-2.pid")))), child)
  pids <- vapply(1:2, function(k) as.integer(readLines(file.path(dir, sprintf("chain-%d.pid", k)))[1]),
                 integer(1))
  child$interrupt()
  wait_until(function() file.exists(file.path(dir, "STOP")), child)
  Sys.sleep(0.5)
  child$interrupt()
  child$wait(60000)
  expect_false(child$is_alive())
  res <- child$get_result()
  expect_equal(sum(res$fit$chain == 1), (ck_iter(dir, 1) - 100) / 2)
  expect_setequal(unique(res$fit$chain), 1:2)
  expect_equal(res$again, 100)
  # the killed workers are gone (or zombies nobody reaps)
  expect_false(any(vapply(pids, FBC:::process_alive, logical(1))))
})

test_that("a mismatched or corrupt checkpoint is refused and nothing is overwritten", {
  dir <- tempfile("ck-")
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  args <- list(nMCMC = 200, nBurn = 100, thinning = 2, nChains = 2)
  set.seed(1)
  fit <- do.call(calibrate, c(list(ballSim, ballField, checkpoint = dir), args))
  md5 <- dir_md5(dir)
  hide <- function(x) gsub(dir, "<dir>", x, fixed = TRUE)
  field2 <- ballField
  field2[1, 1] <- field2[1, 1] + 0.01
  expect_snapshot(error = TRUE, transform = hide, {
    do.call(calibrate, c(list(ballSim, field2, checkpoint = dir), args))
  })
  expect_snapshot(error = TRUE, transform = hide, {
    calibrate(ballSim, ballField, nMCMC = 300, nBurn = 50, thinning = 2, nChains = 2,
              kappaP1 = 2, checkpoint = dir)
  })
  # another correlation family is another run
  expect_snapshot(error = TRUE, transform = hide, {
    do.call(calibrate, c(list(ballSim, ballField, checkpoint = dir, kernelS = "powexp"), args))
  })
  expect_identical(dir_md5(dir), md5)
  # so is another discrepancy model
  expect_snapshot(error = TRUE, transform = hide, {
    do.call(calibrate, c(list(ballSim, ballField, checkpoint = dir, discrepancy = "none"), args))
  })
  expect_identical(dir_md5(dir), md5)
  # a truncated chain file
  f <- file.path(dir, "chain-2.rds")
  writeBin(readBin(f, "raw", 100), f)
  md5 <- dir_md5(dir)
  expect_snapshot(error = TRUE, transform = hide, {
    do.call(calibrate, c(list(ballSim, ballField, checkpoint = dir), args))
  })
  expect_identical(dir_md5(dir), md5)
  # deleting it reruns chain 2 from its start: the same draws
  unlink(f)
  expect_message(again <- do.call(calibrate, c(list(ballSim, ballField, checkpoint = dir), args)),
                 "iterations 200 and 0")
  expect_identical(again$Phi, fit$Phi)
  # a corrupt run file
  writeLines("not a checkpoint", file.path(dir, "run.rds"))
  expect_snapshot(error = TRUE, transform = hide, {
    do.call(calibrate, c(list(ballSim, ballField, checkpoint = dir), args))
  })
  # a directory that is not a checkpoint
  other <- tempfile("other-")
  dir.create(other)
  on.exit(unlink(other, recursive = TRUE), add = TRUE)
  writeLines("mine", file.path(other, "notes.txt"))
  expect_snapshot(error = TRUE, transform = function(x) gsub(other, "<dir>", x, fixed = TRUE), {
    calibrate(ballSim, ballField, nMCMC = 200, nBurn = 100, checkpoint = other)
  })
  expect_identical(list.files(other), "notes.txt")
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, checkpointEvery = -1))
  expect_snapshot(error = TRUE, calibrate(ballSim, ballField, checkpoint = c("a", "b")))
})

test_that("batchtools_local gives the draws of the sequential plan", {
  skip_on_cran()
  skip_if_not_installed("future.batchtools")
  args <- list(nMCMC = 200, nBurn = 100, thinning = 2, nChains = 2)
  set.seed(5)
  seq <- do.call(calibrate, c(list(ballSim, ballField), args))
  # batchtools keeps its registries under future.cache.path (not here)
  opts <- options(future.cache.path = file.path(tempdir(), "future-cache"))
  on.exit(options(opts), add = TRUE)
  old <- future::plan(future.batchtools::batchtools_local)
  on.exit(future::plan(old), add = TRUE)
  dir <- tempfile("ck-")
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  set.seed(5)
  bt <- do.call(calibrate, c(list(ballSim, ballField, checkpoint = dir), args))
  expect_same_draws(bt, seq)
  expect_true(all(file.exists(file.path(dir, c("chain-1.rds", "chain-2.rds")))))
})

test_that("progress comes from every worker under multisession, and only when asked", {
  skip_on_cran()
  old <- future::plan(future::multisession, workers = 2)
  on.exit(future::plan(old), add = TRUE)
  got <- list()
  record <- function(c) {
    if (!is.null(c$fbcChain)) got[[length(got) + 1L]] <<- c[c("fbcChain", "fbcDone", "fbcAcceptance", "fbcBurn")]
  }
  set.seed(2)
  withCallingHandlers(
    suppressMessages(  # the bar itself
      fit <- calibrate(ballSim, ballField, nMCMC = 600, nBurn = 300, nChains = 2, showProgress = TRUE)
    ),
    progression = record
  )
  chains <- vapply(got, `[[`, integer(1), "fbcChain")
  expect_setequal(chains, 1:2)
  for (k in 1:2) {
    done <- vapply(got[chains == k], `[[`, numeric(1), "fbcDone")
    expect_false(is.unsorted(done))
    expect_equal(max(done), 600)
    # the last report carries the chain's acceptance after burn-in
    last <- got[chains == k][[length(done)]]
    expect_false(last$fbcBurn)
    acc <- fit$state$chains[[k]]$acceptance
    expect_equal(last$fbcAcceptance, mean(acc, na.rm = TRUE))
  }
  got <- list()
  set.seed(2)
  expect_silent(withCallingHandlers(
    calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, nChains = 2),
    progression = record
  ))
  expect_length(got, 0)
})

test_that("the sequential progress bar follows all chains to the end", {
  # cli's logger handler writes the bar's states as lines (the drawn bar
  # depends on timing)
  old <- options(cli.progress_handlers_only = "logger")
  on.exit(options(old), add = TRUE)
  set.seed(2)
  out <- capture_output(suppressMessages(
    calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, nChains = 2, showProgress = TRUE)
  ))
  expect_match(out, "0/600 created")
  expect_match(out, "600/600 terminated")
  expect_silent(calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, nChains = 2))
})

test_that("a run with another correlation family checkpoints and comes back with its columns", {
  dir <- tempfile("ck-")
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  args <- list(ballSim, ballField, nMCMC = 120, nBurn = 60, thinning = 2, nChains = 2,
               kernelS = "matern32", checkpoint = dir)
  set.seed(4)
  fit <- do.call(calibrate, args)
  expect_false("alphaS1" %in% colnames(fit$Phi))
  # the finished run's directory gives the fit back, kernels and all
  expect_message(again <- do.call(calibrate, args), "Resuming")
  expect_identical(again$Phi, fit$Phi)
  expect_identical(again$model$kernelS, "matern32")
  # the default kernels are not written into the fingerprint, so
  # checkpoints written before the kernels existed still match
  id <- FBC:::run_identity(ballSim, ballField, fit$model$spec,
                           list(nMCMC = 1, kernelS = "powexp", kernelB = "powexp"))
  expect_named(id$settings, "nMCMC")
})

test_that("a run without a discrepancy checkpoints, resumes, and is refused by a \"gp\" call", {
  dir <- tempfile("ck-")
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  args <- list(ballSim, ballField, nMCMC = 120, nBurn = 60, thinning = 2, nChains = 2,
               discrepancy = "none", checkpoint = dir)
  set.seed(4)
  fit <- do.call(calibrate, args)
  expect_false("sigma2B" %in% colnames(fit$Phi))
  expect_message(again <- do.call(calibrate, args), "Resuming")
  expect_identical(again$Phi, fit$Phi)
  expect_identical(again$model$discrepancy, "none")
  # the identity holds the discrepancy model when it is not the default;
  # the default is left out, so checkpoints written before it still match
  expect_identical(FBC:::run_identity(ballSim, ballField, fit$model$spec,
                                      list(nMCMC = 1, discrepancy = "none"))$settings,
                   list(nMCMC = 1, discrepancy = "none"))
  expect_named(FBC:::run_identity(ballSim, ballField, fit$model$spec,
                                  list(nMCMC = 1, discrepancy = "gp"))$settings, "nMCMC")
  args$discrepancy <- NULL
  expect_error(do.call(calibrate, args), "`discrepancy` differs: none in the checkpoint, gp now")
})

test_that("a run with outputs and a bias per data set resumes to the uninterrupted draws", {
  # two outputs (conc, rate) and two laboratories, B with its own bias
  set.seed(5)
  x <- runif(30); t <- runif(30, 0.5, 3)
  sim <- rbind(data.frame(y = 5 * exp(-t * x), x = x, out = "conc", t = t),
               data.frame(y = 2 * t * x, x = x, out = "rate", t = t))
  xf <- seq(0.1, 0.9, length.out = 6)
  field <- rbind(data.frame(y = 5 * exp(-1.7 * xf) + rnorm(6, 0, 0.05), x = xf, out = "conc", lab = "A"),
                 data.frame(y = 3.4 * xf + rnorm(6, 0, 0.05), x = xf, out = "rate", lab = "A"),
                 data.frame(y = 5 * exp(-1.7 * xf) + 0.3 + rnorm(6, 0, 0.05), x = xf, out = "conc",
                            lab = "B"))
  args <- list(sim, field, output = "out", outputs = "shared", source = "lab", sourceBias = "own", nMCMC = 200,
               nBurn = 100, thinning = 2, nChains = 2, kernelS = "matern52", kernelB = "matern52")
  set.seed(6)
  ref <- do.call(calibrate, args)
  expect_true(all(c("rhoS1", "rhoB1", "rhoD1") %in% colnames(ref$Phi)))
  dir <- tempfile("ck-")
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  old <- options(FBC.sampler = interrupt_at_call(3))
  set.seed(6)
  # (posterior's note on the ESS of the 25 draws kept is not the point here)
  withCallingHandlers(
    expect_warning(part <- do.call(calibrate, c(args, checkpoint = dir)), "Resume it with the same"),
    warning = function(w) {
      if (grepl("ESS has been capped", conditionMessage(w))) invokeRestart("muffleWarning")
    })
  options(old)
  expect_true(part$state$interrupted)
  expect_message(fit <- do.call(calibrate, c(args, checkpoint = dir)), "Resuming")
  expect_same_draws(fit, ref)
  # the same data with one shared bias is another run
  args$sourceBias <- "shared"
  expect_error(do.call(calibrate, c(args, checkpoint = dir)), "checkpoint")
})

test_that("a checkpoint of other data sets (rows moved between sources) is refused naming the rows", {
  # the same field values, the same number of data sets, rows 1
  # and 7 swapped between laboratories: another model (other noise groups)
  set.seed(5)
  x <- runif(30); t <- runif(30, 0.5, 3)
  sim <- data.frame(y = 5 * exp(-t * x), x = x, t = t)
  xf <- seq(0.1, 0.9, length.out = 6)
  field <- data.frame(y = 5 * exp(-1.7 * rep(xf, 2)) + rnorm(12, 0, 0.05), x = rep(xf, 2),
                      lab = rep(c("A", "B"), each = 6))
  dir <- tempfile("ck-")
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  hide <- function(x) gsub(dir, "<dir>", x, fixed = TRUE)
  args <- list(sim, source = "lab", nMCMC = 100, nBurn = 50, nChains = 1, checkpoint = dir)
  set.seed(1)
  fit <- do.call(calibrate, c(list(field = field), args))
  md5 <- dir_md5(dir)
  moved <- field
  moved$lab[c(1, 7)] <- c("B", "A")
  expect_snapshot(error = TRUE, transform = hide, do.call(calibrate, c(list(field = moved), args)))
  # with a bias per data set, both the noise groups and the biases differ
  expect_snapshot(error = TRUE, transform = hide,
                  do.call(calibrate, c(list(field = moved, sourceBias = "own"), args)))
  expect_identical(dir_md5(dir), md5)
  # the rule's settings are shown, not "another value"
  expect_snapshot(error = TRUE, transform = hide,
                  do.call(calibrate, c(list(field = field, converge = TRUE), args)))
  # the same data resumes (relabelling the data sets is the same model)
  relabel <- field
  relabel$lab <- ifelse(field$lab == "A", "lab1", "lab2")
  expect_message(again <- do.call(calibrate, c(list(field = relabel), args)),
                 "iteration 100 of 100")
  expect_identical(again$Phi, fit$Phi)
})

test_that("a resumed run under converge says where it stops", {
  dir <- tempfile("ck-")
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  starts <- list(list(state = list(iter = 4750L)), list(state = list(iter = 3000L)))
  rule <- until_converged(maxMCMC = 20000)
  expect_snapshot(FBC:::inform_resumed("<dir>", starts, 1500, rule))
  expect_snapshot(FBC:::inform_resumed("<dir>", starts[1], 1500))
})
