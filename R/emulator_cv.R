#' Cross-validate the emulator on the simulator runs
#'
#' Checks how well the simulator emulator predicts the simulator runs it was
#' built from: each run is predicted from the others (leave-one-out, or
#' k-fold for large designs) at the posterior, and its standardized error
#' tells whether the emulator's uncertainty is honest. Look at this before
#' trusting a calibration: an emulator that is wrong somewhere in the design
#' passes its error on to \eqn{\kappa}.
#'
#' @section What is predicted:
#' The emulator is the simulator GP alone, conditioned on the simulator runs:
#' zero mean and covariance \eqn{K = \sigma^2_S (R_s + \nu I)} on the scaled
#' space of [calibrate()] (\eqn{\nu} the nugget, `fit$settings$nugget`). The
#' field data play no part. For one draw of the parameters, with
#' \eqn{Q = K^{-1}} and \eqn{a = Q y_s} computed by the fit's simulator
#' algebra (see `vignette("sampler", package = "FBC")`: from the Cholesky factor
#' of \eqn{K}, or on a product design from the eigendecompositions of its two
#' factors, without any `m x m` matrix), the closed-form identities of GP
#' regression give the held-out predictive of every run without refitting
#' (Rasmussen and Williams 2006, section 5.4.2):
#' * leave-one-out: mean \eqn{y_i - a_i / Q_{ii}}, variance \eqn{1 / Q_{ii}};
#' * a fold \eqn{B} held out: mean \eqn{y_B - (Q_{BB})^{-1} a_B},
#'   covariance \eqn{(Q_{BB})^{-1}}, of which each run's marginal is used.
#'
#' With `method = "MAP"` the draw with the highest log posterior is used.
#' With `method = "Bayesian"`, `ndraws` draws evenly spaced over the retained
#' ones; each run's predictive is then the equal-weight mixture of the
#' draws' Gaussians: mean the mean of the means, variance the mean of the
#' variances plus the variance of the means (law of total variance).
#' Results are in the response's units.
#'
#' @section Stochastic simulators:
#' With the simulator's own noise modelled ([simulator_noise]) the emulator
#' holds the unique inputs with their mean responses; an input is held out
#' with all its replicates (a replicate left in would predict its own
#' input), and each run is predicted as a run: the held-out predictive of
#' \eqn{\eta} at its input plus the noise variance \eqn{r(x, t)} of that
#' draw. `runs` has one row per run, `fold` its input's fold; `folds`
#' counts or labels the unique inputs (a vector: one label per run, the
#' same for an input's replicates).
#'
#' @section Folds:
#' `folds = NULL` uses leave-one-out when there are at most 2000 runs and
#' 10 folds otherwise. A number `k` asks for `k` folds (`k` = the number of
#' runs is leave-one-out): run `i` goes to fold `((i - 1) mod k) + 1`, so
#' each fold is an even thinning of the runs in their given order. A vector
#' with one fold label per run sets the folds directly (e.g. to hold out
#' whole blocks of the design).
#'
#' @section Summaries:
#' For each run: `z = (observed - mean) / sd` and `pit`, the predictive
#' probability below the observed value (for the Bayesian method, of the
#' mixture). A run lies inside the central `level` interval when
#' `|pit - 0.5| < level / 2`; `coverage` gives the share of runs inside the
#' 50%, 90% and 95% intervals, which should be close to those levels.
#' `rmse` is the root mean squared error of the means, in the response's
#' units (with several outputs one per output, named, since their units
#' differ; `rmseRel`: pooled as a share of each output's sd) and `shareZ3` the share of runs with
#' `|z| > 3` (0.27% for a Gaussian). Coverage well below nominal or many
#' large `|z|` mean the emulator is overconfident (`print()` says so when the
#' 95% coverage is below 0.85 or at least 3 runs, and 2%, have `|z| > 3`);
#' coverage well above
#' nominal means it is too cautious, unless some runs are far off (`|z| > 3`):
#' then the errors are uneven, and `print()` says that instead. Leave-one-out is optimistic when runs
#' sit very close to each other: then use folds of neighbouring runs.
#'
#' @param fit An `fbc` object from [calibrate()].
#' @param method `"Bayesian"` (a mixture over `ndraws` posterior draws) or
#'   `"MAP"` (the draw with the highest log posterior).
#' @param ndraws For `method = "Bayesian"`, how many draws to use (all when
#'   fewer are retained). Each costs one factorization of the simulator
#'   covariance by the fit's algebra (on the dense one: a Cholesky factor
#'   and a triangular inverse of the `m x m` matrix; on a product design two
#'   small eigendecompositions). The draws go 10 at a time, with a progress
#'   bar in an interactive session when there are more. The default 50 takes
#'   about 25 CPU s on the m = 4000 product design `decaySim`.
#' @param folds `NULL` (default), a number of folds, or one fold label per
#'   simulator run (see "Folds").
#' @return An object of class `fbc_emulator_cv`: a list with `runs` (a data
#'   frame with one row per simulator run: its inputs in their own units
#'   (a categorical input, outputs included, as a factor of its levels),
#'   `fold`, `observed`, `mean`, `sd`, `z`, `pit`), `coverage` (named by
#'   level), `rmse`, `rmseRel`, `shareZ3`, `method`, `ndraws` (draws used),
#'   `nFolds` and `inputs` (the names of the input columns of `runs`). It
#'   has `print()` and `plot()` methods (see [plot.fbc_emulator_cv()]).
#' @seealso [ppc_field()] for the field data.
#' @export
#' @examples
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 500, nBurn = 200, nChains = 2)
#' v <- emulator_cv(fit, ndraws = 20)
#' v
#' plot(v)
emulator_cv <- function(fit, method = c("Bayesian", "MAP"), ndraws = 50, folds = NULL) {
  fit <- check_fbc(fit)
  if (!is.null(fit$model$simulator)) {
    cli::cli_abort(c(
      "{.arg fit} has no emulator to validate: its simulator is a function, called directly.",
      i = "{.fn emulator_cv} checks an emulator's predictions of held-out runs; {.fn emulator_vs_direct} compares an emulator-based calibration with the function's."
    ))
  }
  method <- match_choice(method, c("Bayesian", "MAP"), "method")
  ndraws <- check_count(ndraws, "ndraws")
  sc <- fit$model$scale
  ys <- fit$model$data$ys
  m <- length(ys)
  # with the simulator's own noise the model holds the unique inputs: their
  # folds hold each input's replicates out together
  reps <- noise_cv_groups(fit$model)
  fold <- if (is.null(reps)) emulator_folds(folds, m) else noise_cv_folds(folds, reps, m)
  rows <- check_rows(fit, method, ndraws)
  phis <- sampler_draws(fit, rows)
  labels <- if (is.null(fold)) seq_len(m) else match(fold, unique(fold))
  cv <- heldout_draws(fit, phis, labels)
  means <- cv$mean
  vars <- cv$var
  Xs <- fit$model$data$Xs
  if (!is.null(reps)) {
    # every run: its input's held-out mean, and a run's variance (the
    # mean's less its noise r / n, plus r)
    r <- noise_variances(fit$model, phis)
    g <- reps$group
    vars <- (vars - r / reps$count + r)[g, , drop = FALSE]
    means <- means[g, , drop = FALSE]
    ys <- run_responses(fit$model)
    Xs <- Xs[g, , drop = FALSE]
    fold <- if (is.null(fold)) g else fold[g]
    m <- length(ys)
  }
  D <- nrow(phis)
  mu <- rowMeans(means)
  v <- rowMeans(vars) + rowMeans((means - mu)^2)
  sds <- sqrt(vars)
  pit <- rowMeans(stats::pnorm((ys - means) / sds))
  z <- (ys - mu) / sqrt(v)

  X <- unscale_inputs(Xs, sc, seq_len(ncol(Xs)))
  stat_cols <- c("fold", "observed", "mean", "sd", "z", "pit")
  inputs <- make.unique(c(stat_cols, sim_input_names(sc, ncol(X))))[-seq_along(stat_cols)]
  colnames(X) <- inputs
  out <- fit$model$data$outS
  runs <- data.frame(X, fold = fold %||% seq_len(m),
                     observed = y_mean(sc, out) + y_sd(sc, out) * ys,
                     mean = y_mean(sc, out) + y_sd(sc, out) * mu,
                     sd = y_sd(sc, out) * sqrt(v), z = z, pit = pit, check.names = FALSE)
  levels_ <- c(0.5, 0.9, 0.95)
  coverage <- stats::setNames(vapply(levels_, function(l) mean(abs(pit - 0.5) < l / 2), numeric(1)),
                              paste0(100 * levels_, "%"))
  # raw errors pool only within one output's units: with several outputs
  # one RMSE per output
  err <- runs$observed - runs$mean
  rmse <- if (is.null(sc$output)) sqrt(mean(err^2)) else
    vapply(seq_along(sc$output$levels), function(k) sqrt(mean(err[out == k]^2)), numeric(1))
  if (!is.null(sc$output)) names(rmse) <- sc$output$levels
  cat_runs <- categorical_runs(runs, inputs, sc)
  runs <- cat_runs$runs
  inputs <- cat_runs$inputs
  structure(list(
    runs = runs, coverage = coverage, rmse = rmse,
    rmseRel = sqrt(mean(((runs$observed - runs$mean) / y_sd(sc, out))^2)),
    shareZ3 = mean(abs(z) > 3), method = method, ndraws = D,
    nFolds = if (is.null(fold)) m else length(unique(fold)), inputs = inputs,
    response = sc$names$response,
    unique = if (!is.null(reps)) length(reps$count)
  ), class = "fbc_emulator_cv")
}

