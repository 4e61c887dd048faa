#' Calibrated prediction
#'
#' Predicts the field response (or the calibrated simulator, the discrepancy,
#' or the noise-free field mean) at new experimental inputs, with the
#' uncertainty the posterior carries.
#'
#' @section Formulas:
#' All computations are on the scaled space of [calibrate()]. For a draw
#' \eqn{\phi} of the parameters, a new input \eqn{x^*} and \eqn{x_\kappa^* =
#' (x^*, \kappa)}, the training responses \eqn{y = (y_f, y_s)} have mean
#' \eqn{\mu = (\mu_B 1_n, 0)} and covariance \eqn{C} (see [calibrate()]). With
#' \eqn{k} the covariance between \eqn{y} and the target, \eqn{\mu^*} and
#' \eqn{v^*} its prior mean and variance, the GP conditional is
#' \deqn{m(x^*) = \mu^* + k' C^{-1} (y - \mu), \quad
#'       v(x^*) = v^* - k' C^{-1} k,}
#' where, by `type`:
#' * `"field"`, \eqn{y_f^* = \eta(x_\kappa^*) + \delta(x^*) + \epsilon}:
#'   \eqn{k_f = \sigma^2_S R_s(X_\kappa, x_\kappa^*) + \sigma^2_B R_b(X_f, x^*)},
#'   \eqn{k_s = \sigma^2_S R_s(X_s, x_\kappa^*)}, \eqn{\mu^* = \mu_B},
#'   \eqn{v^* = \sigma^2_S + \sigma^2_B + \sigma^2_E} (measurement error
#'   included, as in the reference vignette);
#' * `"mean"`, \eqn{\eta(x_\kappa^*) + \delta(x^*)}: as `"field"` with
#'   \eqn{v^* = \sigma^2_S + \sigma^2_B};
#' * `"simulator"`, the calibrated emulator \eqn{\eta(x^*, \kappa)}:
#'   \eqn{k_f = \sigma^2_S R_s(X_\kappa, x_\kappa^*)},
#'   \eqn{k_s = \sigma^2_S R_s(X_s, x_\kappa^*)}, \eqn{\mu^* = 0},
#'   \eqn{v^* = \sigma^2_S};
#' * `"bias"`, the discrepancy \eqn{\delta(x^*)}:
#'   \eqn{k_f = \sigma^2_B R_b(X_f, x^*)}, \eqn{k_s = 0}, \eqn{\mu^* = \mu_B},
#'   \eqn{v^* = \sigma^2_B}.
#'
#' \eqn{C^{-1}} is never formed: the Cholesky factors of the simulator block
#' and of its Schur complement are computed once per draw and shared by all
#' new points, which are processed in blocks of 500 rows. Results are
#' returned in the response's units: \eqn{\bar y_s + s_y m} (a difference
#' \eqn{s_y m} for `"bias"`) with standard error \eqn{s_y \sqrt{v}}.
#'
#' `method = "Bayesian"` (reference section 4.2) computes \eqn{m_i, v_i} for
#' every retained draw; the prediction is \eqn{\bar m = \frac1M\sum m_i} and,
#' by the law of total variance, \eqn{\mathrm{Var} = \frac1M \sum v_i +
#' \frac{1}{M-1}\sum (m_i - \bar m)^2}. The interval bounds are quantiles of
#' the predictive distribution itself, the equal-weight mixture of the
#' \eqn{N(m_i, v_i)}, found numerically. `method = "MAP"` (section 4.3) uses
#' only the draw with the highest log posterior and a Gaussian interval.
#'
#' @param object An `fbc` object from [calibrate()].
#' @param newdata New experimental inputs in their own units: a numeric matrix
#'   or data frame with the `p` experimental input columns (a vector when
#'   `p = 1`).
#' @param method `"Bayesian"` (average over all retained draws) or `"MAP"`
#'   (the draw with the highest log posterior).
#' @param type What to predict: `"field"` (a new field observation),
#'   `"mean"` (the field response without measurement error), `"simulator"`
#'   (the calibrated simulator \eqn{\eta(x, \kappa)}) or `"bias"` (the
#'   discrepancy \eqn{\delta(x)}).
#' @param level Probability of the interval `[lower, upper]`.
#' @param draws If `TRUE`, also return the per-draw predictive means.
#' @param ... Unused.
#' @return A list with `pred`, `se`, `lower` and `upper` (one value per row of
#'   `newdata`, in the response's units) and, when `draws = TRUE`, `draws`: a
#'   matrix with one row per new point and one column per draw used.
#' @export
#' @examples
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 500, nBurn = 200, thinning = 3)
#' predict(fit, c(2.2, 2.4))
#' predict(fit, c(2.2, 2.4), method = "MAP")
#' predict(fit, c(2.2, 2.4), type = "bias")
predict.fbc <- function(object, newdata, method = c("Bayesian", "MAP"),
                        type = c("field", "mean", "simulator", "bias"),
                        level = 0.95, draws = FALSE, ...) {
  method <- match_choice(method, c("Bayesian", "MAP"), "method")
  type <- match_choice(type, c("field", "mean", "simulator", "bias"), "type")
  if (!is.numeric(level) || length(level) != 1L || is.na(level) || level <= 0 || level >= 1) {
    cli::cli_abort("{.arg level} must be a single number strictly between 0 and 1.")
  }
  check_flag(draws, "draws")
  sc <- object$scale
  X <- check_newdata(newdata, sc$p)
  Xn <- scale_inputs(X, sc, seq_len(sc$p))

  rows <- if (method == "MAP") which.max(object$logPost) else seq_len(nrow(object$Phi))
  phis <- sampler_scale(object$Phi[rows, , drop = FALSE], sc)
  mc <- model_codes(object$spec)
  res <- .fbc_predict(object$data$Xf, object$data$yf, object$data$Xs, object$data$ys,
                      phis, Xn, match(type, c("field", "mean", "simulator", "bias")),
                      object$settings$nugget %||% fbc_nugget, 500L, mc$kernS, mc$kernB,
                      mc$algebra)
  shift <- if (type == "bias") 0 else sc$ymean
  m <- shift + sc$ysd * res$mean
  v <- sc$ysd^2 * pmax(res$var, 0)

  if (method == "MAP") {
    pred <- m[, 1]
    se <- sqrt(v[, 1])
    z <- stats::qnorm((1 + level) / 2)
    lower <- pred - z * se
    upper <- pred + z * se
  } else {
    pred <- rowMeans(m)
    M <- ncol(m)
    spread <- if (M > 1L) rowSums((m - pred)^2) / (M - 1L) else 0
    se <- sqrt(rowMeans(v) + spread)
    lower <- mixture_quantile(m, sqrt(v), (1 - level) / 2)
    upper <- mixture_quantile(m, sqrt(v), (1 + level) / 2)
  }
  out <- list(pred = pred, se = se, lower = lower, upper = upper)
  if (draws) out$draws <- m
  out
}

