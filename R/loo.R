#' Leave-one-out cross-validation of a calibration
#'
#' Estimates the expected log predictive density of new field data by
#' Pareto-smoothed importance sampling leave-one-out (PSIS-LOO, package
#' \pkg{loo}), from the *exact* leave-one-out predictive density of each
#' field observation given the other field data and every simulator run, at
#' each posterior draw: the model is a joint Gaussian, so
#' \eqn{p(y_G \mid y_{-G}, \phi)} has a closed form (the field block of the
#' inverse covariance is the inverse of the Schur complement; Rasmussen and
#' Williams 2006, section 5.4.2), computed through the fit's algebra without
#' refitting. These non-factorized densities are what PSIS needs for a
#' Gaussian model with correlated errors (Bürkner, Gabry and Vehtari 2021).
#' [loo::loo_compare()] then compares fits of the same data: discrepancy
#' models (`calibrate(discrepancy =)`), correlation families, priors, and
#' the models of a stochastic simulator's noise (`calibrate(simNoise =)`,
#' [simulator_noise]) and what the field is to it (`calibrate(fieldLink =)`):
#' each density conditions on every simulator run (with
#' the noise modelled, the unique inputs' means carry all the runs say of
#' \eqn{\eta}), so the elements are the same field observations.
#'
#' @section What is left out:
#' With `unit = "input"` (the default) every observation made at one field
#' input (its replicates) is left out together, and the unit of the
#' comparison is the input: calibrated prediction is about the field at an
#' input not measured yet. Replicates share the bias at their input, so
#' leaving one out while its twins stay in lets the bias GP predict it from
#' them whatever the calibration, which would blur the differences between
#' discrepancy models. `unit = "observation"` leaves out one observation at a
#' time. Without replicates the two are the same. Compare fits with the
#' same `unit`.
#'
#' An input is a point of the experimental inputs but the output: with
#' several outputs (`calibrate(output =)`) or field data sets (`source =`)
#' every output and data set observed at one input is left out with it
#' (they share its bias, correlated across outputs by `rhoB` and across data
#' sets by `rhoD`). A categorical input other than the output is part of
#' the input: another level is another input. The pointwise elements are
#' then the inputs, not the observations.
#'
#' @param x An `fbc` object from [calibrate()].
#' @param unit `"input"` (default) or `"observation"`: see "What is left out".
#' @param ndraws How many posterior draws to use, evenly spaced within each
#'   chain (the same number per chain, for the relative efficiencies); `NULL`
#'   for all. At least 2 per chain. Each draw costs one evaluation of the
#'   likelihood's factors.
#' @param ... Not used: an argument given here is an error.
#' @return A `psis_loo` object of \pkg{loo} (see [loo::loo()]), whose
#'   pointwise elements are the field inputs (or observations) in the order
#'   of their first row in `field`; log densities are in the response's own
#'   units. `attr(, "unit")` says which unit was left out.
#' @exportS3Method loo::loo
#' @examples
#' \donttest{
#' if (requireNamespace("loo", quietly = TRUE)) {
#'   set.seed(1)
#'   gp <- calibrate(ballSim, ballField, nMCMC = 600, nBurn = 200, nChains = 2)
#'   none <- calibrate(ballSim, ballField, nMCMC = 600, nBurn = 200, nChains = 2,
#'                     discrepancy = "none")
#'   loo::loo_compare(list(gp = loo::loo(gp), none = loo::loo(none)))
#' }
#' }
loo.fbc <- function(x, unit = c("input", "observation"), ndraws = 4000, ...) {
  check_dots_empty(..., fn = loo.fbc, name = "loo")
  x <- check_fbc(x, "x")
  if (!requireNamespace("loo", quietly = TRUE)) {
    cli::cli_abort("{.fn loo} for {.cls fbc} objects needs the {.pkg loo} package: {.code install.packages(\"loo\")}.")
  }
  unit <- match_choice(unit, c("input", "observation"), "unit")
  if (!is.null(ndraws)) ndraws <- check_count(ndraws, "ndraws", min = 1)
  check_loo_draws(x$chain, ndraws)
  rows <- loo_rows(x$chain, ndraws)
  d <- x$model$data
  group <- loo_groups(d$Xf, unit, loo_input_columns(x$model$scale))
  ll <- at_draws(x, .fbc_loo, sampler_draws(x, rows$rows), group = group)
  # densities in the response's units: y = ymean + ysd * y_scaled (each
  # row by its output's sd)
  logsd <- log(y_sd(x$model$scale, d$outF))
  if (length(logsd) == 1L) logsd <- rep(logsd, length(group))
  ll <- sweep(ll, 2, vapply(split(logsd, group), sum, numeric(1)))
  r_eff <- loo::relative_eff(exp(ll), chain_id = rows$chain)
  out <- loo::loo(ll, r_eff = r_eff)
  attr(out, "unit") <- unit
  out
}

