#' Posterior predictive check of the field data
#'
#' Compares the field observations with replicated field data drawn from the
#' posterior predictive distribution, so that a systematic misfit (a trend
#' the model misses, noise it under- or overstates) shows up. The numbers
#' come with a plot in the style of \pkg{bayesplot}'s `ppc_intervals()` and
#' `ppc_dens_overlay()` ([plot.fbc_ppc()]); [pp_check()][pp_check.fbc] hands
#' the same replicates to \pkg{bayesplot} when it is installed.
#'
#' @section Which predictive distribution:
#' For each posterior draw used, observation \eqn{i} is replicated from the
#' distribution of a *new* field observation at its input \eqn{x_i} given
#' *all* the data (the field data included): the Gaussian \eqn{N(m_i, v_i)}
#' of [predict.fbc()] with `type = "field"` (simulator, discrepancy and
#' measurement error; see "Formulas" there), and
#' \eqn{y^{rep}_i = m_i + \sqrt{v_i}\, \epsilon}, \eqn{\epsilon \sim N(0, 1)}.
#' This is the usual posterior predictive check (Gelman et al. 2013, ch. 6):
#' the data are used twice, to fit and to check, so the check is
#' conservative. Observations fall inside their intervals somewhat more often
#' than the nominal rate even for a good model, and a share outside well
#' above nominal is a clear sign of misfit. It is not a cross-validation: an
#' observation is not held out from its own prediction.
#'
#' @section Numbers:
#' Per observation, from the equal-weight mixture of the draws' Gaussians
#' (exact, not from the random replicates): the predictive `mean` and `sd`,
#' the `median`, the 50% and 90% central intervals (`lower50`, `upper50`, `lower90`,
#' `upper90`) and the posterior predictive p-value
#' \eqn{p_i = \Pr(y^{rep}_i \ge y_i \mid y)}; values near 0 or 1 mark
#' observations the model does not expect. `outside` gives the share of
#' observations outside their central 50%, 90% and 95% intervals
#' (\eqn{p_i} outside \eqn{[(1 - l)/2, (1 + l)/2]}), to compare with 0.5,
#' 0.1 and 0.05.
#'
#' @param fit An `fbc` object from [calibrate()].
#' @param ndraws How many posterior draws to use, evenly spaced over the
#'   retained ones (all when fewer are retained); one replicated data set
#'   per draw.
#' @return An object of class `fbc_ppc`: a list with `y` (the observations,
#'   response units), `yrep` (an `ndraws x n` matrix of replicated data sets,
#'   one row per draw, as \pkg{bayesplot} expects), `x` (the field inputs, a
#'   matrix with named columns), `obs` (the per-observation table: inputs,
#'   `observed`, `mean`, `sd`, `median`, the intervals, `p`), `outside` (named by
#'   level) and `ndraws`.
#' @seealso [emulator_cv()] for the simulator runs.
#' @export
#' @examples
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 500, nBurn = 200, nChains = 2)
#' pp <- ppc_field(fit, ndraws = 100)
#' pp
#' plot(pp)
#' plot(pp, type = "density")
ppc_field <- function(fit, ndraws = 500) {
  fit <- check_fbc(fit)
  ndraws <- check_count(ndraws, "ndraws")
  sc <- fit$model$scale
  dat <- fit$model$data
  rows <- check_rows(fit, "Bayesian", ndraws)
  phis <- sampler_draws(fit, rows)
  fc <- field_conditionals(fit, phis, 1L)
  m <- fc$mean         # n x D
  s <- fc$sd
  n <- nrow(m)
  D <- ncol(m)
  y <- field_response(fit)
  yrep <- t(m) + t(s) * matrix(stats::rnorm(D * n), D, n)

  mu <- rowMeans(m)
  p <- rowMeans(stats::pnorm((m - y) / s))   # Pr(yrep >= y)
  X <- unscale_inputs(dat$Xf, sc, seq_len(sc$p))
  inputs <- field_input_names(sc)
  stat_cols <- c("observed", "mean", "sd", "median", "lower50", "upper50", "lower90", "upper90", "p")
  colnames(X) <- make.unique(c(stat_cols, inputs))[-seq_along(stat_cols)]
  obs <- data.frame(X, observed = y, mean = mu, sd = sqrt(rowMeans(s^2) + rowMeans((m - mu)^2)),
                    median = mixture_quantile(m, s, 0.5),
                    lower50 = mixture_quantile(m, s, 0.25), upper50 = mixture_quantile(m, s, 0.75),
                    lower90 = mixture_quantile(m, s, 0.05), upper90 = mixture_quantile(m, s, 0.95),
                    p = p, check.names = FALSE)
  levels_ <- c(0.5, 0.9, 0.95)
  outside <- stats::setNames(vapply(levels_, function(l) mean(abs(p - 0.5) > l / 2), numeric(1)),
                             paste0(100 * levels_, "%"))
  structure(list(y = y, yrep = yrep, x = X, obs = obs, outside = outside, ndraws = D,
                 response = sc$names$response, noise = ppc_noise(fit, y, mu)),
            class = "fbc_ppc")
}

