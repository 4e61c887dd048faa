# Runs that stop when converged: the rule (until_converged()), its check,
# and the rounds calibrate() and update() run under it.
#
# A run under a rule is one run of every chain, stopped at a data-dependent
# length: the chains go to their first target (nMCMC sweeps, or, without
# nMCMC, the end of their warm-up plus fbc_first_check sweeps), then, while
# the draws do not meet the rule and the ceiling is not reached, further:
# the retained-phase sweeps of each chain grow by `every`, or (every =
# NULL) to where the draws so far predict the rule will be met
# (next_check()), each chain continuing its own random stream. The checks
# fall at sweep counts fixed by the chain's own state (its warm-up length)
# and the draws up to the check before, and read only the draws up to that
# count, so a run resumed from a checkpoint, or run on another plan, stops
# where the uninterrupted run stops, with its draws.

# Defaults of the run's length (see ?calibrate, "Run length"):
# a warm-up of data-dependent length (nBurn = NULL) takes between `min` and
# `max` sweeps (src/sampler.cpp); without nMCMC a rule first checks
# `fbc_first_check` sweeps after a chain's warm-up; converge = FALSE
# without nMCMC runs fbc_fixed_nMCMC sweeps.
# `ess`: a joint block's shape counts as learnt when its running covariance
# holds this many effective draws per parameter (src/sampler.cpp): at
# m = 1000 scattered runs the simulator block's bulk ESS at 875 retained
# draws a chain was 373 with it against 168 without (RESULTS-defaults.md).
# `forget`: the weight of each earlier epoch of a block's estimate
# (epochs of 200, 200, 400, 800, ... sweeps) relative to the next one's;
# 0 would start the estimate afresh at 200, 400, 800, ... (RESULTS-defaults.md).
fbc_warmup <- list(min = 200L, max = 5000L, ess = 10, forget = 0.5)
fbc_first_check <- 500L
# Without `every`, each check after the first comes fbc_check_approach of
# the way to where the draws so far predict the rule will be met
# (next_check()), at least fbc_check_step of the retained sweeps (and one
# piece of 50 sweeps) further, at most fbc_check_growth times as many (the
# geometric step of earlier versions), rounded up to a piece of 50.
fbc_check_growth <- 1.5
fbc_check_approach <- 0.7
fbc_check_step <- 0.05
fbc_fixed_nMCMC <- 8000L