# The runs' categorical inputs (outputs included) as one factor column each,
# with the level names, in place of their indicator columns: list(runs,
# inputs).
categorical_runs <- function(runs, inputs, scale) {
  for (f in scale$factors) {
    cols <- f$columns
    if (!all(cols %in% names(runs))) next
    ind <- as.matrix(runs[, cols, drop = FALSE])
    code <- indicator_codes(ind)
    j <- match(cols[1], names(runs))
    runs[[cols[1]]] <- factor(f$levels[code], f$levels)
    names(runs)[j] <- f$name
    runs <- runs[, setdiff(names(runs), cols[-1]), drop = FALSE]
    inputs <- unique(replace(inputs, inputs %in% cols, f$name))
  }
  list(runs = runs, inputs = inputs)
}

# Above this many simulator runs, emulator_cv() uses 10 folds.
fbc_kfold_above <- 2000L

# Fold labels (NULL for leave-one-out) from the `folds` argument.
emulator_folds <- function(folds, m, call = parent.frame()) {
  if (is.null(folds)) {
    if (m <= fbc_kfold_above) return(NULL)
    folds <- 10L
  }
  if (length(folds) == 1L) {
    k <- check_count(folds, "folds", min = 2, call = call)
    if (k > m) {
      cli::cli_abort("{.arg folds} must be at most the number of simulator runs ({m}); got {k}.",
                     call = call)
    }
    if (k == m) return(NULL)
    return((seq_len(m) - 1L) %% k + 1L)
  }
  if (length(folds) != m || anyNA(folds)) {
    cli::cli_abort(c(
      "{.arg folds} must be a number of folds or one fold label per simulator run ({m}).",
      x = "It has length {length(folds)}{if (anyNA(folds)) ' and missing values' else ''}."
    ), call = call)
  }
  if (length(unique(folds)) < 2L) {
    cli::cli_abort("{.arg folds} must define at least 2 folds.", call = call)
  }
  if (all(table(folds) == 1L)) return(NULL)
  as.vector(folds)
}