# How far the measurement error's variance exceeds what the observations
# show, per measurement-error group: the posterior median of sigma2E (in
# the response's units squared: the scaled-space draws times the output's
# variance) against the mean squared distance of the group's observations
# from their predictive means (which a good fit keeps near sigma2E plus the
# latent field's posterior variance, so a ratio well above 1 says the noise
# is overstated). A data frame: label, sigma2E, residual, ratio.
ppc_noise <- function(fit, y, mu) {
  cols <- grep("^sigma2E[0-9]*$", colnames(fit$Phi), value = TRUE)
  if (!length(cols)) return(NULL)
  codes <- fit$model$spec$model$noise %||% rep(1L, length(y))
  sds <- y_sd(fit$model$scale, fit$model$data$outF)
  if (length(sds) == 1L) sds <- rep(sds, length(y))
  labels <- fit$model$scale$noiseLabels %||% rep("", length(cols))
  out <- lapply(seq_along(cols), function(g) {
    rows <- which(codes == g)
    s2 <- stats::median(fit$Phi[, cols[g]]) * sds[rows[1]]^2
    res <- mean((y[rows] - mu[rows])^2)
    data.frame(parameter = cols[g], label = labels[g], sigma2E = s2, residual = res,
               ratio = s2 / res, stringsAsFactors = FALSE)
  })
  do.call(rbind, out)
}

# Ratio of sigma2E to the observations' mean squared residual above which
# ppc_field() says the measurement error is overstated.
fbc_ppc_noise_ratio <- 4

field_input_names <- function(scale) {
  nm <- scale$names$inputs
  if (length(nm) != scale$p || anyNA(nm) || any(!nzchar(nm))) nm <- paste0("x", seq_len(scale$p))
  nm
}

