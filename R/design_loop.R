# design_loop(): a calibration campaign for a simulator given as an R
# function: a small maximin design, then batches chosen by propose_runs(),
# run through futures and added by update_runs().

#' Run a design loop with a simulator function
#'
#' Starts from `n0` runs of a maximin Latin hypercube in the ranges given,
#' fits, and then repeats: [propose_runs()] chooses `batch` runs, the
#' simulator is called at them (each run one [future::future()], so a batch
#' runs in parallel under [future::plan()] or on a cluster), and
#' [update_runs()] refits on all runs from the last posterior; until
#' `budget` runs have been added or the 90% interval of every calibration
#' input is narrower than `width`.
#'
#' @param f The simulator: `f(x, kappa)` with `x` a data frame of the
#'   field's input columns (one row per point) and `kappa` a named numeric
#'   vector of the calibration inputs, returning one response per row.
#'   With several outputs (`output = "<column>"` among `...`, the field in
#'   long format as for [calibrate()]) a run gives every output: `x` holds
#'   the run's inputs once per output, its output column a factor, and `f`
#'   returns each row's output (one call per run). A stochastic `f`
#'   (another value at each call) is called as it is: with `simNoise =
#'   "constant"` or `"input"` among `...` the fits model its noise and
#'   [propose_runs()] weighs replicates at the runs' inputs beside new
#'   inputs.
#' @param field The field data (response first, as in [calibrate()]; with
#'   several data sets, `source =` among `...` names their column, which is
#'   not an input).
#' @param lower,upper Named numeric vectors: the ranges of the numeric
#'   experimental inputs (named as in `field`) and of the calibration inputs
#'   (their names are the calibration inputs'). A categorical input (a
#'   factor or character column of `field`) is run at the field's levels
#'   (a factor's levels), spread evenly over the starting design.
#' @param n0 Runs of the initial design.
#' @param batch Runs per step.
#' @param budget Runs to add at most.
#' @param width Stop when every calibration input's 90% interval is
#'   narrower (in its units; a vector per input or one number); `NULL`:
#'   run the whole budget.
#' @param ... Passed to [calibrate()] (model and run settings; `nMCMC` and
#'   `converge` to [update_runs()] too).
#' @param design Arguments for [propose_runs()] (such as `ndraws`,
#'   `method`, or `target` for runs that serve calibrated predictions at
#'   given inputs rather than kappa; `width` still stops on kappa's
#'   intervals).
#' @param showProgress Report each step (`NULL`: in interactive sessions).
#' @return A list: `fit` (the last fit), `sim` (every run), `history` (a
#'   data frame per step: `runs`, each calibration input's posterior mean,
#'   sd and 90% interval width, the design step's and the fit's CPU
#'   seconds, and `reweighted`: whether the step's posterior is the last
#'   fit's draws reweighted, see [update_runs()]; `replicates`: how many of
#'   the step's runs repeat an earlier run's inputs, which
#'   [propose_runs()] proposes for a stochastic simulator, see
#'   [simulator_noise]), and `failed`: the runs
#'   where `f` failed (an error, or `NA`, `NaN` or an infinite value), as
#'   `run` (the row of `sim`) and `condition` (the error's message). A
#'   failed run is kept in `sim` with an `NA` response and set aside by the
#'   fits (see `failedRuns` in [calibrate()]); the loop goes on, and
#'   [propose_runs()] weighs each candidate's gain by its probability of
#'   succeeding.
#'
#' A fit's warning that field inputs lie beyond the runs' range (a small
#' starting design seldom reaches the edges of the field's inputs) is given
#' once, at the end, and only when the last fit's runs still do not cover
#' them.
#' @seealso [propose_runs()], [update_runs()]
#' @export
#' @examples
#' \donttest{
#' f <- function(x, kappa) sin(10 * kappa[["u"]] * x$x)
#' xf <- rep(seq(0.1, 0.9, length.out = 5), 2)
#' field <- data.frame(y = sin(2 * pi * xf) + rnorm(10, 0, 0.1), x = xf)
#' set.seed(1)
#' out <- design_loop(f, field, lower = c(x = 0, u = 0), upper = c(x = 1, u = 1),
#'                    n0 = 6, batch = 3, budget = 3, discrepancy = "none",
#'                    nChains = 2, design = list(ndraws = 50))
#' out$history
#' }
design_loop <- function(f, field, lower, upper, n0 = 10, batch = 1, budget = 40, width = NULL,
                        ..., design = list(), showProgress = NULL) {
  if (!is.function(f)) {
    cli::cli_abort("{.arg f} must be a function {.code f(x, kappa)}, not {.obj_type_friendly {f}}.")
  }
  showProgress <- default_progress(showProgress)
  dots <- list(...)
  # the field's inputs: its columns but the response and the data sets'
  # (`source`, passed on to calibrate()); the categorical ones run at the
  # field's levels, the numeric ones in `lower`, `upper`
  xnames <- setdiff(names(field)[-1], if (is.character(dots$source)) dots$source)
  categorical <- xnames[vapply(field[xnames], is_categorical, logical(1))]
  levs <- lapply(field[categorical], function(v) if (is.factor(v)) levels(v) else sort(unique(v)))
  # several outputs: each run gives every output (one call of f on its rows)
  output <- loop_output(dots, field, levs)
  levs[output$name] <- NULL
  check_loop_ranges(lower, upper, setdiff(xnames, categorical))
  cal <- setdiff(names(lower), xnames)
  xnum <- setdiff(names(lower), c(cal, categorical))
  n0 <- check_count(n0, "n0", min = 3)
  batch <- check_count(batch, "batch", min = 1)
  budget <- check_count(budget, "budget", min = 0)
  X <- with_levels(maximin_lhs(n0, lower, upper), levs)
  sim <- run_simulator(f, X, xnames, cal, names(field)[1], output)
  failures <- attr(sim, "failed")
  runs <- n0
  # a fit's warning that the field inputs lie beyond the runs' range: kept
  # (muffled) at each step, and given once at the end if the last fit's
  # runs still do not cover them (a small starting design rarely does; the
  # runs added may)
  extrapolation <- NULL
  keep_extrapolation <- function(expr) {
    extrapolation <<- NULL
    withCallingHandlers(expr, fbc_extrapolation = function(w) {
      extrapolation <<- w
      invokeRestart("muffleWarning")
    }, fbc_failed_runs = function(m) invokeRestart("muffleMessage"))
  }
  t0 <- proc.time()
  fit <- keep_extrapolation(muffle_wide_outputs(calibrate(sim, field, showProgress = FALSE, ...)))
  history <- loop_row(fit, runs, 0, cpu_since(t0), 0L)
  limited <- FALSE
  while (runs - n0 < budget && !loop_done(fit, width, cal)) {
    t0 <- proc.time()
    # propose_runs()'s "limited" message once a loop, not at every step
    cand <- loop_candidates(fit, field, lower, upper, levs, cal, xnum)
    pr <- withCallingHandlers(
      do.call(propose_runs, c(list(fit, n = min(batch, budget - (runs - n0)), candidates = cand),
                              design)),
      fbc_design_limited = function(m) {
        if (limited) invokeRestart("muffleMessage")
        limited <<- TRUE
      })
    tDesign <- cpu_since(t0)
    new <- run_simulator(f, pr[c(setdiff(xnames, output$name), cal)], xnames, cal,
                         names(field)[1], output)
    failures <- add_failures(failures, attr(new, "failed"), runs)
    sim <- rbind(sim, new)
    runs <- runs + nrow(pr)
    t0 <- proc.time()
    fit <- keep_extrapolation(update_runs(fit, new, nMCMC = dots$nMCMC, converge = dots$converge,
                                          showProgress = FALSE))
    history <- rbind(history, loop_row(fit, runs, tDesign, cpu_since(t0), sum(pr$replicate)))
    if (showProgress) {
      h <- history[nrow(history), ]
      cli::cli_inform("{runs} runs: 90% width {.val {signif(unlist(h[paste0(cal, '.width')]), 3)}} (design {round(tDesign, 1)} s, {if (h$reweighted) 'last fit reweighted' else 'fit'} {round(h$fitTime, 1)} s).")
    }
  }
  if (!is.null(extrapolation)) warning(extrapolation)
  if (nrow(failures)) {
    cli::cli_inform(c(
      "{nrow(failures)} of the {runs} simulator runs failed and {?was/were} set aside; {.code $failed} has their conditions.",
      i = "{.code predict(result$fit, newdata, type = \"failure\")} gives the probability that a run fails."
    ))
  }
  rownames(failures) <- NULL
  list(fit = fit, sim = sim, history = history, failed = failures)
}