# The held-out predictives of every run at each draw (rows of `phis`),
# through the fit's algebra: m x draws means and variances. Draws go to the
# compiled code a block of `fbc_validate_block` at a time, with a progress
# bar when there are several blocks (interactive, or option FBC.progress),
# so a long validation shows how far it got.
fbc_validate_block <- 10L

heldout_draws <- function(fit, phis, labels) {
  parts <- in_blocks(nrow(phis), fbc_validate_block, "Validating", function(b) {
    at_draws(fit, .fbc_heldout, phis[b, , drop = FALSE], fold = labels)
  })
  list(mean = do.call(cbind, lapply(parts, `[[`, "mean")),
       var = do.call(cbind, lapply(parts, `[[`, "var")))
}

# Rows of Phi used by a check: the MAP draw, or `ndraws` evenly spaced ones
# (the same rows predict() would use: draw_rows() in predict.R).
check_rows <- function(fit, method, ndraws) {
  if (method == "MAP") return(which.max(fit$logPost))
  draw_rows(nrow(fit$Phi), ndraws)
}


# Names of the simulator's input columns (experimental, then calibration).
sim_input_names <- function(scale, k) {
  nm <- c(scale$names$inputs, scale$names$calibration)
  if (length(nm) != k || anyNA(nm) || any(!nzchar(nm))) {
    nm <- c(paste0("x", seq_len(scale$p)), paste0("t", seq_len(scale$q)))
  }
  nm
}

