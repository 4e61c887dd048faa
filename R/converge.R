# Runs that stop when converged: the rule (until_converged()), its check,
# and the rounds calibrate() and update() run under it.
#
# A run under a rule is one run of every chain, stopped at a data-dependent
# length: the chains go to their first target (nMCMC sweeps), then, while
# the draws do not meet the rule and the ceiling is not reached, `every`
# sweeps further, each chain continuing its own random stream. The checks
# fall at fixed sweep counts (nMCMC, nMCMC + every, ...) and read only the
# draws up to that count, so a run resumed from a checkpoint, or run on
# another plan, stops where the uninterrupted run stops, with its draws.

#' Stop a run when it has converged
#'
#' A rule for [calibrate()] and [update.fbc()] (`converge =`): the chains run
#' their `nMCMC` sweeps, then `every` sweeps more at a time until every
#' sampled parameter has a rank-normalised split R-hat below `rhat` and a
#' bulk effective sample size of at least `ess` (Vehtari et al. 2021, as in
#' the `estimates` table and [convergence_messages()]), or until a chain has
#' run `maxMCMC` sweeps in all. The checks fall after `nMCMC`,
#' `nMCMC + every`, ... sweeps and each reads the draws up to that point, so
#' [set.seed()] reproduces the run and a checkpointed run resumes to the same
#' end with the same draws. Burn-in (`nBurn`) is not extended: the proposals
#' stay as burn-in left them.
#'
#' So give the run the burn-in its proposals need. With hundreds or
#' thousands of simulator runs the simulator's hyperparameters have a narrow,
#' correlated posterior, and their joint move learns its shape from the
#' second half of burn-in: on a scattered design of m = 1000 runs
#' (`inst/bench/vecchia.R`) a burn-in of 1000 sweeps left their bulk ESS at
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
#' @param every Sweeps per chain between two checks (a whole number, at
#'   least 50).
#' @param maxMCMC Most sweeps a chain runs in all, counted from its start
#'   (burn-in included; for [update.fbc()], the sweeps of the run it
#'   continues too).
#' @return A list of class `fbc_converge`.
#' @export
#' @examples
#' until_converged()
#' \donttest{
#' # a short first stretch, then 500 sweeps at a time until converged
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 2000, nBurn = 1000,
#'                  converge = until_converged(ess = 400, every = 500))
#' fit$settings$converge$sweeps
#' }
until_converged <- function(rhat = 1.01, ess = 400, every = 500, maxMCMC = 50000) {
  if (!is.numeric(rhat) || length(rhat) != 1L || is.na(rhat) || !(rhat > 1)) {
    cli::cli_abort("{.arg rhat} must be a number above 1 (got {format_value(rhat)}).")
  }
  ess <- check_count(ess, "ess", min = 10)
  every <- check_count(every, "every", min = 50)
  maxMCMC <- check_count(maxMCMC, "maxMCMC", min = 2)
  structure(list(rhat = rhat, ess = ess, every = every, maxMCMC = maxMCMC),
            class = "fbc_converge")
}

#' @export
print.fbc_converge <- function(x, ...) {
  cat(sprintf("<fbc_converge> until every R-hat < %g and bulk ESS >= %d, checked every %d sweeps, at most %d sweeps per chain\n",
              x$rhat, x$ess, x$every, x$maxMCMC))
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
       logPost = r$logPost, logLik = r$logLik,
       accSum = r$acceptance * r$nPost, scaleAccSum = r$scaleAcceptance * r$nPost,
       nPost = r$nPost, finished = FALSE)
}

# A chain's result cut to the draws it kept up to sweep `target` (a chain
# resumed from a checkpoint of a later round is further on).
result_up_to <- function(r, iter0, target, nBurn, thinning) {
  keep <- seq_len(min(r$kept, kept_between(iter0, target, nBurn, thinning)))
  r$draws <- r$draws[keep, , drop = FALSE]
  r$logPost <- r$logPost[keep]
  r$logLik <- r$logLik[keep]
  r$kept <- length(keep)
  r
}

# Runs the chains from `starts` to `target` (one per chain), then, under
# `rule` (until_converged(), or NULL for one round), in rounds of
# rule$every further sweeps until assemble() of the results cut to the
# round's targets meets the rule or a chain reaches rule$maxMCMC. Chain k
# continues its own stream across rounds. `assemble(results, target)` makes
# the fit of the chains run to `target`; `run_chains()` gets the other
# arguments. Returns the fit, with
# settings$converge (the rule and how it ended) when there is a rule.
run_rounds <- function(starts, seeds, target, rule, assemble, nBurn, thinning, showProgress,
                       ...) {
  iter0 <- vapply(starts, function(s) as.integer(s$iter0), integer(1))
  target <- as.integer(target)
  if (!is.null(rule)) target <- pmin(target, rule$maxMCMC)
  checks <- 0L
  repeat {
    for (k in seq_along(starts)) {
      starts[[k]]$finished <- starts[[k]]$state$iter >= target[k]
    }
    results <- run_chains(starts = starts, seeds = seeds, target = target, nBurn = nBurn,
                          thinning = thinning, showProgress = showProgress, ...)
    if (is.null(rule)) return(assemble(results, target))
    stopped <- vapply(results, function(r) is.null(r) || isTRUE(r$interrupted), logical(1))
    cut <- results
    for (k in which(!stopped)) {
      cut[[k]] <- result_up_to(results[[k]], iter0[k], target[k], nBurn, thinning)
    }
    fit <- assemble(cut, target)
    checks <- checks + 1L
    converged <- !any(stopped) && meets_rule(fit, rule)
    if (converged || any(stopped) || all(target >= rule$maxMCMC)) break
    if (showProgress) {
      est <- fit$estimates
      cli::cli_inform(
        "Not converged after {max(target)} sweeps (max R-hat {format(max(est$rhat, na.rm = TRUE), digits = 4)}, min bulk ESS {round(min(est$ess, na.rm = TRUE))}): {rule$every} more."
      )
    }
    starts <- lapply(seq_along(results), function(k) start_from_result(results[[k]], iter0[k]))
    seeds <- lapply(results, `[[`, "seed")
    target <- pmin(target + rule$every, rule$maxMCMC)
  }
  fit$settings$converge <- c(unclass(rule), list(converged = converged, checks = checks,
                                                 sweeps = max(target)))
  fit
}
