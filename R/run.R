# Running the chains: each chain one future (any future::plan()), in pieces,
# with checkpoints (R/checkpoint.R), clean interrupts and progress.
#
# A chain runs in pieces that end at multiples of `fbc_piece` sweeps
# (counted from the chain's start), whatever the plan, the checkpoint
# interval or the interruptions. Each piece is one call of the compiled
# sampler, which takes the chain's whole state in and gives it back, and
# draws from R's RNG; so a chain continued from the state and the RNG state
# saved at a piece boundary makes exactly the draws it would have made
# without stopping. (The boundaries must not move: the sampler recomputes
# its cached factors from scratch at the start of a call, and a factor
# updated in closed form over many sweeps differs from a fresh one in the
# last bits.)

fbc_piece <- 50L

# One L'Ecuyer-CMRG stream per chain: streams 1..n after a seed made from one
# integer drawn from the session's RNG (which is left advanced by that draw,
# so consecutive calls differ and set.seed() reproduces a call).
chain_seeds <- function(n) {
  s <- sample.int(.Machine$integer.max, 1L)
  genv <- globalenv()
  old <- genv$.Random.seed
  on.exit(assign(".Random.seed", old, envir = genv))
  set.seed(s, kind = "L'Ecuyer-CMRG")
  seed <- genv$.Random.seed
  out <- vector("list", n)
  for (k in seq_len(n)) {
    seed <- parallel::nextRNGStream(seed)
    out[[k]] <- seed
  }
  out
}

# Where chain k starts this call: its sampler state, the iteration its run
# (calibrate() or update()) started at, and what it has kept since then.
chain_start <- function(state, d, iter0 = state$iter) {
  list(state = state, iter0 = as.integer(iter0), draws = matrix(0, 0, d),
       logPost = numeric(), logLik = numeric(), nPost = 0L, finished = FALSE)
}

# A chain's burn-in (warm-up) length: `nBurn` when fixed; for a warm-up of
# data-dependent length (`nBurn` its bounds, list(min, max)) the length it
# ended at, NA while it goes on.
chain_burn <- function(state, nBurn) {
  if (!is.list(nBurn)) return(nBurn)
  w <- state$warmup
  if (is.null(w) || w <= 0) NA_real_ else as.numeric(w)
}

# Where a chain stops: at `target`, or `post` sweeps after its warm-up
# (post not NA/NULL) when that comes first (not known while it warms up).
chain_stop <- function(state, target, post, nBurn) {
  if (is.null(post) || is.na(post)) return(as.integer(target))
  w <- chain_burn(state, nBurn)
  as.integer(if (is.na(w)) target else min(target, w + post))
}

# Number of draws kept over iterations (from, to] (see src/sampler.cpp).
kept_between <- function(from, to, nBurn, thinning) {
  k <- function(it) if (it > nBurn) (it - nBurn) %/% thinning else 0L
  as.integer(k(to) - k(from))
}

# A run directory of its own for a call under a parallel plan without
# `checkpoint`: workers on this machine see it (stop file, checkpoints for
# Ctrl-C); remote workers do not, and run without it.
temp_run <- function(every) {
  dir <- tempfile("fbc-run-")
  dir.create(dir)
  list(dir = dir, id = basename(dir), every = every, user = FALSE, resumed = FALSE)
}

# A chain's result (as the compiled sampler returns one) from its checkpoint
# (its acceptance: the moves' counts in its state; a checkpoint's accSum and
# scaleAccSum, from before, are not read).
result_from_start <- function(start, interrupted) {
  list(draws = start$draws, logPost = start$logPost, logLik = start$logLik,
       kept = nrow(start$draws),
       done = start$state$iter - start$iter0, nPost = start$nPost,
       interrupted = interrupted, state = start$state)
}

