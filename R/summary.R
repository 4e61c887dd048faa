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
#'   parameter (the `estimates` element of the fit).
#' @export
#' @examples
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 500, nBurn = 200, thinning = 3)
#' summary(fit)
#' coef(fit)
#' coef(fit, stat = "median")["kappa1"]
summary.fbc <- function(object, ...) {
  check_dots_empty(..., fn = summary.fbc, name = "summary")
  object <- check_fbc(object, "object")
  structure(object$estimates, class = c("summary.fbc", "data.frame"))
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
  invisible(x)
}

#' @rdname summary.fbc
#' @param stat `"mean"` (default) or `"median"`: which posterior summary
#'   `coef()` returns.
#' @return `coef()`: a named numeric vector, one value per parameter.
#' @export
coef.fbc <- function(object, stat = c("mean", "median"), ...) {
  check_dots_empty(..., fn = coef.fbc, name = "coef")
  stat <- match_choice(stat, c("mean", "median"), "stat")
  object <- check_fbc(object, "object")
  stats::setNames(object$estimates[[stat]], rownames(object$estimates))
}
