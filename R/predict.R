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
#' A fit without a discrepancy (`calibrate(discrepancy = "none")`) has
#' \eqn{\sigma^2_B = \mu_B = 0} in these formulas: `"bias"` is exactly 0
#' with standard error 0, `"mean"` equals `"simulator"`, and `"field"` adds
#' \eqn{\sigma^2_E}.
#'
#' \eqn{C^{-1}} is never formed: the Cholesky factors of the simulator block
#' and of its Schur complement are computed once per draw and shared by a
#' block of new points (see "Memory and time"). Results are
#' returned in the response's units: \eqn{\bar y_s + s_y m} (a difference
#' \eqn{s_y m} for `"bias"`) with standard error \eqn{s_y \sqrt{v}}.
#'
#' `method = "Bayesian"` (reference section 4.2) computes \eqn{m_i, v_i} for
#' every retained draw; the prediction is \eqn{\bar m = \frac1M\sum m_i} and,
#' by the law of total variance, \eqn{\mathrm{Var} = \frac1M \sum v_i +
#' \frac{1}{M-1}\sum (m_i - \bar m)^2}. The interval bounds are quantiles of
#' the predictive distribution itself, the equal-weight mixture of the
#' \eqn{N(m_i, v_i)} over the draws used, found numerically to a relative
#' 1e-10 (Newton's method on the mixture's distribution function, within a
#' bisection bracket). `method = "MAP"` (section 4.3) uses only the draw with
#' the highest log posterior and a Gaussian interval.
#'
#' @section Memory and time:
#' `method = "Bayesian"` uses at most `ndraws` draws (1000 by default, evenly
#' spaced over all retained draws of all chains, as \pkg{brms} does; the
#' rows used are in `attr(result, "draw_rows")`): the Monte Carlo error of
#' the prediction is then far below its standard error for a well-mixed fit,
#' and `ndraws = NULL` uses every draw. The new points are processed in
#' blocks whose points x draws means and variances take at most about 100 MB
#' (about 0.5 GB at the peak, with the interval computation's temporaries),
#' so memory does not grow with the number of points;
#' each block refactorizes every draw's covariance, a small cost next to the
#' predictions (blocks have at least 500 points). A progress bar appears
#' when there are several blocks and the prediction takes more than a couple
#' of seconds (interactive sessions only). The time grows with points x
#' draws: on the ball data (m = 100 runs, n = 63 field points) 5000 points
#' with 1000 draws take about a minute of CPU. With the nearest-neighbour
#' algebra each draw refactorizes the run side, so the default costs about
#' ndraws factorizations, a minute or more at m in the thousands:
#' `ndraws = 100` is ten times cheaper, `method = "MAP"` costs one draw. `draws = TRUE` returns the
#' whole points x draws matrix (8 bytes each: 40 MB for 5000 points and
#' 1000 draws), which does not fit in the blocks' budget: use it with a
#' moderate `ndraws`.
#'
#' @section Calibration values beyond the design:
#' When more than 1% of the draws used put a calibration parameter beyond the
#' range the simulator design covers for it (by more than 5% of that range's
#' width), `predict()` warns (class `fbc_extrapolation`), naming the
#' parameter, the share of draws and their range: there the prediction rests
#' on the emulator's extrapolation (see "Checks" in `vignette("model", package = "FBC")`).
#'
#' @param object An `fbc` object from [calibrate()].
#' @param newdata New experimental inputs in their own units: a numeric matrix
#'   or data frame with the `p` experimental input columns (a vector when
#'   `p = 1`). When the calibration's data carried column names (see
#'   "Columns" in `vignette("model", package = "FBC")`) and `newdata` does too, its columns are
#'   matched by name, in any order, and other columns are ignored; an
#'   unnamed matrix gives the inputs by position. A column named like a
#'   calibration input is refused: every prediction, `type = "simulator"`
#'   included, is made at the posterior draws of \eqn{\kappa}, so a value
#'   given there could not be used (drop the column; [emulator_cv()]
#'   shows how the emulator predicts the simulator runs).
#' @param method `"Bayesian"` (average over the posterior draws: see
#'   `ndraws`) or `"MAP"` (the draw with the highest log posterior).
#' @param type What to predict: `"field"` (a new field observation),
#'   `"mean"` (the field response without measurement error), `"simulator"`
#'   (the calibrated simulator \eqn{\eta(x, \kappa)}) or `"bias"` (the
#'   discrepancy \eqn{\delta(x)}), or `"failure"`: the probability that a
#'   simulator run at `newdata` fails, for a fit whose `sim` had failed
#'   runs (see `failedRuns` in [calibrate()]). For `"failure"`, `newdata`
#'   holds the simulator's inputs (experimental and calibration; by name,
#'   or in `sim`'s order without the response; missing: the runs' own
#'   inputs) and a vector of probabilities is returned; the other
#'   arguments are not used.
#' @param level Probability of the interval `[lower, upper]`.
#' @param draws If `TRUE`, also return the per-draw predictive means (a
#'   points x draws matrix: see "Memory and time").
#' @param ndraws For `method = "Bayesian"`, the number of posterior draws
#'   used: at most this many, evenly spaced over all retained draws (chains
#'   stacked), first and last included. `NULL` uses them all. Ignored by
#'   `method = "MAP"`.
#' @param ... Not used: an argument given here is an error (a typo such
#'   as `lvl =` would otherwise be ignored silently).
#' @return A list with `pred`, `se`, `lower` and `upper` (one value per row of
#'   `newdata`, in the response's units) and, when `draws = TRUE`, `draws`: a
#'   matrix with one row per new point and one column per draw used. For
#'   `type = "simulator"` with the simulator's own noise modelled
#'   ([simulator_noise]), `noiseSd`: the sd of a run's noise about
#'   \eqn{\eta} at each point (the root of the posterior mean of its
#'   variance, constant over the inputs), in the response's units. The
#'   attribute `draw_rows` gives the rows of `object$Phi` used. Its class,
#'   `fbc_prediction`, prints the first 20 points as a table.
#' @export
#' @examples
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 500, nBurn = 200, thinning = 3,
#'                  nChains = 2)
#' predict(fit, c(2.2, 2.4))
#' predict(fit, c(2.2, 2.4), method = "MAP")
#' predict(fit, c(2.2, 2.4), type = "bias")
predict.fbc <- function(object, newdata, method = c("Bayesian", "MAP"),
                        type = c("field", "mean", "simulator", "bias", "failure"),
                        level = 0.95, draws = FALSE, ndraws = 1000, ...) {
  check_dots_empty(..., fn = predict.fbc, name = "predict")
  object <- check_fbc(object, "object")
  method <- match_choice(method, c("Bayesian", "MAP"), "method")
  type <- match_choice(type, c("field", "mean", "simulator", "bias", "failure"), "type")
  if (type == "failure") return(predict_failure(object, if (!missing(newdata)) newdata))
  if (!is.numeric(level) || length(level) != 1L || is.na(level) || level <= 0 || level >= 1) {
    cli::cli_abort("{.arg level} must be a single number strictly between 0 and 1.")
  }
  check_flag(draws, "draws")
  if (!is.null(ndraws)) ndraws <- check_count(ndraws, "ndraws", min = 1)
  sc <- object$model$scale
  nf <- read_newdata_factors(newdata, sc, type)
  X <- check_newdata(nf$newdata, sc)
  warn_newdata_outside(X, object)
  Xn <- scale_inputs(X, sc, seq_len(sc$p))

  rows <- if (method == "MAP") which.max(object$logPost) else draw_rows(nrow(object$Phi), ndraws)
  warn_kappa_beyond(object, rows)
  phis <- sampler_draws(object, rows)
  N <- nrow(Xn)
  M <- length(rows)
  code <- predict_type_codes[[type]]
  shift <- if (type == "bias") 0 else y_mean(sc, nf$output)
  ysd <- y_sd(sc, nf$output)
  z <- stats::qnorm((1 + level) / 2)

  # Points in blocks, so that memory stays bounded whatever their number: a
  # block holds its points x draws means and variances (and a few matrices
  # of the same size in mixture_quantile()). Each block calls the compiled
  # code once, which factorizes the covariance of every draw again: at the
  # m of calibration problems (hundreds of runs) a factorization costs about
  # as much as predicting at a few dozen points, so blocks of >= 500 points
  # lose a few percent to it, and buy a bounded memory and a progress bar.
  B <- predict_block_size(N, M)
  pred <- se <- lower <- upper <- numeric(N)
  D <- if (draws) matrix(NA_real_, N, M) else NULL
  in_blocks(N, B, "Predicting", function(idx) {
    res <- at_draws(object, .fbc_predict, phis, Xnew = Xn[idx, , drop = FALSE], type = code,
                    block = 500L, noise = nf$noise[idx[idx <= length(nf$noise)]],
                    source = nf$source[idx[idx <= length(nf$source)]])
    at <- function(v) if (length(v) > 1L) v[idx] else v
    m <- at(shift) + at(ysd) * res$mean
    s <- at(ysd) * sqrt(pmax(res$var, 0))
    res <- NULL
    if (method == "MAP") {
      pred[idx] <<- m[, 1]
      se[idx] <<- s[, 1]
      lower[idx] <<- m[, 1] - z * s[, 1]
      upper[idx] <<- m[, 1] + z * s[, 1]
    } else {
      mbar <- rowMeans(m)
      spread <- if (M > 1L) rowSums((m - mbar)^2) / (M - 1L) else 0
      pred[idx] <<- mbar
      se[idx] <<- sqrt(rowMeans(s^2) + spread)
      lower[idx] <<- mixture_quantile(m, s, (1 - level) / 2)
      upper[idx] <<- mixture_quantile(m, s, (1 + level) / 2)
    }
    if (draws) D[idx, ] <<- m
    NULL
  })
  out <- list(pred = pred, se = se, lower = lower, upper = upper)
  if (draws) out$draws <- D
  # a stochastic simulator's own noise (R/sim_noise.R): constant, or from
  # the latent log-variances' GP at each point
  if (type == "simulator" && "sigma2R" %in% colnames(object$Phi)) {
    out$noiseSd <- rep(sqrt(mean(object$Phi[rows, "sigma2R"])) * ysd, N)
  } else if (type == "simulator" && "gR1" %in% colnames(object$Phi)) {
    out$noiseSd <- latent_noise_sd(object$model, phis, Xn) * ysd
  }
  attr(out, "draw_rows") <- rows
  class(out) <- c("fbc_prediction", "list")
  out
}