cpu_since <- function(t0) {
  tm <- proc.time() - t0
  sum(tm[c(1, 2)]) + sum(tm[c(4, 5)], na.rm = TRUE)
}

check_loop_ranges <- function(lower, upper, xnames, call = parent.frame()) {
  ok <- is.numeric(lower) && is.numeric(upper) && !is.null(names(lower)) &&
    identical(names(lower), names(upper)) && all(upper > lower) && all(xnames %in% names(lower)) &&
    length(setdiff(names(lower), xnames)) >= 1L
  if (!ok) {
    cli::cli_abort(c(
      "{.arg lower} and {.arg upper} must be named numeric vectors with the same names, {.arg upper} above {.arg lower}: the field's inputs ({.val {xnames}}) and at least one calibration input.",
      i = "Such as {.code lower = c(x = 0, u = 0), upper = c(x = 1, u = 1)}."
    ), call = call)
  }
}

# design_loop()'s candidates: a maximin sample of `lower`-`upper` (the
# categorical inputs at levels `levs`), half with the calibration inputs
# `cal` at kappa's draws and the numeric experimental inputs `xnum` at the
# field's, as propose_runs()'s own; every one held to `lower`-`upper` (the
# field's inputs may lie beyond them).
loop_candidates <- function(fit, field, lower, upper, levs, cal, xnum) {
  cand <- half_at(with_levels(maximin_lhs(100 * length(lower), lower, upper, tries = 1), levs),
                  cal, as.matrix(fit$Phi[, seq_along(cal), drop = FALSE]), lower[cal], upper[cal])
  if (length(xnum)) {
    cand <- half_at(cand, xnum, as.matrix(unique(field[xnum])), lower[xnum], upper[xnum])
  }
  cand
}

