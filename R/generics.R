#' Posterior predictive draws, expected values and pointwise log-likelihoods
#'
#' The generics of \pkg{rstantools} that R's Bayesian modelling packages
#' share, for a calibration: with them `tidybayes::add_predicted_draws()`,
#' `tidybayes::add_epred_draws()` and the \pkg{loo} and \pkg{bayesplot}
#' functions that take matrices of draws work on a fit.
#'
#' * `posterior_predict()`: draws of a new field observation
#'   (\eqn{\eta(x, \kappa) + \delta(x) + \epsilon}, measurement error
#'   included) at `newdata`, one row per posterior draw.
#' * `posterior_epred()`: the expected value of that observation given each
#'   draw and the data, the calibrated field mean \eqn{\eta(x, \kappa) +
#'   \delta(x)} (`predict(type = "mean")`'s per-draw mean).
#' * `log_lik()`: the pointwise log-likelihood, for each draw the log
#'   density of each field observation (or input, `unit = "input"`) given
#'   all the other data: the field observations are correlated, so these are
#'   the non-factorized leave-one-out terms that [loo.fbc()] uses.
#'
#' Each draw of `posterior_predict()` takes each new point's value from its
#' Gaussian predictive distribution given that posterior draw and the data;
#' the points are drawn independently of each other given the draw, so each
#' column has the right distribution and the pointwise intervals are
#' right, but the correlation between points within a draw is not kept
#' (use [predict()] with `draws = TRUE` for the per-draw means). Values are
#' in the response's units.
#'
#' The generics are re-exported from \pkg{rstantools}, so they can be
#' called after `library(FBC)` alone.
#'
#' @param object An `fbc` object from [calibrate()].
#' @param newdata The new experimental inputs, as for [predict.fbc()]; `NULL`
#'   (the default) for the field data's inputs.
#' @param ndraws How many posterior draws, evenly spaced over all retained
#'   draws; `NULL` (the default) for all.
#' @param draws The same as `ndraws` (the name rstanarm uses).
#' @param unit `"observation"` (the default) or `"input"`: what `log_lik()`
#'   leaves out, as in [loo.fbc()].
#' @param ... Ignored by these methods (tidybayes passes its own arguments).
#' @return A matrix with one row per posterior draw used and one column per
#'   point of `newdata` (the field rows when `newdata` is `NULL`; for
#'   `log_lik()`, the field observations or inputs in the order of their
#'   first row). `attr(, "draw_rows")` gives the draws' rows in `fit$Phi`.
#' @seealso [predict.fbc()], [ppc_field()], [loo.fbc()]
#' @examples
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, nChains = 2,
#'                  converge = FALSE)
#' yrep <- posterior_predict(fit, newdata = c(2.2, 2.4), ndraws = 50)
#' dim(yrep)
#' mu <- posterior_epred(fit, newdata = c(2.2, 2.4), ndraws = 50)
#' colMeans(mu)
#' dim(log_lik(fit, ndraws = 20))
#' @name fbc-generics
NULL

#' @importFrom rstantools posterior_predict
#' @export
rstantools::posterior_predict

#' @importFrom rstantools posterior_epred
#' @export
rstantools::posterior_epred

#' @importFrom rstantools log_lik
#' @export
rstantools::log_lik

#' @importFrom rstantools prior_summary
#' @export
rstantools::prior_summary

#' @rdname fbc-generics
#' @method posterior_predict fbc
#' @export
posterior_predict.fbc <- function(object, newdata = NULL, ndraws = NULL, draws = NULL, ...) {
  object <- check_fbc(object, "object")
  pd <- predictive_draws(object, newdata, ndraws %||% draws, "field")
  n <- length(pd$mean)
  out <- t(pd$mean + pd$sd * matrix(stats::rnorm(n), nrow(pd$mean), ncol(pd$mean)))
  attr(out, "draw_rows") <- pd$rows
  out
}

#' @rdname fbc-generics
#' @method posterior_epred fbc
#' @export
posterior_epred.fbc <- function(object, newdata = NULL, ndraws = NULL, draws = NULL, ...) {
  object <- check_fbc(object, "object")
  pd <- predictive_draws(object, newdata, ndraws %||% draws, "mean")
  out <- t(pd$mean)
  attr(out, "draw_rows") <- pd$rows
  out
}