#' @export
print.fbc_ppc <- function(x, digits = 3, ...) {
  n <- length(x$y)
  cat(sprintf("<fbc_ppc> Posterior predictive check of %d field observation%s\n", n,
              if (n == 1) "" else "s"))
  cat(sprintf("  %d posterior draw%s; each observation's predictive given all the data\n",
              x$ndraws, if (x$ndraws == 1) "" else "s"))
  cat(sprintf("  share outside the 50/90/95%% intervals: %s (nominal 0.5, 0.1, 0.05)\n",
              paste(sprintf("%.2f", x$outside), collapse = ", ")))
  p <- x$obs$p
  extreme <- sum(p < 0.005 | p > 0.995)
  cat(sprintf("  p-values below 0.005 or above 0.995: %d observation%s\n", extreme,
              if (extreme == 1) "" else "s"))
  z <- (x$y - x$obs$mean) / x$obs$sd
  worst <- which.max(abs(z))
  cat(sprintf("  most surprising: observation %d (observed %s, predictive mean %s, p = %s)\n",
              worst, format(signif(x$y[worst], digits)), format(signif(x$obs$mean[worst], digits)),
              format(signif(p[worst], 2))))
  if (x$outside[["90%"]] > 0.2) {
    cat_warning(
      "Many observations fall outside their 90% intervals: the model misses part of the field data. The plot shows where; a discrepancy the bias GP cannot follow, or a measurement error variance fixed too low, are common causes.")
  } else if (x$outside[["50%"]] < 0.2) {
    nz <- x$noise
    big <- if (!is.null(nz)) nz[is.finite(nz$ratio) & nz$ratio > fbc_ppc_noise_ratio, , drop = FALSE]
    cause <- if (!is.null(big) && nrow(big)) {
      what <- sprintf("%s%s's posterior median %s is %s times the mean squared distance of %s observations from their predictive means (%s)",
                      big$parameter, ifelse(nzchar(big$label), sprintf(" (%s)", big$label), ""),
                      format(signif(big$sigma2E, 2)), format(signif(big$ratio, 2)),
                      ifelse(nzchar(big$label), "its", "the"), format(signif(big$residual, 2)))
      paste0(": ", paste(what, collapse = "; "),
             ". A prior that holds sigma2E up (its sigma2EP1, sigma2EP2 in set_hyperPriors()) or a bias the data cannot separate from noise are common causes (see convergence_messages(), which flags a prior only beyond its thresholds).")
    } else ". A prior that holds sigma2E too high is a common cause."
    cat_warning(paste0(
      "The observations sit much closer to their predictive means than the intervals allow: the model overstates the noise", cause))
  }
  invisible(x)
}

#' Plot a posterior predictive check
#'
#' Two views of [ppc_field()], following \pkg{bayesplot}'s conventions:
#' * `"intervals"` (like `ppc_intervals()`): for each field observation, the
#'   median of its predictive distribution (light dot) with the central 50%
#'   (thick) and 90% (thin) intervals, and the observation (dark dot),
#'   against each experimental input (one panel per input, labelled with its
#'   name);
#' * `"density"` (like `ppc_dens_overlay()`): the density of the observed
#'   data (dark) over the densities of up to `nOverlay` replicated data sets
#'   (light).
#'
#' @param x An `fbc_ppc` object.
#' @param type `"intervals"` or `"density"`.
#' @param nOverlay For `"density"`, how many replicated data sets to draw.
#' @param ... Unused.
#' @return A ggplot object.
#' @export
plot.fbc_ppc <- function(x, type = c("intervals", "density"), nOverlay = 50, ...) {
  type <- match_choice(type, c("intervals", "density"), "type")
  nOverlay <- check_count(nOverlay, "nOverlay")
  light <- "#9ecae1"
  dark <- "#08306b"
  if (type == "density") {
    k <- min(nOverlay, nrow(x$yrep))
    rep_df <- data.frame(value = as.vector(t(x$yrep[seq_len(k), , drop = FALSE])),
                         draw = rep(seq_len(k), each = ncol(x$yrep)))
    return(
      ggplot2::ggplot() +
        ggplot2::stat_density(data = rep_df, ggplot2::aes(x = .data$value, group = .data$draw),
                              geom = "line", position = "identity", colour = light,
                              linewidth = 0.3, alpha = 0.7) +
        ggplot2::stat_density(data = data.frame(value = x$y), ggplot2::aes(x = .data$value),
                              geom = "line", colour = dark, linewidth = 1) +
        ggplot2::labs(x = x$response, y = "density",
                      title = "Field data (dark) and replicated data sets (light)") +
        ggplot2::theme_bw()
    )
  }
  obs <- x$obs
  inputs <- colnames(x$x)
  df <- do.call(rbind, lapply(inputs, function(v) {
    data.frame(input = v, x = x$x[, v], y = x$y, median = obs$median,
               lower50 = obs$lower50, upper50 = obs$upper50,
               lower90 = obs$lower90, upper90 = obs$upper90)
  }))
  df$input <- factor(df$input, inputs)
  ggplot2::ggplot(df, ggplot2::aes(x = .data$x)) +
    ggplot2::geom_linerange(ggplot2::aes(ymin = .data$lower90, ymax = .data$upper90),
                            colour = light, linewidth = 0.5) +
    ggplot2::geom_linerange(ggplot2::aes(ymin = .data$lower50, ymax = .data$upper50),
                            colour = light, linewidth = 1.5) +
    ggplot2::geom_point(ggplot2::aes(y = .data$median), colour = light, size = 1.6) +
    ggplot2::geom_point(ggplot2::aes(y = .data$y), colour = dark, size = 1.2) +
    ggplot2::facet_wrap(ggplot2::vars(.data$input), scales = "free_x") +
    ggplot2::labs(x = if (length(inputs) == 1L) inputs else NULL, y = x$response,
                  title = "Field data (dark) and posterior predictive 50% / 90% intervals (light)") +
    ggplot2::theme_bw()
}