# n points of a Latin hypercube in the box, the best of `tries` by the
# smallest pairwise distance (scaled units); columns named as `lower`.
maximin_lhs <- function(n, lower, upper, tries = 20) {
  d <- length(lower)
  best <- NULL
  score <- -Inf
  for (k in seq_len(tries)) {
    U <- vapply(seq_len(d), function(j) (sample.int(n) - stats::runif(n)) / n, numeric(n))
    U <- matrix(U, n, d)
    s <- if (n > 1) min(stats::dist(U)) else 0
    if (s > score) {
      best <- U
      score <- s
    }
  }
  X <- sweep(sweep(best, 2, upper - lower, "*"), 2, lower, "+")
  colnames(X) <- names(lower)
  as.data.frame(X)
}

# X with a column per categorical input (`levs`: each one's levels, named),
# its levels spread evenly over the rows in a random order.
with_levels <- function(X, levs) {
  for (nm in names(levs)) X[[nm]] <- sample(rep_len(levs[[nm]], nrow(X)))
  X
}

# design_loop()'s several outputs: `output` (among its `...`, as for
# calibrate()) names the field's column saying each row's output; its
# name and levels (those of `levs`, the field's categorical inputs'), or
# NULL.
loop_output <- function(dots, field, levs, call = parent.frame()) {
  nm <- dots$output
  if (is.null(nm)) return(NULL)
  if (!is.character(nm) || length(nm) != 1L || !nm %in% names(levs)) {
    cli::cli_abort("{.arg output} must name a categorical column of {.arg field} (the output of each row), not {.val {nm}}.",
                   call = call)
  }
  list(name = nm, levels = levs[[nm]])
}