#' Stop a run when it has converged
#'
#' A rule for [calibrate()] and [update.fbc()] (`converge =`), and what
#' [calibrate()] does by default: the chains run their first stretch
#' (`nMCMC` sweeps when given; otherwise until 500 sweeps after each
#' chain's warm-up), then more until every sampled parameter has a
#' rank-normalised split R-hat below `rhat` and a bulk effective sample size
#' of at least `ess` (Vehtari et al. 2021, as in the `estimates` table and
#' [convergence_messages()]), or until a chain has run `maxMCMC` sweeps in
#' all. Without `every`, each check predicts from the draws so far where the
#' rule will be met (the smallest bulk ESS grows in proportion to the
#' sweeps, R-hat's excess over 1 about as their inverse square) and puts
#' the next check 70% of the way there (a check costs little, sweeps past
#' the end do not), at least 5% and at most 50% further (rounded up to 50
#' sweeps), so the run ends close to the
#' shortest that meets the rule (on the ball drop a few percent past it,
#' `bench/RESULTS-speed.md`); with `every` (a number) it checks every
#' `every` sweeps. The checks fall at sweep counts fixed by each chain's
#' own warm-up and the draws up to the check before, so [set.seed()]
#' reproduces the run on any [future::plan()] and a checkpointed run
#' resumes to the same end with the same draws. Warm-up is not extended:
#' the proposals stay as warm-up left them.
#'
#' What R-hat cannot see: a mode that every chain visits too rarely. The
#' chains agree, so the rule is met, while the mode's share of the draws is
#' far from its share of the posterior; `print()` says when kappa's draws
#' are multimodal, and more chains (`nChains = 8`) show how stable the
#' shares are.
#'
#' So give the run the burn-in its proposals need. With hundreds or
#' thousands of simulator runs the simulator's hyperparameters have a narrow,
#' correlated posterior, and their joint move learns its shape from the
#' second half of burn-in: on a scattered design of m = 1000 runs
#' (`bench/vecchia.R`) a burn-in of 1000 sweeps left their bulk ESS at
#' about 60 per 12,000 draws and the rule ran 21,000 sweeps a chain, while a
#' burn-in of 4000 gave about 630 per 12,000 draws: the longer burn-in is the
#' cheaper run.
#'
#' `converge = TRUE` in [calibrate()] or [update.fbc()] means
#' `until_converged()` with these defaults. The fit's
#' `settings$converge` keeps the rule with `converged` (whether the rule was
#' met), `checks` (how many checks were made) and `sweeps` (the sweeps per
#' chain at the end); `print()` says whether the run converged.
#'
#' @param rhat Largest R-hat allowed (above 1).
#' @param ess Smallest bulk ESS allowed (a whole number, at least 10).
#' @param every `NULL` (the default: each check comes where the draws so
#'   far predict the rule is met, see above) or the sweeps per chain between
#'   two checks (a whole number, at least 50).
#' @param maxMCMC Most sweeps a chain runs in all, counted from its start
#'   (burn-in included; for [update.fbc()], the sweeps of the run it
#'   continues too).
#' @return A list of class `fbc_converge`.
#' @export
#' @examples
#' until_converged()
#' # a first stretch of 600 sweeps, then checks where the draws predict
#' # every R-hat < 1.02 and bulk ESS >= 100, at most 1200 sweeps a chain
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 600, nBurn = 200, nChains = 2,
#'                  converge = until_converged(rhat = 1.02, ess = 100, maxMCMC = 1200))
#' fit$settings$converge[c("converged", "checks", "sweeps")]
until_converged <- function(rhat = 1.01, ess = 400, every = NULL, maxMCMC = 50000) {
  if (!is.numeric(rhat) || length(rhat) != 1L || is.na(rhat) || !(rhat > 1)) {
    cli::cli_abort("{.arg rhat} must be a number above 1 (got {format_value(rhat)}).")
  }
  ess <- check_count(ess, "ess", min = 10)
  if (!is.null(every)) every <- check_count(every, "every", min = 50)
  maxMCMC <- check_count(maxMCMC, "maxMCMC", min = 2)
  structure(list(rhat = rhat, ess = ess, every = every, maxMCMC = maxMCMC),
            class = "fbc_converge")
}

#' @export
print.fbc_converge <- function(x, ...) {
  cat(sprintf("<fbc_converge> until every R-hat < %g and bulk ESS >= %d, checked %s, at most %d sweeps per chain\n",
              x$rhat, x$ess, check_schedule(x), x$maxMCMC))
  invisible(x)
}

# The rule `converge` stands for: NULL for FALSE (run nMCMC sweeps), the
# defaults for TRUE, or an until_converged() rule as given.
check_converge <- function(converge, arg = "converge", call = parent.frame()) {
  if (inherits(converge, "fbc_converge")) return(converge)
  if (is.logical(converge) && length(converge) == 1L && !is.na(converge)) {
    return(if (converge) until_converged() else NULL)
  }
  cli::cli_abort(
    "{.arg {arg}} must be {.code TRUE}, {.code FALSE} or a rule from {.fn until_converged}, not {format_value(converge, typed = TRUE)}.",
    call = call
  )
}

# When a rule checks, in words.
check_schedule <- function(rule) {
  if (is.null(rule$every)) "where the draws predict it is met" else sprintf("every %d sweeps", rule$every)
}