#' Posterior predictive checks with bayesplot
#'
#' A method for \pkg{bayesplot}'s `pp_check()` generic (registered when
#' \pkg{bayesplot} is installed; FBC does not depend on it): it replicates
#' the field data as [ppc_field()] does and calls
#' `bayesplot::ppc_<type>(y, yrep, ...)`.
#'
#' @param object An `fbc` object from [calibrate()].
#' @param type The name of a \pkg{bayesplot} `ppc_` function without the
#'   prefix, e.g. `"dens_overlay"` (default), `"intervals"`, `"ribbon"`,
#'   `"stat"`, `"ecdf_overlay"`.
#' @param ndraws Number of posterior draws (replicated data sets).
#' @param ... Passed to the \pkg{bayesplot} function. For `"intervals"` and
#'   `"ribbon"`, `x` defaults to the first experimental input.
#' @return The ggplot object of the \pkg{bayesplot} function.
#' @exportS3Method bayesplot::pp_check
#' @examples
#' if (requireNamespace("bayesplot", quietly = TRUE)) {
#'   set.seed(1)
#'   fit <- calibrate(ballSim, ballField, nMCMC = 500, nBurn = 200, nChains = 2)
#'   bayesplot::pp_check(fit, ndraws = 50)
#'   bayesplot::pp_check(fit, type = "intervals")
#' }
pp_check.fbc <- function(object, type = "dens_overlay", ndraws = 50, ...) {
  if (!requireNamespace("bayesplot", quietly = TRUE)) {
    cli::cli_abort(c("{.fn pp_check} needs the {.pkg bayesplot} package.",
                     i = "Install it, or use {.fn ppc_field} and its {.fn plot} method."))
  }
  type <- check_string(type, "type")
  fun <- paste0("ppc_", type)
  if (!exists(fun, envir = asNamespace("bayesplot"), inherits = FALSE)) {
    cli::cli_abort("{.arg type} must name a {.pkg bayesplot} {.code ppc_} function; {.fn bayesplot::{fun}} does not exist.")
  }
  pp <- ppc_field(object, ndraws = ndraws)
  args <- list(y = pp$y, yrep = pp$yrep, ...)
  if (type %in% c("intervals", "ribbon") && is.null(args$x)) args$x <- pp$x[, 1]
  do.call(getExportedValue("bayesplot", fun), args)
}

# The GP conditionals of target type `code` (1 field, 2 mean, ...) at the
# field inputs, one column per row of `phis`, in the response's units (each
# field row by its output's mean and sd); a field target has its row's
# measurement error.
field_conditionals <- function(fit, phis, code) {
  dat <- fit$model$data
  sc <- fit$model$scale
  res <- at_draws(fit, .fbc_predict, phis, Xnew = dat$Xf, type = code, block = 500L,
                  noise = if (code == 1L) fit$model$spec$model$noise %||% integer() else integer(),
                  source = if (code != 3L) fit$model$spec$model$source %||% integer() else integer())
  shift <- if (code == 4L) 0 else y_mean(sc, dat$outF)
  list(mean = shift + y_sd(sc, dat$outF) * res$mean,
       sd = y_sd(sc, dat$outF) * sqrt(pmax(res$var, 0)))
}

# The field response in its units.
field_response <- function(fit) {
  y_mean(fit$model$scale, fit$model$data$outF) + y_sd(fit$model$scale, fit$model$data$outF) * fit$model$data$yf
}
