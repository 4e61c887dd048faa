# Helpers for the checkpoint tests (test-checkpoint.R).

# The run the kill-and-resume tests interrupt: two short chains of the ball
# data. The uninterrupted reference is computed once per test session.
ck_args <- list(nMCMC = 800, nBurn = 300, thinning = 2, nChains = 2)
ck_seed <- 21L
ck_reference <- local({
  fit <- NULL
  function() {
    if (is.null(fit)) {
      set.seed(ck_seed)
      fit <<- do.call(calibrate, c(list(ballSim, ballField), ck_args))
    }
    fit
  }
})

# A sampler that sleeps `pause` seconds before each piece (a call) and, when
# `marker` (a directory) is given, adds a line to the file there named by
# its process id: a run that is long in wall time but cheap in CPU, to be
# killed mid-way. Installed with options(FBC.sampler = ...); run_chains()
# hands it to the workers. One file per process: two workers appending to
# one file interleave their writes (cat() writes a line in pieces; seen
# here as lines "2412424125"), which made a third "process" appear.
slow_sampler <- function(pause, marker = NULL) {
  force(pause)
  force(marker)
  function(...) {
    if (!is.null(marker)) cat("piece\n", file = file.path(marker, Sys.getpid()), append = TRUE)
    if (pause > 0) Sys.sleep(pause)
    FBC:::.fbc_sample(...)
  }
}

# The calls of slow_sampler() so far, by process id (names), from its
# `marker` directory.
sampler_calls <- function(marker) {
  files <- list.files(marker)
  calls <- vapply(file.path(marker, files), function(f) length(readLines(f, warn = FALSE)), integer(1))
  stats::setNames(calls, files)
}

# A sampler that imitates a Ctrl-C caught by the compiled sampler at the end
# of its `m`-th call (the compiled sampler polls for Ctrl-C every 100
# sweeps, which are ends of pieces): that call's sweeps are kept and the
# result is flagged as interrupted.
interrupt_at_call <- function(m) {
  n <- 0L
  function(...) {
    n <<- n + 1L
    res <- FBC:::.fbc_sample(...)
    if (n == m) res$interrupted <- TRUE
    res
  }
}

# Polls `cond()` every 0.1 s until TRUE; fails the test (naming the
# condition, and with what `state()` returns, when given) after `timeout` s,
# or at once when the background R session `child` has ended without it
# (with the child's error output). The timeout is generous: a loaded
# machine can take long to start a session and its workers, and a passing
# run never waits for it.
wait_until <- function(cond, child = NULL, timeout = 300, state = NULL) {
  what <- paste(deparse(body(cond)), collapse = " ")
  t0 <- Sys.time()
  while (!isTRUE(tryCatch(suppressWarnings(cond()), error = function(e) FALSE))) {
    gone <- !is.null(child) && !child$is_alive()
    if (gone || as.numeric(Sys.time() - t0, units = "secs") > timeout) {
      why <- if (gone) {
        err <- tryCatch(child$read_all_error(), error = function(e) "")
        sprintf("the child session ended first (exit status %s): %s",
                format(child$get_exit_status()), substr(err, 1, 500))
      } else {
        sprintf("not met within %s s", format(timeout))
      }
      if (!is.null(state)) {
        why <- paste0(why, "; ", tryCatch(state(), error = function(e) conditionMessage(e)))
      }
      testthat::fail(sprintf("wait_until(%s): %s", substr(what, 1, 200), why))
      return(FALSE)
    }
    Sys.sleep(0.1)
  }
  TRUE
}

# The iteration chain k's checkpoint in `dir` has reached (0 when none).
ck_iter <- function(dir, k) {
  f <- file.path(dir, sprintf("chain-%d.rds", k))
  if (!file.exists(f)) return(0L)
  readRDS(f)$start$state$iter
}

# md5 sums of every file in a directory (to show nothing was rewritten).
dir_md5 <- function(dir) tools::md5sum(sort(list.files(dir, full.names = TRUE, all.files = TRUE, no.. = TRUE)))

expect_same_draws <- function(fit, ref) {
  expect_identical(fit$Phi, ref$Phi)
  expect_identical(fit$chain, ref$chain)
  expect_identical(fit$logPost, ref$logPost)
  expect_identical(fit$logLik, ref$logLik)
  expect_equal(fit$acceptance, ref$acceptance)
  for (k in seq_along(ref$state$chains)) {
    expect_identical(fit$state$chains[[k]]$sampler, ref$state$chains[[k]]$sampler)
  }
}
