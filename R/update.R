#' Continue a calibration
#'
#' Runs every chain of a calibration further from where it stopped, with its
#' adapted (now frozen) proposal standard deviations, and appends the new
#' draws to the old ones. Nothing is recomputed: the chains go on exactly as
#' if they had been run longer in the first place (with fresh random
#' streams). A run interrupted with Ctrl-C is continued the same way.
#'
#' A fit whose draws were reweighted after runs were added ([update_runs()])
#' goes on with the proposals adapted before the runs were added: when a
#' move then accepts under a quarter of its adaptation's target, `update()`
#' warns (class `fbc_stale_proposals`), naming the moves; such chains mix
#' slowly, and `calibrate(fit$model)` fits the model afresh.
#'
#' `update()` writes no checkpoint: the continued draws are only in the
#' object it returns (an `update()` interrupted with Ctrl-C returns the
#' draws made so far, and is continued by `update()` again). For a long
#' continuation that must survive the session, run [calibrate()] with
#' `checkpoint =` and a larger `nMCMC` (or `converge =`) instead.
#'
#' @param object An `fbc` object from [calibrate()] (or from `update()`).
#' @param nMCMC Number of further iterations (sweeps) per chain. Every
#'   `thinning`-th is kept, with the `thinning` of the original run. Under
#'   `converge`, the first stretch (by default the rule's `every`).
#' @param converge `FALSE` (the default) runs `nMCMC` sweeps more. `TRUE`,
#'   or a rule from [until_converged()], runs `nMCMC` sweeps more and then
#'   `every` at a time until every R-hat and bulk ESS, over the old and new
#'   draws, meet the rule, or a chain has run the rule's `maxMCMC` sweeps in
#'   all (counted from its start in [calibrate()]).
#' @param showProgress Show a progress bar over all chains: `NULL` (the
#'   default) shows it in an interactive session and not in scripts or knitr,
#'   as in [calibrate()].
#' @param sim New simulator runs (rows in the form of `calibrate()`'s `sim`):
#'   the model is rebuilt on all runs and its posterior drawn from the old
#'   draws reweighted, or refitted from the chains' last states (a warm
#'   start), see [update_runs()]. `nMCMC` and `converge` are then the new
#'   run's, as in [calibrate()].
#' @param reweight With `sim`: try the old draws reweighted first (see
#'   [update_runs()]); `FALSE` always refits. Given without `sim`, an
#'   error (it would do nothing).
#' @param ... Not used: an argument given here is an error (a typo such
#'   as `lvl =` would otherwise be ignored silently).
#' @return The `fbc` object with the chains extended: `Phi`, `chain`,
#'   `logPost`, `logLik`, `estimates` (with R-hat and ESS over all draws),
#'   `acceptance` (over all iterations after burn-in), `settings$nMCMC` (total
#'   sweeps per chain) and `state`.
#' @export
#' @examples
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 600, nBurn = 200, nChains = 2)
#' fit <- update(fit, nMCMC = 400)
#' table(fit$chain)
update.fbc <- function(object, nMCMC, showProgress = NULL, converge = FALSE, sim = NULL,
                       reweight = TRUE, ...) {
  check_dots_empty(..., fn = update.fbc, name = "update")
  if (is.null(sim) && !missing(reweight)) {
    cli::cli_abort(c(
      "{.arg reweight} is for new simulator runs ({.arg sim}): continuing the chains draws no new posterior.",
      i = "Add runs with {.code update(fit, sim = more_runs, reweight = {format_value(reweight)})}."
    ))
  }
  if (!is.null(sim)) {
    return(update_runs(object, sim, nMCMC = if (!missing(nMCMC)) nMCMC,
                       converge = if (!missing(converge)) converge, showProgress = showProgress,
                       reweight = reweight))
  }
  converge <- check_converge(converge)
  if (missing(nMCMC) && !is.null(converge)) nMCMC <- converge$every %||% fbc_first_check
  nMCMC <- check_count(nMCMC, "nMCMC", min = 1)
  showProgress <- default_progress(showProgress)
  object <- check_fbc(object, "object")
  s <- object$settings
  states <- object$state$chains
  if (!is.null(converge)) {
    done <- chain_sweeps(object)
    check_update_ceiling(converge, done, nMCMC)
  }
  if (nMCMC %/% s$thinning < 1L) {
    cli::cli_abort("{.arg nMCMC} = {nMCMC} keeps no draw at thinning {s$thinning}; use at least {s$thinning}.")
  }
  further <- if (is.null(converge)) nMCMC else converge$maxMCMC - as.numeric(s$nMCMC)
  check_run_size(max(vapply(states, function(st) as.numeric(st$kept), numeric(1))) +
                   further %/% s$thinning,
                 ncol(object$Phi), length(states), iters = as.numeric(s$nMCMC) + further,
                 args = if (is.null(converge)) "nMCMC" else "maxMCMC", thin = FALSE)
  t0 <- proc.time()[["elapsed"]]
  d <- length(object$model$spec$vars)  # the sampler's parameters (see phi_columns())
  starts <- lapply(states, function(st) chain_start(st$sampler, d))
  target <- vapply(starts, function(st) st$iter0, integer(1)) + as.integer(nMCMC)
  here <- environment()
  assemble <- function(results, target) {
    # a chain skipped after an interrupt adds nothing and stays where it was
    for (k in seq_along(results)) {
      if (is.null(results[[k]])) {
        st <- states[[k]]
        results[[k]] <- list(draws = matrix(0, 0, length(st$last)), logPost = numeric(),
                             logLik = numeric(), kept = 0L, done = 0L, nPost = 0L,
                             interrupted = TRUE, state = st$sampler)
      }
    }
    interrupted <- vapply(results, function(r) isTRUE(r$interrupted), logical(1))
    further <- max(target - iter0)
    if (any(interrupted)) {
      ids <- which(interrupted)
      its <- vapply(results, function(r) as.integer(r$done), integer(1))[interrupted]
      cli::cli_warn(c(
        "Interrupted: {cli::qty(length(ids))}chain{?s} {ids} stopped after {its} of {further} further iterations.",
        i = "Returning all draws retained so far; continue with {.code update(fit, nMCMC = ...)}."
      ), call = here)
    }
    s$nMCMC <- s$nMCMC + further
    s$time <- s$time + proc.time()[["elapsed"]] - t0
    s$converge <- NULL
    new_fbc_chains(results, object$model, object$call, s, prev = object)
  }
  iter0 <- vapply(starts, function(st) st$iter0, integer(1))
  out <- run_rounds(starts, chain_seeds(length(starts)), target, converge, assemble,
                    nBurn = run_burn(s), thinning = s$thinning, showProgress = showProgress,
                    dat = object$model$data, spec = object$model$spec, moves = object$model$moves, whole = TRUE)
  if (isTRUE(s$reweight$used)) warn_stale(object, out, here)
  out
}