# The run's length from calibrate()'s arguments (see ?calibrate, "Run
# length"): `nMCMC` the sweeps a chain runs at most (the given nMCMC, or
# the rule's ceiling), `nBurn` a number (a fixed burn-in) or the bounds of a
# warm-up of data-dependent length (list(min, max): at most half the run,
# whole windows of 100 sweeps), `converge` the rule or NULL (`first`: the
# sweeps after warm-up of its first check, when nMCMC was not given).
check_run_length <- function(nMCMC, nBurn, thinning, converge, call = parent.frame()) {
  rule <- check_converge(converge %||% is.null(nMCMC), call = call)
  if (!is.null(nMCMC)) nMCMC <- check_count(nMCMC, "nMCMC", min = 2, call = call)
  if (!is.null(nBurn)) nBurn <- check_count(nBurn, "nBurn", min = 0, call = call)
  thinning <- check_count(thinning, "thinning", min = 1, call = call)
  if (is.null(nMCMC) && is.null(rule)) nMCMC <- fbc_fixed_nMCMC
  if (is.null(nMCMC)) {
    rule$first <- fbc_first_check
    nMCMC <- rule$maxMCMC
    check_ceiling(rule, (nBurn %||% 0) + rule$first, arg = "nBurn", call = call)
  } else if (!is.null(nBurn)) {
    if (nBurn >= nMCMC) {
      cli::cli_abort("{.arg nBurn} must be smaller than {.arg nMCMC} (got {nBurn} and {nMCMC}).",
                     call = call)
    }
    if ((nMCMC - nBurn) %/% thinning < 2L) {
      cli::cli_abort(
        "{.arg nMCMC}, {.arg nBurn} and {.arg thinning} keep fewer than 2 draws ((nMCMC - nBurn) / thinning = {(nMCMC - nBurn) / thinning}).",
        call = call
      )
    }
  }
  if (!is.null(rule) && is.null(rule$first)) check_ceiling(rule, nMCMC, call = call)
  if (is.null(nBurn)) {
    cap <- min(fbc_warmup$max, (nMCMC %/% 2L) %/% 100L * 100L)
    if (cap < 100L) {
      cli::cli_abort(c(
        "{.arg nMCMC} = {nMCMC} leaves no room for a warm-up of data-dependent length ({.code nBurn = NULL}).",
        i = "Give {.arg nMCMC} of at least 200, or a fixed {.arg nBurn}."
      ), call = call)
    }
    nBurn <- list(min = min(fbc_warmup$min, cap), max = cap, ess = fbc_warmup$ess,
                  forget = fbc_warmup$forget)
  }
  list(nMCMC = nMCMC, nBurn = nBurn, thinning = thinning, converge = rule)
}

# The size check of a run (check_run_size()) at its longest.
check_run_length_size <- function(len, d, nChains, call = parent.frame()) {
  burn <- if (is.list(len$nBurn)) len$nBurn$min else len$nBurn
  args <- c(if (is.null(len$converge)) "nMCMC" else "maxMCMC", "nChains")
  check_run_size((len$nMCMC - burn) %/% len$thinning, d, nChains, iters = len$nMCMC,
                 args = args, call = call)
}

# The ceiling of a rule must leave room for the first stretch of `first`
# sweeps per chain (`arg`).
check_ceiling <- function(rule, first, arg = "nMCMC", call = parent.frame()) {
  if (!is.null(rule) && rule$maxMCMC < first) {
    cli::cli_abort(c(
      "The rule's {.arg maxMCMC} ({rule$maxMCMC}) is smaller than the first stretch of {first} sweeps ({.arg {arg}}).",
      i = "Give a larger {.arg maxMCMC} in {.fn until_converged}, or a smaller {.arg {arg}}."
    ), call = call)
  }
  invisible()
}

# Does a fit meet the rule? Every sampled parameter (a fixed one has NA
# diagnostics) has R-hat below rule$rhat and bulk ESS of at least rule$ess.
meets_rule <- function(fit, rule) {
  est <- fit$estimates
  ok <- !is.na(est$rhat) & !is.na(est$ess)
  any(ok) && all(est$rhat[ok] < rule$rhat) && all(est$ess[ok] >= rule$ess)
}

# Chain k's start for the next round, from its result so far (the inverse
# of result_from_start() in run.R).
start_from_result <- function(r, iter0) {
  list(state = r$state, iter0 = as.integer(iter0), draws = r$draws,
       logPost = r$logPost, logLik = r$logLik, nPost = r$nPost, finished = FALSE)
}

# A chain's result cut to the draws it kept up to sweep `target` (a chain
# resumed from a checkpoint of a later round is further on).
result_up_to <- function(r, iter0, target, nBurn, thinning) {
  keep <- seq_len(min(r$kept, kept_between(iter0, target, chain_burn(r$state, nBurn), thinning)))
  r$draws <- r$draws[keep, , drop = FALSE]
  r$logPost <- r$logPost[keep]
  r$logLik <- r$logLik[keep]
  r$kept <- length(keep)
  r
}