#' @rdname fbc-generics
#' @method log_lik fbc
#' @export
log_lik.fbc <- function(object, unit = c("observation", "input"), ndraws = NULL, draws = NULL,
                        ...) {
  object <- check_fbc(object, "object")
  unit <- match_choice(unit, c("observation", "input"), "unit")
  ndraws <- ndraws %||% draws
  if (!is.null(ndraws)) ndraws <- check_count(ndraws, "ndraws", min = 1)
  rows <- loo_rows(object$chain, ndraws)
  d <- object$model$data
  group <- loo_groups(d$Xf, unit, loo_input_columns(object$model$scale))
  ll <- at_draws(object, .fbc_loo, sampler_draws(object, rows$rows), group = group)
  # densities in the response's units (each row by its output's sd)
  logsd <- log(y_sd(object$model$scale, d$outF))
  if (length(logsd) == 1L) logsd <- rep(logsd, length(group))
  ll <- sweep(ll, 2, vapply(split(logsd, group), sum, numeric(1)))
  attr(ll, "draw_rows") <- rows$rows
  ll
}

#' The number of field observations and the priors of a calibration
#'
#' `nobs()` is the number of field observations the fit was calibrated
#' against (the rows of `field`). `prior_summary()` lists every parameter's
#' prior as the model holds it: one row per parameter, its class, the prior
#' family and its parameters, and the initial value. The priors act on the
#' scaled space of [calibrate()] (inputs on \eqn{[0, 1]}, the response
#' standardised); `kappa`'s on its own range.
#'
#' @param object An `fbc` object from [calibrate()].
#' @param ... Not used: an argument given here is an error.
#' @return `nobs()`: an integer. `prior_summary()`: a data frame with
#'   columns `parameter`, `class`, `prior` (as [set_hyperPriors()] prints
#'   it), `family`, `p1`, `p2`, `init` and `fixed`.
#' @seealso [set_hyperPriors()] and [prior_builder()] to set them.
#' @examples
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 200, nBurn = 100, nChains = 2,
#'                  converge = FALSE)
#' nobs(fit)
#' prior_summary(fit)
#' @name fbc-priors
NULL

#' @rdname fbc-priors
#' @importFrom stats nobs
#' @export
nobs.fbc <- function(object, ...) {
  check_dots_empty(..., fn = nobs.fbc, name = "nobs")
  object <- check_fbc(object, "object")
  length(object$model$data$yf)
}

#' @rdname fbc-priors
#' @method prior_summary fbc
#' @export
prior_summary.fbc <- function(object, ...) {
  check_dots_empty(..., fn = prior_summary.fbc, name = "prior_summary")
  object <- check_fbc(object, "object")
  spec <- object$model$spec
  cls <- spec$classes
  rows <- lapply(unique(cls), function(cl) {
    pr <- spec$priors[[cl]]
    k <- sum(cls == cl)
    at <- function(v, i) v[(i - 1L) %% length(v) + 1L]
    data.frame(
      parameter = spec$vars[cls == cl], class = cl,
      prior = vapply(seq_len(k), function(i) {
        format_prior(at(pr$dist, i), at(pr$p1, i), at(pr$p2, i), at(pr$init, i))
      }, character(1)),
      family = vapply(seq_len(k), function(i) at(pr$dist, i), character(1)),
      p1 = vapply(seq_len(k), function(i) at(pr$p1, i), numeric(1)),
      p2 = vapply(seq_len(k), function(i) at(pr$p2, i), numeric(1)),
      init = vapply(seq_len(k), function(i) at(pr$init, i), numeric(1)),
      stringsAsFactors = FALSE
    )
  })
  out <- do.call(rbind, rows)
  out$fixed <- out$family == "fixed"
  rownames(out) <- NULL
  out
}

# Each draw's Gaussian predictive mean and sd (points x draws, in the
# response's units) of target `type` at `newdata` (the field inputs when
# NULL), through the same steps as predict.fbc(); `rows`, the draws used.
predictive_draws <- function(object, newdata, ndraws, type, call = parent.frame()) {
  if (!is.null(ndraws)) ndraws <- check_count(ndraws, "ndraws", min = 1, call = call)
  rows <- draw_rows(nrow(object$Phi), ndraws)
  phis <- sampler_draws(object, rows)
  code <- predict_type_codes[[type]]
  if (is.null(newdata)) {
    fc <- field_conditionals(object, phis, code)
    return(list(mean = fc$mean, sd = fc$sd, rows = rows))
  }
  sc <- object$model$scale
  nf <- read_newdata_factors(newdata, sc, type, call = call)
  X <- check_newdata(nf$newdata, sc, call = call)
  warn_newdata_outside(X, object, call = call)
  warn_kappa_beyond(object, rows, call = call)
  Xn <- scale_inputs(X, sc, seq_len(sc$p))
  res <- at_draws(object, .fbc_predict, phis, Xnew = Xn, type = code, block = 500L,
                  noise = nf$noise, source = nf$source)
  list(mean = y_mean(sc, nf$output) + y_sd(sc, nf$output) * res$mean,
       sd = y_sd(sc, nf$output) * sqrt(pmax(res$var, 0)), rows = rows)
}