# Prints a message as print.fbc() prints its warnings: "! " then wrapped lines.
cat_warning <- function(msg) {
  lines <- strwrap(msg, width = getOption("width") - 2L, exdent = 2L)
  cat(paste0("! ", paste(lines, collapse = "\n")), "\n", sep = "")
}

#' @export
print.fbc_emulator_cv <- function(x, digits = 3, ...) {
  m <- nrow(x$runs)
  how <- if (x$nFolds == m || identical(x$nFolds, x$unique)) "leave-one-out" else sprintf("%d-fold", x$nFolds)
  at <- if (x$method == "MAP") "at the MAP draw" else
    sprintf("over %d posterior draw%s (Gaussian mixture per run)", x$ndraws, if (x$ndraws > 1) "s" else "")
  cat(sprintf("<fbc_emulator_cv> Emulator check: %s predictions of %d simulator runs\n", how, m))
  if (!is.null(x$unique)) {
    cat(sprintf("  %d unique inputs, each one's replicates held out together; intervals with the run noise\n",
                x$unique))
  }
  cat(sprintf("  %s\n", at))
  cat(sprintf("  coverage of nominal intervals: %s\n",
              paste(sprintf("%s: %.2f", names(x$coverage), x$coverage), collapse = "  ")))
  rmse <- if (length(x$rmse) > 1L) {
    # several outputs: each in its own units, pooled only relative to each sd
    paste0("RMSE by output: ", paste(sprintf("%s %s", names(x$rmse),
                                             vapply(signif(x$rmse, digits), format, character(1))),
                                     collapse = ", "),
           sprintf(" (%s%% of each output's sd, pooled)", format(signif(100 * x$rmseRel, digits))))
  } else {
    sprintf("RMSE %s (%s%% of the response's sd)", format(signif(x$rmse, digits)),
            format(signif(100 * x$rmseRel, digits)))
  }
  cat(sprintf("  %s; |z| > 3: %d run%s (%.1f%%)\n", rmse,
              sum(abs(x$runs$z) > 3), if (sum(abs(x$runs$z) > 3) == 1) "" else "s",
              100 * x$shareZ3))
  worst <- which.max(abs(x$runs$z))
  cat(sprintf("  largest |z|: run %d (z = %s)\n", worst, format(signif(x$runs$z[worst], digits))))
  verdict <- validation_verdict(x)
  if (length(verdict)) cat_warning(verdict)
  invisible(x)
}

# A one-line reading of the coverage, when it is clearly off.
validation_verdict <- function(x) {
  cov95 <- x$coverage[["95%"]]
  cov50 <- x$coverage[["50%"]]
  if (cov95 < 0.85 || sum(abs(x$runs$z) > 3) >= max(3, 0.02 * nrow(x$runs))) {
    return("The emulator is overconfident: its intervals miss too many runs. Look at the plot for where (an input range, a corner of the design), and consider more runs there or a longer run of the sampler.")
  }
  if (cov50 > 0.85) {
    far <- sum(abs(x$runs$z) > 3)
    if (far > 0) {
      return(sprintf("Most runs sit well inside their intervals (50%% coverage %.2f), yet %d run%s beyond 3 sd: the errors are uneven, not just cautious. Look at the plot for where (an input range, a corner of the design), and consider more runs there.",
                     cov50, far, if (far == 1) " lies" else "s lie"))
    }
    return("The emulator's intervals are much wider than its errors: it is too cautious (often harmless; check sigma2S and thetaS).")
  }
  character()
}

