#' Summarise a calibration
#'
#' `summary()` returns the posterior summary table of every parameter: mean,
#' median, mode (see [pmode()]), the bounds of the central 50% and 80%
#' intervals, the standard deviation, and the convergence diagnostics `rhat`
#' and `ess` (see [convergence_messages()]). The calibration parameters are in
#' their own units, every hyperparameter on the scaled space of
#' [calibrate()].
#'
#' @param object An `fbc` object from [calibrate()].
#' @param ... Not used: an argument given here is an error for `summary()`
#'   and `coef()` (a typo would otherwise be ignored silently), a warning for
#'   `print()`.
#' @return `summary()`: a data frame of class `summary.fbc`, one row per
#'   parameter (the `estimates` element of the fit). With several
#'   measurement-error groups (outputs or field data sets) its `print()`
#'   says which `sigma2E` is whose.
#' @export
#' @examples
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 500, nBurn = 200, thinning = 3,
#'                  nChains = 2)
#' summary(fit)
#' coef(fit)
#' coef(fit, stat = "median")["kappa1"]
summary.fbc <- function(object, ...) {
  check_dots_empty(..., fn = summary.fbc, name = "summary")
  object <- check_fbc(object, "object")
  # (several measurement-error groups: which variance is whose, for print())
  structure(object$estimates, class = c("summary.fbc", "data.frame"),
            noiseLabels = object$model$scale$noiseLabels)
}

#' @rdname summary.fbc
#' @param x A `summary.fbc` object.
#' @param digits Significant digits.
#' @export
print.summary.fbc <- function(x, digits = 3, ...) {
  digits <- check_count(digits, "digits")
  check_dots_empty(..., fn = print.summary.fbc, name = "print", cls = "summary.fbc", action = "warn")
  df <- as.data.frame(unclass(x), stringsAsFactors = FALSE)
  attr(df, "row.names") <- attr(x, "row.names")
  num <- vapply(df, is.numeric, logical(1))
  # each number with its own significant digits (a column may span magnitudes)
  df[num] <- lapply(df[num], function(col) {
    formatC(col, digits = digits, format = "fg", flag = "#")
  })
  print(df, right = TRUE)
  lab <- attr(x, "noiseLabels")
  if (!is.null(lab)) cat(noise_labels_line(lab), "\n", sep = "")
  invisible(x)
}

# Which measurement-error variance is whose (print() of a fit and of its
# summary): "measurement error: sigma2E1 = conc, sigma2E2 = rate".
noise_labels_line <- function(labels) {
  paste0("measurement error: ", paste0("sigma2E", seq_along(labels), " = ", labels, collapse = ", "))
}

#' @rdname summary.fbc
#' @param stat `"mean"` (default), `"median"` or `"mode"` (see [pmode()]):
#'   which posterior summary `coef()` returns.
#' @return `coef()`: a named numeric vector, one value per parameter.
#' @export
coef.fbc <- function(object, stat = c("mean", "median", "mode"), ...) {
  check_dots_empty(..., fn = coef.fbc, name = "coef")
  stat <- match_choice(stat, c("mean", "median", "mode"), "stat")
  object <- check_fbc(object, "object")
  stats::setNames(object$estimates[[stat]], rownames(object$estimates))
}

#' Fitted values and residuals of a calibration
#'
#' `fitted()` gives the calibrated model's prediction of the field response
#' at each field observation's inputs: the predictive mean of
#' [predict.fbc()] (`type = "field"`) given all the data, averaged over up
#' to 1000 posterior draws (`method = "Bayesian"`) or at the MAP draw
#' (`method = "MAP"`, as `plot(fit, type = "fits")` shows). `residuals()`
#' is the observed field response minus these. Both are in the response's
#' units, one value per row of the field data, in its order. The
#' observations are part of the data each prediction is conditioned on, so
#' these residuals are smaller than out-of-sample errors; [ppc_field()]
#' checks the observations against their predictive distributions.
#'
#' `as.matrix()` returns the retained draws, `x$Phi`: one row per draw
#' (chains stacked, their ids in `x$chain`), one column per parameter.
#'
#' @param object,x An `fbc` object from [calibrate()].
#' @param method `"Bayesian"` (default) or `"MAP"`, as in [predict.fbc()].
#' @param ... Not used: an argument given here is an error.
#' @return `fitted()`, `residuals()`: a numeric vector, one value per field
#'   observation. `as.matrix()`: a draws x parameters matrix.
#' @export
#' @examples
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 500, nBurn = 200, thinning = 3,
#'                  nChains = 2)
#' head(fitted(fit, method = "MAP"))
#' sd(residuals(fit, method = "MAP"))
#' dim(as.matrix(fit))
fitted.fbc <- function(object, method = c("Bayesian", "MAP"), ...) {
  check_dots_empty(..., fn = fitted.fbc, name = "fitted")
  object <- check_fbc(object, "object")
  method <- match_choice(method, c("Bayesian", "MAP"), "method")
  rows <- check_rows(object, method, 1000L)
  # the Bayesian prediction's mean: the average of the draws' means
  rowMeans(field_conditionals(object, sampler_draws(object, rows), 1L)$mean)
}

#' @rdname fitted.fbc
#' @export
residuals.fbc <- function(object, method = c("Bayesian", "MAP"), ...) {
  check_dots_empty(..., fn = residuals.fbc, name = "residuals")
  object <- check_fbc(object, "object")
  method <- match_choice(method, c("Bayesian", "MAP"), "method")
  field_response(object) - fitted.fbc(object, method = method)
}

#' @rdname fitted.fbc
#' @export
as.matrix.fbc <- function(x, ...) {
  check_dots_empty(..., fn = as.matrix.fbc, name = "as.matrix")
  check_fbc(x, "x")$Phi
}