# Runs chain k from `start` to iteration `job$target[k]` in pieces (see the
# top); evaluated by a future, on any backend. Between pieces: saves a
# checkpoint when `job$every` seconds have passed (and at the end), reports
# progress, and stops early when the main session asks (STOP file), when
# the main session is gone (same host), or on an interrupt in this process.
# Returns the chain's result over its whole run (from start$iter0).
run_chain <- function(job, k, start) {
  cx <- chain_context(job, k)
  if (!is.null(cx$pidFile)) on.exit(unlink(cx$pidFile), add = TRUE)
  genv <- globalenv()
  d <- length(start$state$phi)
  stopAt <- function(state) chain_stop(state, job$target[k], job$post[k], job$nBurn)
  # room for every draw the run can keep (see chain_room()); `cur` is
  # replaced whole after each piece, so an interrupt at any point leaves the
  # last consistent piece boundary
  n0 <- nrow(start$draws)
  nAll <- chain_room(start, job, stopAt)
  draws <- matrix(NA_real_, nAll, d)
  logPost <- logLik <- rep(NA_real_, nAll)
  if (n0) {
    draws[seq_len(n0), ] <- start$draws
    logPost[seq_len(n0)] <- start$logPost
    logLik[seq_len(n0)] <- start$logLik
  }
  cur <- list(state = start$state, kept = n0, nPost = start$nPost, seed = genv$.Random.seed)
  snapshot <- function() {
    kept <- seq_len(cur$kept)
    list(state = cur$state, iter0 = start$iter0,
         draws = draws[kept, , drop = FALSE], logPost = logPost[kept], logLik = logLik[kept],
         nPost = cur$nPost,
         finished = cur$state$iter >= stopAt(cur$state))
  }
  status <- "done"
  status <- tryCatch({
    repeat {
      # a Ctrl-C that reached this process (a terminal sends it to the
      # workers too) while no R code checked for it stays pending until
      # something does; Sys.sleep() does, here, inside the handler, rather
      # than later in the future's own code, which would lose the result
      Sys.sleep(0.001)
      it <- cur$state$iter
      stop <- stopAt(cur$state)
      if (it >= stop) break
      if (chain_stop_asked(cx)) { status <- "stopped"; break }
      n <- min(stop, (it %/% fbc_piece + 1L) * fbc_piece) - it
      assign(".Random.seed", cur$seed, envir = genv)
      r <- sample_chain(job$dat, job$spec, cur$state, job$moves, n, job$nBurn,
                        job$thinning, FALSE, sampler = job$sampler)
      if (r$kept > 0) {  # (nAll is an upper bound: never past the end)
        idx <- cur$kept + seq_len(r$kept)
        draws[idx, ] <- r$draws[seq_len(r$kept), , drop = FALSE]
        logPost[idx] <- r$logPost[seq_len(r$kept)]
        logLik[idx] <- r$logLik[seq_len(r$kept)]
      }
      cur <- merge_piece(cur, r, genv$.Random.seed)
      if (isTRUE(r$interrupted)) { status <- "interrupted"; break }
      if (chain_save_due(cx) && cur$state$iter < stopAt(cur$state)) save_chain(cx, snapshot(), cur$seed)
      chain_tick(cx, cur)
    }
    status
  }, interrupt = function(e) "interrupted")
  if (status == "interrupted") fbc_run$stop <- TRUE
  if (cx$files) save_chain(cx, snapshot(), cur$seed)
  chain_tick(cx, cur, force = TRUE)
  res <- result_from_start(snapshot(), interrupted = status != "done")
  res$status <- status
  # where its stream stands: a further round continues it (run_rounds())
  res$seed <- cur$seed
  res
}

# What chain k's run needs besides its draws: whether the run directory is
# visible here (else an error when the user gave it), its pid file (written
# here: the main session kills a worker by it), whether the main session
# runs on this host (then its death stops the chain), and the times of the
# last checkpoint and progress report.
chain_context <- function(job, k) {
  dir <- job$dir
  files <- !is.null(dir) && dir.exists(dir)
  host <- Sys.info()[["nodename"]]
  if (!is.null(dir) && !files && job$user) {
    stop(sprintf("the checkpoint directory %s is not visible from the worker on %s: put it on storage the workers share",
                 dir, host), call. = FALSE)
  }
  cx <- new.env(parent = emptyenv())
  cx$job <- job
  cx$k <- k
  cx$files <- files
  cx$host <- host
  cx$pidFile <- if (files) chain_file(dir, k, "pid")
  if (files) writeLines(c(as.character(Sys.getpid()), host, job$token), cx$pidFile)
  cx$ownerHere <- identical(host, job$owner$host) && job$owner$pid != Sys.getpid()
  cx$lastSave <- cx$lastTick <- proc.time()[["elapsed"]]
  cx
}

# Rows a chain's draws need: what it has, or what it can keep up to where
# it stops (a chain resumed beyond this call's target, a later round of a
# run under until_converged(), keeps what it has; while a warm-up of
# data-dependent length goes on, room for the most it can keep).
chain_room <- function(start, job, stopAt) {
  burn <- chain_burn(start$state, job$nBurn)
  if (is.na(burn)) burn <- start$state$iter
  max(nrow(start$draws), kept_between(start$iter0, stopAt(start$state), burn, job$thinning))
}

