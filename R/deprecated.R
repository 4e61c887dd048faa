#' Deprecated functions
#'
#' These names still work and say which function replaces them:
#' * `validate_emulator()`: use [emulator_cv()], the emulator's
#'   predictions of held-out simulator runs.
#' * `emulator_check()`: use [emulator_vs_direct()], an emulator-based
#'   calibration against the one of the simulator function itself.
#'
#' @param ... Passed on to the replacement.
#' @return What the replacement returns.
#' @name FBC-deprecated
#' @keywords internal
NULL

#' @rdname FBC-deprecated
#' @export
validate_emulator <- function(...) {
  .Deprecated("emulator_cv", package = "FBC")
  emulator_cv(...)
}

#' @rdname FBC-deprecated
#' @export
emulator_check <- function(...) {
  .Deprecated("emulator_vs_direct", package = "FBC")
  emulator_vs_direct(...)
}