# Parameter draws in the sampler's parameterisation: kappa back to [0, 1].
sampler_scale <- function(Phi, scale) {
  q <- scale$q
  cal <- scale$p + seq_len(q)
  Phi[, seq_len(q)] <- sweep(sweep(Phi[, seq_len(q), drop = FALSE], 2, scale$xmin[cal], "-"),
                             2, scale$xmax[cal] - scale$xmin[cal], "/")
  unname(Phi)
}

# Quantile `prob` of the equal-weight Gaussian mixture sum_i N(mu[, i], sd[, i]^2) / M,
# for every row at once, by bisection on the mixture CDF.
mixture_quantile <- function(mu, sd, prob, tol = 1e-10) {
  z <- stats::qnorm(prob)
  lo <- apply(mu + z * sd, 1, min)  # every component's quantile brackets the mixture's
  hi <- apply(mu + z * sd, 1, max)
  width <- max(hi - lo)
  scale_ <- max(abs(c(lo, hi)), 1)
  iter <- 0L
  while (width > tol * scale_ && iter < 200L) {
    mid <- (lo + hi) / 2
    cdf <- rowMeans(stats::pnorm(mid, mu, sd))
    below <- cdf < prob
    lo[below] <- mid[below]
    hi[!below] <- mid[!below]
    width <- max(hi - lo)
    iter <- iter + 1L
  }
  (lo + hi) / 2
}

# New experimental inputs as a double matrix with p columns.
check_newdata <- function(newdata, p, call = parent.frame()) {
  if (is.data.frame(newdata)) {
    bad <- !vapply(newdata, is.numeric, logical(1))
    if (any(bad)) {
      cli::cli_abort(c(
        "{.arg newdata} must contain only numeric columns.",
        x = "Column{?s} {.val {names(newdata)[bad]}} {?is/are} not numeric."
      ), call = call)
    }
    newdata <- as.matrix(newdata)
  }
  if (is.numeric(newdata) && is.null(dim(newdata))) {
    if (p != 1L) {
      cli::cli_abort(c(
        "{.arg newdata} must be a matrix or data frame with {p} columns (one per experimental input).",
        i = "A vector is accepted only when there is one experimental input."
      ), call = call)
    }
    newdata <- matrix(newdata, ncol = 1L)
  }
  if (!is.matrix(newdata) || !is.numeric(newdata)) {
    cli::cli_abort(
      "{.arg newdata} must be a numeric matrix, data frame or vector, not {.obj_type_friendly {newdata}}.",
      call = call
    )
  }
  if (ncol(newdata) != p) {
    cli::cli_abort(
      "{.arg newdata} must have {p} column{?s} (one per experimental input); it has {ncol(newdata)}.",
      call = call
    )
  }
  if (nrow(newdata) < 1L) cli::cli_abort("{.arg newdata} has no rows.", call = call)
  if (any(!is.finite(newdata))) {
    where <- which(!is.finite(newdata), arr.ind = TRUE)[1, ]
    cli::cli_abort(c(
      "{.arg newdata} must not contain NA, NaN or infinite values.",
      x = "Found {sum(!is.finite(newdata))} such value{?s}; the first is in row {where[1]}, column {where[2]}."
    ), call = call)
  }
  storage.mode(newdata) <- "double"
  unname(newdata)
}

# One of `choices` (the first when `x` is the default vector).
match_choice <- function(x, choices, arg, call = parent.frame()) {
  if (identical(x, choices)) return(choices[1])
  if (!is.character(x) || length(x) != 1L || is.na(x) || !(x %in% choices)) {
    cli::cli_abort(
      "{.arg {arg}} must be one of {.or {.val {choices}}}, not {.val {format_value(x)}}.",
      call = call
    )
  }
  x
}