# The chain's bookkeeping after piece `r` of the compiled sampler: its state,
# draws kept, retained sweeps, and RNG state `seed` (acceptance: the moves'
# counts in the state).
merge_piece <- function(cur, r, seed) {
  list(state = r$state, kept = cur$kept + r$kept,
       nPost = cur$nPost + r$nPost, seed = seed)
}

# Has the main session asked chain cx$k to stop (STOP file), or gone away?
chain_stop_asked <- function(cx) {
  (cx$files && file.exists(file.path(cx$job$dir, "STOP"))) ||
    (cx$ownerHere && !process_alive(cx$job$owner$pid))
}

# Is a checkpoint due (job$every seconds since the last)? Then the clock
# restarts.
chain_save_due <- function(cx) {
  now <- proc.time()[["elapsed"]]
  if (!cx$files || now - cx$lastSave < cx$job$every) return(FALSE)
  cx$lastSave <- now
  TRUE
}

# Writes chain cx$k's checkpoint: its start for a resumed run and RNG state.
save_chain <- function(cx, start, seed) {
  write_atomic(list(format = fbc_checkpoint_format, id = cx$job$id, chain = cx$k,
                    start = start, seed = seed, host = cx$host,
                    pid = Sys.getpid(), time = Sys.time()), chain_file(cx$job$dir, cx$k))
}

# Reports chain cx$k's progress (at most every 0.25 s unless `force`).
chain_tick <- function(cx, cur, force = FALSE) {
  job <- cx$job
  k <- cx$k
  if (is.null(job$progress)) return(invisible())
  now <- proc.time()[["elapsed"]]
  if (!force && now - cx$lastTick < 0.25) return(invisible())
  cx$lastTick <- now
  acc <- if (cur$nPost > 0) mean(move_acceptance(cur$state$moves, job$moves$params), na.rm = TRUE) else NA_real_
  job$progress(amount = 0, fbcChain = k, fbcDone = cur$state$iter - job$from[k],
               fbcAcceptance = acc, fbcBurn = in_warmup(cur$state, job$nBurn),
               fbcTotal = expected_stop(cur$state, job$target[k], job$post[k], job$nBurn) - job$from[k])
}

# Is the current plan one that evaluates futures in this process?
plan_is_sequential <- function() {
  inherits(future::plan("next"), c("sequential", "uniprocess"))
}

free_workers <- function() {
  tryCatch(future::nbrOfFreeWorkers(), error = function(e) Inf)
}