#' @export
print.fbc_prediction <- function(x, digits = 4, ...) {
  check_dots_empty(..., fn = print.fbc_prediction, name = "print", cls = "fbc_prediction",
                   action = "warn")
  digits <- check_count(digits, "digits")
  n <- length(x$pred)
  D <- length(attr(x, "draw_rows"))
  cat(sprintf("<fbc_prediction> %d point%s from %d posterior draw%s\n", n, if (n == 1L) "" else "s",
              D, if (D == 1L) "" else "s"))
  shown <- min(n, 20L)
  tab <- data.frame(pred = x$pred, se = x$se, lower = x$lower, upper = x$upper)
  print(utils::head(tab, shown), digits = digits)
  if (n > shown) cat(sprintf("... %d more point%s: see `$pred`, `$se`, `$lower`, `$upper`\n",
                             n - shown, if (n - shown == 1L) "" else "s"))
  if (!is.null(x$draws)) {
    cat(sprintf("$draws: the per-draw predictive means, %d x %d\n", nrow(x$draws), ncol(x$draws)))
  }
  invisible(x)
}

# Rows of Phi used by the Bayesian prediction: all, or `ndraws` evenly
# spaced over all retained draws (chains stacked), first and last included.
draw_rows <- function(n, ndraws) {
  if (is.null(ndraws) || ndraws >= n) return(seq_len(n))
  unique(as.integer(round(seq(1, n, length.out = ndraws))))
}