# The rule's diagnostics of chain results (R-hat and bulk ESS of the
# parameters of Phi, as the fit's estimates would give them: both are
# invariant under the affine map of kappa to its units), without making the
# fit: the check's cost is that of the diagnostics alone.
rule_met <- function(results, rule, cols) {
  draws <- lapply(results, function(r) r$draws[seq_len(r$kept), cols, drop = FALSE])
  chain <- rep(seq_along(draws), vapply(draws, nrow, integer(1)))
  est <- chain_diagnostics(do.call(rbind, draws), chain)
  ok <- !is.na(est$rhat) & !is.na(est$ess)
  list(met = any(ok) && all(est$rhat[ok] < rule$rhat) && all(est$ess[ok] >= rule$ess),
       rhat = max(est$rhat, na.rm = TRUE), ess = min(est$ess, na.rm = TRUE))
}

# Sweeps after warm-up of the next check, after one at `post` retained
# sweeps a chain whose draws gave `check` (list(rhat, ess): the largest
# R-hat and the smallest bulk ESS), or `every` more. Bulk ESS grows in
# proportion to the draws, so the rule's ESS is met near post * ess /
# check$ess. R-hat - 1 of chains whose means are apart shrinks about as
# 1 / post^2 as later draws average the offsets out (as 1 / post once they
# agree): the factor R-hat asks for is the square root of the ratio of
# R-hat - 1 to the rule's. The check comes fbc_check_approach of the way
# to the longer of the two lengths: a check costs little (tens of ms),
# sweeps past the end do not, and the prediction is noisy (measured on the
# ball drop against checking at the predicted length and against R-hat's
# ratio itself instead of its root: bench/check-schedule.R, its figures in
# bench/RESULTS-speed.md). At least a step
# of fbc_check_step (a check after a near miss comes soon, but not at
# every piece), at most the geometric step fbc_check_growth (a far miss,
# where the prediction is least sure, waits no longer than it did).
# Without a finite check (no sampled parameter), the geometric step.
next_check <- function(post, rule, check = NULL) {
  if (!is.null(rule$every)) return(as.integer(post + rule$every))
  up <- function(x) ceiling(x / fbc_piece - 1e-9) * fbc_piece
  cap <- up(fbc_check_growth * post)
  if (is.null(check) || !is.finite(check$rhat) || !is.finite(check$ess) || check$ess <= 0) {
    return(as.integer(cap))
  }
  need <- post * max(rule$ess / check$ess, sqrt(max(check$rhat - 1, 0) / (rule$rhat - 1)))
  least <- post + max(fbc_piece, up(fbc_check_step * post))
  as.integer(min(cap, max(least, up(post + fbc_check_approach * (need - post)))))
}

