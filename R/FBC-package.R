#' FBC: Full Bayesian Calibration of computer models
#'
#' Fits the Kennedy-O'Hagan calibration model (a GP emulator of the
#' simulator, a GP discrepancy and measurement error) and samples every
#' unknown by adaptive Metropolis-within-Gibbs in C++. Start with
#' [calibrate()].
#'
#' @keywords internal
#' @useDynLib FBC, .registration = TRUE
#' @importFrom Rcpp sourceCpp
#' @importFrom cli cli_abort cli_warn
"_PACKAGE"

.onLoad <- function(libname, pkgname) {
  # the compiled core switches on the registry's prior family codes
  check_prior_codes()
  # ... and on its own code tables (walks, kernels, algebras, ...)
  check_model_codes()
}