# Bytes for the per-block means and variances of predict(): points x draws x
# 2 doubles. The process's peak (with the compiled result, the rescaled
# copies and mixture_quantile()'s temporaries) is about five times this:
# 458 MB for 1000 points x 12000 draws of the ball fit.
fbc_predict_budget <- 1e8

# Points per block: as many as the budget allows, but no more than about a
# twentieth of the points (so that a long prediction shows progress) and no
# fewer than 500 (so that the per-block factorizations stay cheap).
# options(FBC.predict_block = b) forces b (tests).
predict_block_size <- function(N, M) {
  forced <- getOption("FBC.predict_block")
  if (!is.null(forced)) return(max(1L, as.integer(forced)))
  cap <- max(1, floor(fbc_predict_budget / (16 * M)))
  as.integer(max(1, min(cap, max(500, ceiling(N / 20)), N)))
}

# Quantile `prob` of the equal-weight Gaussian mixture sum_i N(mu[, i], sd[, i]^2) / M,
# for every row at once: the root of F(x) = mean_i Phi((x - mu_i) / sd_i) - prob,
# by Newton's method (F' = mean_i phi((x - mu_i) / sd_i) / sd_i) inside a
# bracket that always holds the root, starting with the smallest and largest
# component quantiles. A Newton step that leaves the bracket (F is convex in
# the left tail, concave in the right, so Newton overshoots from one side)
# is replaced by the secant of the bracket's ends, or by its midpoint. It
# starts from the Gaussian with the mixture's mean and variance and usually
# converges in 3-6 steps (bisection alone took about 40). Rows that have
# converged (a Newton step or the bracket below `tol` relative, or F zero
# to rounding) drop out.
mixture_quantile <- function(mu, sd, prob, tol = 1e-10) {
  n <- nrow(mu)
  zq <- stats::qnorm(prob)
  cq <- mu + zq * sd  # every component's quantile brackets the mixture's
  i <- seq_len(n)
  lo <- cq[cbind(i, max.col(-cq, ties.method = "first"))]
  hi <- cq[cbind(i, max.col(cq, ties.method = "first"))]
  cq <- NULL
  Flo <- Fhi <- rep(NA_real_, n)  # F at the bracket's ends, once evaluated
  mbar <- rowMeans(mu)
  x <- mbar + zq * sqrt(rowMeans(sd^2) + rowMeans((mu - mbar)^2))
  x <- pmin(pmax(x, lo), hi)
  eps <- tol * pmax(abs(lo), abs(hi), 1)
  conv <- hi - lo <= eps
  x[conv] <- ((lo + hi) / 2)[conv]
  active <- which(!conv)
  whole <- length(active) == n
  mu_a <- if (whole) mu else mu[active, , drop = FALSE]
  sd_a <- if (whole) sd else sd[active, , drop = FALSE]
  for (iter in seq_len(200L)) {
    if (!length(active)) break
    xa <- x[active]
    cdf <- rowMeans(stats::pnorm(xa, mu_a, sd_a)) - prob
    dens <- rowMeans(stats::dnorm(xa, mu_a, sd_a))
    below <- cdf < 0
    lo[active[below]] <- xa[below]
    Flo[active[below]] <- cdf[below]
    hi[active[!below]] <- xa[!below]
    Fhi[active[!below]] <- cdf[!below]
    la <- lo[active]
    ha <- hi[active]
    step <- cdf / dens
    xn <- xa - step
    newton <- is.finite(xn) & xn > la & xn < ha
    sec <- la - Flo[active] * (ha - la) / (Fhi[active] - Flo[active])
    sec_ok <- !newton & is.finite(sec) & sec > la & sec < ha
    xn[sec_ok] <- sec[sec_ok]
    mid <- !newton & !sec_ok
    xn[mid] <- ((la + ha) / 2)[mid]
    ea <- eps[active]
    exact <- abs(cdf) <= 8 * .Machine$double.eps  # F's own rounding: a root
    done <- exact | (newton & abs(step) <= ea) | (ha - la <= ea)
    x[active] <- ifelse(exact, xa, xn)
    if (any(done)) {
      keep <- !done
      active <- active[keep]
      mu_a <- mu_a[keep, , drop = FALSE]
      sd_a <- sd_a[keep, , drop = FALSE]
    }
  }
  x
}

# New experimental inputs as an unnamed double matrix with p columns, in the
# order of the fit's inputs (matched by name when both carry names).
check_newdata <- function(newdata, scale, call = parent.frame()) {
  p <- scale$p
  refuse_calibration_columns(if (is.data.frame(newdata)) names(newdata) else colnames(newdata),
                             scale, call = call)
  if (is.data.frame(newdata) && isTRUE(scale$named) && all(scale$names$inputs %in% names(newdata))) {
    newdata <- newdata[scale$names$inputs]  # other columns (say the response) are not needed
  }
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
  if (is.matrix(newdata) && is.numeric(newdata)) {
    newdata <- match_newdata_columns(newdata, scale, call = call)
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