# Runs chain k of `starts` (see chain_start()) to iteration `target[k]`, one
# future per chain with chain k's random stream `seeds[[k]]`, on whatever
# plan is set. `run` is the run directory (open_checkpoint(), temp_run())
# or NULL. Returns the list of chain results (NULL for a chain that never
# started after an interrupt).
#
# Ctrl-C in the main session: the workers are asked to stop (STOP file) and
# their results collected, so they return their draws and the session stays
# in step with its workers; a second Ctrl-C (or a worker that cannot be
# reached) kills this run's worker processes on this machine and restarts
# the plan's workers, and the chains come back as far as their checkpoints.
run_chains <- function(dat, spec, starts, seeds, moves, target, nBurn, thinning,
                       showProgress, run = NULL, every = 60, post = NULL, stretch = FALSE) {
  n <- length(starts)
  sequential <- plan_is_sequential()
  if (is.null(run) && !sequential) {
    run <- temp_run(every)
    on.exit(unlink(run$dir, recursive = TRUE), add = TRUE)
  }
  fbc_run$stop <- FALSE
  on.exit(fbc_run$stop <- FALSE, add = TRUE)
  if (!is.null(run)) {
    unlink(file.path(run$dir, "STOP"))
    unlink(list.files(run$dir, pattern = "^chain-[0-9]+[.]pid$", full.names = TRUE))
  }
  target <- rep_len(as.integer(target), n)
  job <- list(dat = dat, spec = list(table = spec$table, model = spec$model), moves = moves, nBurn = nBurn,
              thinning = thinning, target = target, post = post,
              from = vapply(starts, function(s) as.integer(s$state$iter), integer(1)),
              dir = run$dir, every = run$every %||% every, id = run$id, user = isTRUE(run$user),
              token = basename(tempfile("")), sampler = fbc_sampler_hook(),
              owner = list(pid = Sys.getpid(), host = Sys.info()[["nodename"]]),
              progress = NULL, stretch = stretch)
  todo <- which(!vapply(starts, function(s) isTRUE(s$finished), logical(1)))
  bar <- NULL
  if (showProgress && length(todo)) {
    bar <- chain_progress(job, starts)
    job$progress <- bar$progressor
  }
  # the run's shared state: the futures launched, the results collected
  # (a finished chain's at once), the chains whose worker died or failed,
  # and what an interrupt needs to know (the chain being launched)
  rs <- new.env(parent = emptyenv())
  rs$futures <- vector("list", n)
  rs$results <- vector("list", n)
  for (k in setdiff(seq_len(n), todo)) {
    rs$results[[k]] <- result_from_start(starts[[k]], FALSE)
    rs$results[[k]]$seed <- seeds[[k]]
  }
  rs$failed <- integer()
  rs$errors <- list()
  rs$launching <- 0L
  interrupted <- dirty <- FALSE
  tryCatch(withCallingHandlers({
    for (k in todo) {
      if (isTRUE(fbc_run$stop)) break
      if (sequential) {
        run_chain_here(rs, job, k, starts[[k]], seeds[[k]])
        next
      }
      while (free_workers() < 1) {
        collect_chains(rs)
        Sys.sleep(0.05)
      }
      launch_chain(rs, job, k, starts[[k]], seeds[[k]])
      collect_chains(rs)
      if (length(rs$errors)) break
    }
    while (!length(rs$errors) && !collect_chains(rs)) Sys.sleep(0.05)
  }, progression = progress_handler(bar)), interrupt = function(e) {
    interrupted <<- TRUE
    dirty <<- rs$launching > 0L
  })
  hard <- FALSE
  if (interrupted || length(rs$errors)) {
    hard <- withCallingHandlers(
      stop_chains(run, function() collect_chains(rs), sequential, quiet = !interrupted),
      progression = progress_handler(NULL, all = TRUE)
    )
  }
  if (!is.null(bar)) bar$done()
  if (length(rs$errors)) stop(rs$errors[[1]])
  # a dead worker's connection, or one a Ctrl-C cut short, is useless
  if ((length(rs$failed) || dirty) && !hard) reset_plan()
  recover_chains(waiting_chains(rs$results, rs$futures, rs$failed, todo, starts, seeds),
                 rs$failed, run, starts)
}

# The chains of `todo` an interrupt left waiting for their turn (never
# launched in this call): each as far as its start, that is with the draws
# of its earlier stretches (a later stretch of a run under
# until_converged()), marked interrupted (status "waiting").
waiting_chains <- function(results, futures, failed, todo, starts, seeds) {
  for (k in todo) {
    if (!is.null(results[[k]]) || !is.null(futures[[k]]) || k %in% failed) next
    results[[k]] <- result_from_start(starts[[k]], interrupted = TRUE)
    results[[k]]$status <- "waiting"
    results[[k]]$seed <- seeds[[k]]
  }
  results
}

# The bar's format: under a rule (`stretch`) the bar and its ETA are those
# of the stretch under way, to the next check, not of the whole run.
progress_format <- function(stretch) {
  sprintf("{cli::pb_name} {cli::pb_bar} {cli::pb_percent} | ETA%s: {cli::pb_eta} | {cli::pb_status}",
          if (stretch) " (this stretch, to the next check)" else "")
}

# The bar's status: each chain's acceptance, "warm-up" for a chain in its
# warm-up, "waiting" for one that has not started (its turn not come: the
# sequential plan, or fewer workers than chains).
progress_status <- function(started, burn, acc) {
  a <- ifelse(!started, "waiting", ifelse(burn, "warm-up", ifelse(is.na(acc), "-", sprintf("%.2f", acc))))
  paste("chains:", paste(a, collapse = " "))
}

