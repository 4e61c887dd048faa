#' Is the emulator good enough for the calibration?
#'
#' Compares the posterior of each calibration input from an emulator-based
#' fit (runs of the simulator as `sim`) with the one from the simulator
#' itself (the function as `sim`, see "The simulator as a function" in
#' `vignette("model", package = "FBC")`), same field data and model otherwise. The emulator's
#' error enters the calibration through kappa: a validation of its
#' predictions ([emulator_cv()]) says how well it predicts runs, not
#' how far it moves kappa's posterior. This says the latter.
#'
#' Per calibration input, in units of the function-based posterior sd:
#' * `distance`: the Wasserstein-1 distance between the two posteriors,
#'   \eqn{\int_0^1 |F_e^{-1}(u) - F_f^{-1}(u)| du} from the draws' quantiles
#'   (0 for the same distribution; a shift by one sd gives 1);
#' * `shift`: the difference of the medians (emulator minus function);
#' * `widthRatio`: the ratio of the 90% intervals' widths (emulator over
#'   function).
#'
#' Two fits of the same posterior differ by Monte Carlo error alone: with
#' bulk ESS of 400 or more in each, distances below about 0.1 are within it.
#' A distance above `tolerance` is reported as the emulator moving kappa.
#'
#' @param emulated An `fbc` fit with runs of the simulator as `sim`.
#' @param direct An `fbc` fit with the simulator function as `sim`, same
#'   field data.
#' @param tolerance The distance (in posterior sd) above which the emulator
#'   is said to move kappa; default 0.2.
#' @param x An `fbc_emulator_vs_direct`.
#' @param ... Not used.
#' @return An `fbc_emulator_vs_direct`: a data frame with one row per
#'   calibration input (`kappa`, `name`, `distance`, `shift`, `widthRatio`,
#'   `medianEmulated`, `medianFunction`, `moved`), with the draws kept for
#'   [plot()] (a ggplot of both posteriors per input).
#' @seealso [calibrate()], [emulator_cv()]
#' @export
#' @examples
#' f <- function(x, kappa) 5 * exp(-kappa[["u"]] * x$t)
#' field <- as.data.frame(kineticField)
#' set.seed(1)
#' direct <- calibrate(f, field, kappaDist = "uniform", kappaP1 = c(u = 0.5),
#'                     kappaP2 = c(u = 3), discrepancy = "none", nMCMC = 1000,
#'                     nBurn = 300, nChains = 2)
#' emulated <- calibrate(kineticSim, field, kappaDist = "uniform", kappaP1 = 0.5,
#'                       kappaP2 = 3, discrepancy = "none", nMCMC = 1000,
#'                       nBurn = 300, nChains = 2)
#' check <- emulator_vs_direct(emulated, direct)
#' check
#' plot(check)
emulator_vs_direct <- function(emulated, direct, tolerance = 0.2) {
  emulated <- check_fbc(emulated, "emulated")
  direct <- check_fbc(direct, "direct")
  if (!is.null(emulated$model$simulator) || is.null(direct$model$simulator)) {
    cli::cli_abort(c(
      "{.arg emulated} must be a fit of runs and {.arg direct} a fit of the simulator function.",
      i = "{.arg emulated}: {.code calibrate(runs, field, ...)}; {.arg direct}: {.code calibrate(f, field, ...)}."
    ))
  }
  if (!is.numeric(tolerance) || length(tolerance) != 1L || is.na(tolerance) || tolerance <= 0) {
    cli::cli_abort("{.arg tolerance} must be a positive number, not {format_choice(tolerance)}.")
  }
  q <- direct$model$scale$q
  same <- length(emulated$model$data$yf) == length(direct$model$data$yf) &&
    isTRUE(all.equal(emulated$model$data$yf * emulated$model$scale$ysd + emulated$model$scale$ymean,
                     direct$model$data$yf * direct$model$scale$ysd + direct$model$scale$ymean, tolerance = 1e-10))
  if (emulated$model$scale$q != q || !same) {
    cli::cli_abort(c(
      "{.arg emulated} and {.arg direct} must calibrate the same field data with the same number of calibration inputs.",
      x = "They have {emulated$model$scale$q} and {q} calibration input{?s} and {length(emulated$model$data$yf)} and {length(direct$model$data$yf)} field rows."
    ))
  }
  u <- (seq_len(200) - 0.5) / 200
  rows <- lapply(seq_len(q), function(j) {
    e <- emulated$Phi[, j]
    f <- direct$Phi[, j]
    s <- stats::sd(f)
    qe <- stats::quantile(e, c(0.05, 0.5, 0.95), names = FALSE)
    qf <- stats::quantile(f, c(0.05, 0.5, 0.95), names = FALSE)
    data.frame(kappa = paste0("kappa", j), name = direct$model$scale$names$calibration[j],
               distance = mean(abs(stats::quantile(e, u, names = FALSE) -
                                     stats::quantile(f, u, names = FALSE))) / s,
               shift = (qe[2] - qf[2]) / s, widthRatio = (qe[3] - qe[1]) / (qf[3] - qf[1]),
               medianEmulated = qe[2], medianFunction = qf[2], stringsAsFactors = FALSE)
  })
  out <- do.call(rbind, rows)
  out$moved <- out$distance > tolerance
  attr(out, "draws") <- list(emulated = emulated$Phi[, seq_len(q), drop = FALSE],
                             direct = direct$Phi[, seq_len(q), drop = FALSE])
  attr(out, "tolerance") <- tolerance
  class(out) <- c("fbc_emulator_vs_direct", "data.frame")
  out
}

#' @rdname emulator_vs_direct
#' @export
print.fbc_emulator_vs_direct <- function(x, ...) {
  tol <- attr(x, "tolerance")
  cat("<fbc_emulator_vs_direct> kappa's posterior from the emulator against the simulator function\n")
  cat("  (distances, shifts in the function-based posterior's sd)\n")
  tab <- data.frame(x$kappa, x$name, signif(x$distance, 2), signif(x$shift, 2),
                    signif(x$widthRatio, 3), signif(x$medianEmulated, 4), signif(x$medianFunction, 4))
  names(tab) <- c("", "input", "distance", "shift", "width ratio", "median (emulator)",
                  "median (function)")
  print(tab, row.names = FALSE)
  moved <- x$name[x$moved]
  if (length(moved)) {
    cat(sprintf("! The emulator moves %s by more than %g sd: more runs near the posterior, or calibrate the function directly.\n",
                paste(moved, collapse = ", "), tol))
  } else {
    cat(sprintf("The emulator moves no calibration input by more than %g sd.\n", tol))
  }
  invisible(x)
}

#' @rdname emulator_vs_direct
#' @export
plot.fbc_emulator_vs_direct <- function(x, ...) {
  d <- attr(x, "draws")
  long <- do.call(rbind, lapply(seq_len(nrow(x)), function(j) {
    rbind(data.frame(value = d$emulated[, j], fit = "emulator", input = x$name[j]),
          data.frame(value = d$direct[, j], fit = "function", input = x$name[j]))
  }))
  ggplot2::ggplot(long, ggplot2::aes(x = .data$value, colour = .data$fit)) +
    ggplot2::geom_density() +
    ggplot2::facet_wrap(~input, scales = "free") +
    ggplot2::labs(x = NULL, y = "posterior density", colour = NULL)
}