# The simulator at each row of X, one future per run; a data frame in the
# form of calibrate()'s sim (response, experimental, calibration inputs).
# With several outputs (`output`, loop_output()) a run is one call of f on
# K rows, the run's inputs at each output in turn (the output column in x,
# as calibrate() gives a simulator function), returning K numbers.
run_simulator <- function(f, X, xnames, cal, yname, output = NULL) {
  K <- if (is.null(output)) 1L else length(output$levels)
  if (K > 1L) X <- at_every_output(X, output)
  futures <- lapply(seq_len(nrow(X) / K), function(i) {
    rows <- (i - 1L) * K + seq_len(K)
    x <- X[rows, xnames, drop = FALSE]
    kappa <- unlist(X[rows[1], cal, drop = FALSE])
    future::future(f(x, kappa), seed = TRUE, globals = list(f = f, x = x, kappa = kappa),
                   label = sprintf("FBC simulator run %d", i))
  })
  # a call that errors, or returns NA, NaN or Inf, is a failed run (NA),
  # its condition kept; one that returns something else is an error
  why <- character(length(futures))
  y <- unlist(lapply(seq_along(futures), function(i) {
    v <- tryCatch(future::value(futures[[i]]), error = function(e) {
      why[i] <<- conditionMessage(e)
      rep(NA_real_, K)
    })
    if (!is.numeric(v) && !(is.logical(v) && all(is.na(v))) || length(v) != K) {
      what <- if (K > 1L) "{K} numbers for a run's {K} rows of {.arg x} (one per output)" else "one number for one row of {.arg x}"
      cli::cli_abort(paste0("{.arg f} must return ", what, "; it returned {.obj_type_friendly {v}}."))
    }
    if (!nzchar(why[i]) && !all(is.finite(v))) why[i] <<- "returned a value that is not finite"
    as.numeric(v)
  }))
  out <- data.frame(y, X[c(xnames, cal)])
  names(out)[1] <- yname
  # (a categorical input's levels as text, as the starting design has them)
  out[] <- lapply(out, function(v) if (is.factor(v)) as.character(v) else v)
  rownames(out) <- NULL
  failed <- which(nzchar(why))
  attr(out, "failed") <- data.frame(run = failed, condition = why[failed])
  out
}

loop_row <- function(fit, runs, tDesign, tFit, replicates) {
  cal <- fit$model$scale$names$calibration
  row <- data.frame(runs = runs)
  for (j in seq_along(cal)) {
    k <- fit$Phi[, j]
    q <- stats::quantile(k, c(0.05, 0.95), names = FALSE)
    row[[paste0(cal[j], ".mean")]] <- mean(k)
    row[[paste0(cal[j], ".sd")]] <- stats::sd(k)
    row[[paste0(cal[j], ".width")]] <- q[2] - q[1]
  }
  row$designTime <- tDesign
  row$fitTime <- tFit
  row$reweighted <- isTRUE(fit$settings$reweight$used)
  row$replicates <- as.integer(replicates)
  row
}

loop_done <- function(fit, width, cal) {
  if (is.null(width)) return(FALSE)
  w <- vapply(seq_along(cal), function(j) diff(stats::quantile(fit$Phi[, j], c(0.05, 0.95))),
              numeric(1))
  all(w < rep_len(width, length(w)))
}

# The failed calls of a step appended to the loop's record, numbered among
# all runs (`before` runs came before the step's).
add_failures <- function(failures, new, before) {
  if (!nrow(new)) return(failures)
  new$run <- new$run + before
  rbind(failures, new)
}