# A reweighted fit (update_runs()) continues with the proposals adapted at
# the last refit, before runs were added; update_runs()'s own continuation
# checks them (top_up()) and refits when they are stale, a user's update()
# says so: the moves accepting under a quarter of their target in the
# sweeps just run (stale_moves()), which mix slowly.
warn_stale <- function(before, after, call) {
  stale <- stale_moves(before, after)
  if (!length(stale)) return(invisible())
  cli::cli_warn(c(
    "The {cli::qty(length(stale))}move{?s} {.val {stale}} accepted under a quarter of {?its/their} target in these sweeps: the draws were reweighted after runs were added (see {.fn update_runs}) and the chains go on with proposals adapted before, which no longer suit the posterior, so they mix slowly.",
    i = "{.code calibrate(fit$model)} fits the model on all runs afresh, with proposals adapted to it."
  ), class = "fbc_stale_proposals", call = call)
}

# The most sweeps any chain of `fit` has run (counted from its start in
# calibrate(), or in the refit it comes from).
chain_sweeps <- function(fit) {
  max(vapply(fit$state$chains, function(st) as.numeric(st$sampler$iter), numeric(1)))
}

# Under a `converge` rule, update() runs `nMCMC` further sweeps first: the
# chains, `done` sweeps already, must stay within the rule's maxMCMC (a
# total counted from calibrate()'s start), said with both numbers.
check_update_ceiling <- function(rule, done, nMCMC, call = parent.frame()) {
  if (rule$maxMCMC >= done + nMCMC) return(invisible())
  cli::cli_abort(c(
    "The rule's {.arg maxMCMC} ({rule$maxMCMC} sweeps in all) leaves no room for {.arg nMCMC} = {nMCMC} further sweeps: the chains have run {done} already.",
    i = if (rule$maxMCMC > done) "Give {.arg nMCMC} of at most {rule$maxMCMC - done}, or a {.arg maxMCMC} of at least {done + nMCMC} in {.fn until_converged}." else
      "Give a {.arg maxMCMC} of at least {done + nMCMC} in {.fn until_converged}."
  ), call = call)
}