# Runs the chains from `starts` to `target` (one per chain), then, under
# `rule` (until_converged(), or NULL for one round), in rounds until the
# results cut to the round's ends meet the rule or a chain reaches
# rule$maxMCMC. A rule with `first` (nMCMC not given) ends its first round
# `first` sweeps after each chain's warm-up; later rounds of any rule end
# each chain at its warm-up plus next_check() of its retained-phase sweeps.
# Chain k continues its own stream across rounds. `assemble(results,
# target)` makes the fit of the chains run to `target` (once, at the end);
# `run_chains()` gets the other arguments. `whole`: the check reads the
# fit assemble() makes at each check (update(): the fit holds the earlier
# run's draws too). Returns the fit, with
# settings$converge (the rule and how it ended) when there is a rule, and
# the warm-up each chain had (settings$warmup; see warmup_settings()).
run_rounds <- function(starts, seeds, target, rule, assemble, nBurn, thinning, showProgress,
                       ..., whole = FALSE) {
  iter0 <- vapply(starts, function(s) as.integer(s$iter0), integer(1))
  target <- as.integer(target)
  if (!is.null(rule)) target <- pmin(target, rule$maxMCMC)
  post <- if (!is.null(rule$first)) rep(as.integer(rule$first), length(starts))
  cols <- phi_columns(list(...)$spec)
  checks <- 0L
  repeat {
    for (k in seq_along(starts)) {
      starts[[k]]$finished <- starts[[k]]$state$iter >= chain_stop(starts[[k]]$state, target[k], post[k], nBurn)
    }
    results <- run_chains(starts = starts, seeds = seeds, target = target, nBurn = nBurn,
                          thinning = thinning, showProgress = showProgress, post = post,
                          stretch = !is.null(rule), ...)
    stops <- vapply(seq_along(results), function(k) {
      if (is.null(results[[k]])) NA_integer_ else chain_stop(results[[k]]$state, target[k], post[k], nBurn)
    }, integer(1))
    if (is.null(rule)) {
      return(warmup_settings(assemble(results, ifelse(is.na(stops), target, stops)), nBurn))
    }
    stopped <- vapply(results, function(r) is.null(r) || isTRUE(r$interrupted), logical(1))
    cut <- results
    for (k in which(!stopped)) {
      cut[[k]] <- result_up_to(results[[k]], iter0[k], stops[k], nBurn, thinning)
    }
    checks <- checks + 1L
    fit <- NULL
    check <- if (any(stopped)) NULL else if (whole) {
      fit <- assemble(cut, stops)
      list(met = meets_rule(fit, rule), rhat = max(fit$estimates$rhat, na.rm = TRUE),
           ess = min(fit$estimates$ess, na.rm = TRUE))
    } else {
      rule_met(cut, rule, cols)
    }
    converged <- isTRUE(check$met)
    if (converged || any(stopped) || all(stops >= rule$maxMCMC)) break
    if (showProgress) {
      cli::cli_inform(
        "Not converged after {max(stops)} sweeps (max R-hat {format(check$rhat, digits = 4)}, min bulk ESS {round(check$ess)}): more."
      )
    }
    starts <- lapply(seq_along(results), function(k) start_from_result(results[[k]], iter0[k]))
    seeds <- lapply(results, `[[`, "seed")
    warm <- vapply(results, function(r) chain_burn(r$state, nBurn), numeric(1))
    post <- vapply(seq_along(results), function(k) next_check(stops[k] - warm[k], rule, check),
                   numeric(1))
    target <- rep(as.integer(rule$maxMCMC), length(starts))
  }
  if (is.null(fit)) fit <- assemble(cut, ifelse(is.na(stops), target, stops))
  fit$settings$converge <- c(unclass(rule), list(converged = converged, checks = checks,
                                                 sweeps = max(stops, na.rm = TRUE)))
  warmup_settings(fit, nBurn)
}

# The fit's warm-up: settings$warmup, the sweeps of warm-up (burn-in) of each
# chain; with a warm-up of data-dependent length, settings$nBurn its longest
# (for readers of a fixed burn-in), settings$warmupBounds its bounds and
# settings$warmupCapped the chains whose warm-up reached the maximum.
warmup_settings <- function(fit, nBurn) {
  states <- lapply(fit$state$chains, `[[`, "sampler")
  warm <- vapply(states, function(st) chain_burn(st, nBurn), numeric(1))
  fit$settings$warmup <- as.integer(warm)
  if (is.list(nBurn)) {
    fit$settings$nBurn <- max(warm, na.rm = TRUE)
    fit$settings$warmupBounds <- nBurn
    fit$settings$warmupCapped <- which(vapply(states, function(st) isTRUE(st$warmCapped), logical(1)))
  }
  fit
}

# The warm-up a fit's further run continues with: the bounds of a warm-up of
# data-dependent length, or the fixed burn-in.
run_burn <- function(settings) settings$warmupBounds %||% settings$nBurn

# How print() states the warm-up.
warmup_text <- function(s) {
  if (is.null(s$warmupBounds)) return(sprintf("%d burn-in", as.integer(s$nBurn)))
  w <- s$warmup
  txt <- if (length(unique(w)) == 1L) sprintf("%d", w[1]) else sprintf("%d-%d", min(w), max(w))
  capped <- s$warmupCapped
  sprintf("%s warm-up (adaptive%s)", txt,
          if (length(capped)) sprintf(", maximum %d reached by chain %s", s$warmupBounds$max,
                                      paste(capped, collapse = ", ")) else "")
}