#' Plot an emulator validation
#'
#' Draws, with ggplot2, the standardized held-out errors `z` of
#' [emulator_cv()] against each simulator input (one panel each,
#' labelled with the input's name), with dashed lines at 0 and \eqn{\pm 2},
#' and a normal QQ plot of `z` (last panel: `z` against the standard normal
#' quantiles, the identity line dashed). A categorical input (an output)
#' is drawn at its levels' positions 1, 2, ..., named in its panel's title.
#' Runs with `|z| > 3` are red. A
#' trend or a funnel against an input shows where the emulator is wrong;
#' points above the QQ line at the right (below it at the left) mean heavier
#' tails than the emulator admits.
#'
#' @param x An `fbc_emulator_cv` object.
#' @param which `"both"` (default), `"inputs"` or `"qq"`.
#' @param ... Unused.
#' @return A ggplot object.
#' @export
plot.fbc_emulator_cv <- function(x, which = c("both", "inputs", "qq"), ...) {
  which <- match_choice(which, c("both", "inputs", "qq"), "which")
  runs <- x$runs
  qq_label <- "normal QQ (x: N(0, 1) quantile)"
  panels <- list()
  if (which != "qq") {
    # a categorical input (an output) at its levels' positions 1, 2, ...,
    # named in the panel's title
    panels <- lapply(x$inputs, function(v) {
      xv <- runs[[v]]
      if (is.factor(xv)) {
        xv <- as.integer(xv)
      }
      data.frame(panel = validation_panel(runs, v), x = xv, z = runs$z)
    })
  }
  if (which != "inputs") {
    o <- order(runs$z)
    panels[[length(panels) + 1L]] <- data.frame(
      panel = qq_label, x = stats::qnorm(stats::ppoints(nrow(runs))), z = runs$z[o]
    )
  }
  df <- do.call(rbind, panels)
  lev <- c(if (which != "qq") vapply(x$inputs, function(v) validation_panel(runs, v), character(1),
                                      USE.NAMES = FALSE),
           if (which != "inputs") qq_label)
  df$panel <- factor(df$panel, lev)
  df$large <- abs(df$z) > 3
  p <- ggplot2::ggplot(df, ggplot2::aes(x = .data$x, y = .data$z)) +
    ggplot2::geom_hline(yintercept = 0, colour = "grey40") +
    ggplot2::geom_hline(yintercept = c(-2, 2), linetype = "dashed", colour = "grey60")
  if (which != "inputs") {
    p <- p + ggplot2::geom_abline(data = data.frame(panel = factor(qq_label, lev)),
                                  ggplot2::aes(intercept = 0, slope = 1),
                                  linetype = "dashed", colour = "steelblue")
  }
  how <- if (x$nFolds == nrow(runs) || identical(x$nFolds, x$unique)) "leave-one-out" else paste0(x$nFolds, "-fold")
  p + ggplot2::geom_point(ggplot2::aes(colour = .data$large), size = 1.2, show.legend = FALSE) +
    ggplot2::scale_colour_manual(values = c(`FALSE` = "grey20", `TRUE` = "firebrick")) +
    ggplot2::facet_wrap(ggplot2::vars(.data$panel), scales = "free_x") +
    ggplot2::labs(x = NULL, y = "standardized error z",
                  title = sprintf("Emulator check: %s standardized errors of the simulator runs", how)) +
    ggplot2::theme_bw()
}

# The panel title of an input in plot.fbc_emulator_cv(): its name, and for a
# categorical one the level at each position ("out (1 conc, 2 rate)").
validation_panel <- function(runs, v) {
  xv <- runs[[v]]
  if (!is.factor(xv)) return(v)
  sprintf("%s (%s)", v, paste(seq_along(levels(xv)), levels(xv), collapse = ", "))
}