# The rows of Phi loo.fbc() uses: at most `ndraws` in all, the same number
# from each chain (the shortest chain's length at most), evenly spaced
# within each; and each row's chain.
loo_rows <- function(chain, ndraws) {
  ids <- sort(unique(chain))
  by <- lapply(ids, function(k) which(chain == k))
  per <- min(lengths(by))
  if (!is.null(ndraws)) per <- max(1L, min(per, ndraws %/% length(ids)))
  pick <- unique(as.integer(round(seq(1, min(lengths(by)), length.out = per))))
  list(rows = unlist(lapply(by, function(i) i[pick])),
       chain = rep(seq_along(ids), each = length(pick)))
}

# The group of each field row: its distinct input (numbered in order of
# first appearance) or itself. `cols`: the columns of Xf that make the
# input (all by default).
loo_groups <- function(Xf, unit, cols = seq_len(ncol(Xf))) {
  if (unit == "observation") seq_len(nrow(Xf)) else distinct_rows(Xf[, cols, drop = FALSE])
}

# The columns of the scaled field inputs that say where an observation was
# made, for unit = "input": every experimental input but the output's
# indicators (the data set, `source`, is not among them). The outputs and
# data sets observed at one input are left out together, as its replicates
# are: they share its bias (correlated across outputs by rhoB, across data
# sets by rhoD), so one left out while the others stay in would be
# predicted from them whatever the calibration.
loo_input_columns <- function(scale) {
  cols <- seq_len(scale$p)
  out <- scale$output$columns
  if (is.null(out)) return(cols)
  setdiff(cols, match(out, scale$names$inputs))
}

# loo() needs a few draws per chain for the relative efficiencies
# (loo::relative_eff fails with one): at least `fbc_loo_per_chain`, from
# `ndraws` and from what the chains kept (an interrupted chain may keep
# fewer than calibrate()'s 2).
fbc_loo_per_chain <- 2L
check_loo_draws <- function(chain, ndraws, call = parent.frame()) {
  k <- length(unique(chain))
  kept <- min(tabulate(match(chain, unique(chain))))
  need <- fbc_loo_per_chain
  if (kept < need) {
    cli::cli_abort(c(
      "{.fn loo} needs at least {need} draws per chain for the relative efficiencies of the chains; {.arg x} keeps {kept} in its shortest chain.",
      i = "Run the chains longer with {.code update(fit, nMCMC = ...)}."
    ), call = call)
  }
  if (!is.null(ndraws) && ndraws %/% k < need) {
    cli::cli_abort(c(
      "{.arg ndraws} = {ndraws} gives {ndraws %/% k} draw{?s} per chain over {k} chain{?s}; {.fn loo} needs at least {need} per chain for the relative efficiencies.",
      i = "Use {.code ndraws = {need * k}} or more (or {.code NULL} for all draws)."
    ), call = call)
  }
  invisible()
}