# The progress bar of a run's chains (the run's size said first with
# several chains) and the progressor the chains report to.
chain_progress <- function(job, starts) {
  n <- length(starts)
  target <- job$target
  post <- job$post
  if (n > 1L) {
    workers <- future::nbrOfWorkers()
    if (is.null(post)) {
      cli::cli_inform("Running {n} chain{?s} of {max(target)} iterations on {workers} worker{?s}.")
    } else {
      cli::cli_inform("Running {n} chain{?s} to {post[1]} sweeps after warm-up on {workers} worker{?s}.")
    }
  }
  total <- vapply(seq_len(n), function(k) {
    expected_stop(starts[[k]]$state, target[k], post[k], job$nBurn)
  }, numeric(1)) - job$from
  bar <- progress_bar(n, total, job$nBurn, isTRUE(job$stretch), .envir = parent.frame())
  bar$progressor <- progressr::progressor(steps = sum(total), enable = TRUE,
                                          initiate = FALSE, auto_finish = FALSE, on_exit = FALSE)
  bar
}

# Launches chain k as a future with its own stream. Not with interrupts
# suspended: launching waits for the worker to answer, and a Ctrl-C must
# always get through; a launch cut short by Ctrl-C may leave that worker out
# of step (rs$launching says which), so the plan is restarted.
launch_chain <- function(rs, job, k, start, seed) {
  expr <- bquote(.(run_chain)(job, .(k), start))
  rs$launching <- k
  rs$futures[[k]] <- future::future(expr, substitute = FALSE, seed = seed, packages = "FBC",
                                    globals = list(job = job, start = start),
                                    label = sprintf("FBC chain %d", k))
  rs$launching <- 0L
}

# The sequential plan runs chain k here, without a future, with its own
# stream; the session's RNG state is left as it was.
run_chain_here <- function(rs, job, k, start, seed) {
  genv <- globalenv()
  old <- genv$.Random.seed
  on.exit(assign(".Random.seed", old, envir = genv))
  assign(".Random.seed", seed, envir = genv)
  rs$results[[k]] <- run_chain(job, k, start)
}

# Collects the futures that are resolved into rs$results (a worker that
# died or a chain that failed into rs$failed, its error into rs$errors);
# TRUE when every launched chain is in.
collect_chains <- function(rs) {
  for (k in which(!vapply(rs$futures, is.null, logical(1)))) {
    if (!is.null(rs$results[[k]]) || k %in% rs$failed) next
    f <- rs$futures[[k]]
    res <- suspendInterrupts(tryCatch(
      if (future::resolved(f)) list(value = future::value(f)) else NULL,
      FutureError = function(e) list(died = e),
      error = function(e) list(error = e)
    ))
    if (is.null(res)) next
    if (!is.null(res$died)) {
      rs$failed <- c(rs$failed, k)
    } else if (!is.null(res$error)) {
      rs$failed <- c(rs$failed, k)
      rs$errors[[length(rs$errors) + 1L]] <- res$error
    } else {
      rs$results[[k]] <- res$value
    }
  }
  launched <- which(!vapply(rs$futures, is.null, logical(1)))
  all(!vapply(rs$results[launched], is.null, logical(1)) | launched %in% rs$failed)
}

# The handler of the workers' progress conditions: the bar (NULL: none)
# shows the chains', which go no further; `all`: every progression is
# muffled, the chains' or not (while stopping).
progress_handler <- function(bar, all = FALSE) {
  function(c) {
    if (!all && is.null(c$fbcChain)) return()
    if (!is.null(bar)) bar$update(c$fbcChain, c$fbcDone, c$fbcAcceptance, c$fbcBurn, c$fbcTotal)
    if (!is.null(findRestart("muffleProgression", c))) invokeRestart("muffleProgression")
  }
}

# A chain whose worker died, or that an interrupt cut short, comes back as
# far as its checkpoint in the run's directory (else from its start,
# marked as died).
recover_chains <- function(results, failed, run, starts) {
  for (k in seq_along(results)) {
    if (!is.null(results[[k]])) next
    f <- if (!is.null(run)) chain_file(run$dir, k)
    if (!is.null(f) && file.exists(f)) {
      ck <- tryCatch(readRDS(f), error = function(e) NULL)
      if (is.list(ck) && identical(ck$id, run$id)) {
        results[[k]] <- result_from_start(ck$start, interrupted = TRUE)
        results[[k]]$status <- if (k %in% failed) "died" else "interrupted"
      }
    }
    if (is.null(results[[k]]) && k %in% failed) {
      results[[k]] <- result_from_start(starts[[k]], interrupted = TRUE)
      results[[k]]$status <- "died"
    }
  }
  results
}

