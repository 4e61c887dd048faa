#' Print a calibration
#'
#' Shows the data sizes, the MCMC settings, the acceptance rates and the
#' posterior summary of every parameter.
#'
#' @param x An `fbc` object from [calibrate()].
#' @param digits Significant digits for the table.
#' @param ... Unused.
#' @return `x`, invisibly.
#' @export
print.fbc <- function(x, digits = 3, ...) {
  s <- x$settings
  cat("<fbc> Full Bayesian calibration (Kennedy-O'Hagan)\n")
  cat(sprintf("  data: n = %d field, m = %d simulator runs; p = %d, q = %d\n",
              length(x$data$yf), length(x$data$ys), x$scale$p, x$scale$q))
  cat(sprintf("  MCMC: %d iterations, %d burn-in, thinning %d -> %d draws (%.1f s)\n",
              s$nMCMC, s$nBurn, s$thinning, nrow(x$Phi), s$time))
  acc <- x$acceptance[!is.na(x$acceptance)]
  if (length(acc)) {
    cat(sprintf("  acceptance: %.2f to %.2f (target 0.44)\n", min(acc), max(acc)))
  }
  cat("\n")
  print(format(x$estimates, digits = digits), quote = FALSE)
  invisible(x)
}