# After Ctrl-C: ask the workers to stop at their next piece and collect
# them; on a second Ctrl-C, kill this run's workers on this machine and
# restart the plan's workers (returns TRUE then).
stop_chains <- function(run, collect, sequential, quiet = FALSE) {
  if (sequential) return(FALSE)
  if (!is.null(run)) file.create(file.path(run$dir, "STOP"))
  if (!quiet) {
    cli::cli_inform(c("!" = "Interrupted: stopping the chains at their next checkpoint (press Ctrl-C again to kill the workers)."))
  }
  hard <- FALSE
  tryCatch(
    while (!collect()) Sys.sleep(0.05),
    interrupt = function(e) hard <<- TRUE
  )
  if (hard) {
    kill_workers(run)
    reset_plan()
  }
  hard
}

# Is process `pid` of this machine running? Signal 0 tells whether it exists;
# a killed process whose parent has not reaped it (a worker reparented to a
# container's PID 1 that never reaps) still exists as a zombie, state "Z" in
# /proc/<pid>/stat, and counts as gone.
process_alive <- function(pid) {
  if (!isTRUE(tools::pskill(pid, 0L))) return(FALSE)
  stat <- tryCatch(readLines(file.path("/proc", pid, "stat"), n = 1L, warn = FALSE),
                   error = function(e) character(), warning = function(w) character())
  if (length(stat) == 0L) return(TRUE)
  # the state follows the command name, which is in parentheses
  !identical(sub("^.*\\) (\\S).*$", "\\1", stat), "Z")
}

# Kills the processes on this machine that run this call's chains.
kill_workers <- function(run) {
  if (is.null(run)) return(invisible())
  host <- Sys.info()[["nodename"]]
  for (f in list.files(run$dir, pattern = "^chain-[0-9]+[.]pid$", full.names = TRUE)) {
    x <- tryCatch(readLines(f, warn = FALSE), error = function(e) character())
    pid <- suppressWarnings(as.integer(x[1]))
    if (length(x) >= 2L && !is.na(pid) && identical(x[2], host) && pid != Sys.getpid()) {
      tools::pskill(pid, tools::SIGKILL)
    }
  }
  invisible()
}

# Restarts the workers of the current plan (after a worker died or was
# killed, its connection is useless): setting the same plan again stops
# the old workers and launches new ones.
reset_plan <- function() {
  if (plan_is_sequential()) return(invisible())
  stack <- future::plan("list")
  tryCatch(suppressWarnings(future::plan(stack, substitute = FALSE, .skip = FALSE)),
           error = function(e) cli::cli_warn(c(
             "Could not restart the future plan's workers: {conditionMessage(e)}",
             i = "Call {.code future::plan()} again before the next run."
           )))
  invisible()
}

# Is the chain in its burn-in (warm-up)?
in_warmup <- function(state, nBurn) {
  w <- chain_burn(state, nBurn)
  is.na(w) || state$iter <= w
}

# Where a chain is expected to stop, for the progress bar: chain_stop(), with
# a warm-up still going on counted as ending where it is now or at its
# minimum.
expected_stop <- function(state, target, post, nBurn) {
  if (is.null(post) || is.na(post) || !is.na(chain_burn(state, nBurn))) {
    return(chain_stop(state, target, post, nBurn))
  }
  min(target, max(state$iter, nBurn$min) + post)
}

# One progress bar for all chains: sweeps done over all, time left and each
# chain's acceptance rate (mean over its parameters, after burn-in).
progress_bar <- function(n, total, nBurn, stretch = FALSE, .envir = parent.frame()) {
  done <- rep(0, n)
  totals <- rep_len(total, n)
  acc <- rep(NA_real_, n)
  burn <- rep(TRUE, n)
  started <- rep(FALSE, n)
  id <- cli::cli_progress_bar(
    name = "Calibrating", total = sum(total), clear = TRUE, auto_terminate = FALSE,
    .envir = .envir, format = progress_format(stretch)
  )
  status <- function() progress_status(started, burn, acc)
  list(
    update = function(k, d, a, b, tot = NULL) {
      done[k] <<- d
      acc[k] <<- a
      burn[k] <<- isTRUE(b)
      started[k] <<- TRUE
      # a run whose length depends on the warm-up: each chain's expected total
      if (!is.null(tot)) totals[k] <<- tot
      try(cli::cli_progress_update(id = id, set = sum(done), total = sum(totals),
                                   status = status(), .envir = .envir),
          silent = TRUE)
    },
    done = function() try(cli::cli_progress_done(id = id, .envir = .envir), silent = TRUE)
  )
}
