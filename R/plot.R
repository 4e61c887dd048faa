#' Plot a calibration
#'
#' Draws, with ggplot2, one of three views of a calibration:
#' * `"density"`: the posterior density of every parameter of a class (one
#'   facet each), a kernel estimate from the retained draws that respects the
#'   parameter's support (the kernel's mass beyond a bound, such as the ends
#'   of a calibration parameter's prior range or 0 for a variance, is
#'   reflected back inside, and nothing is drawn outside), with the prior
#'   density in the same units overlaid (dashed) and the posterior mode as a
#'   vertical line. A fixed parameter has no density: its facet is labelled
#'   `"fixed at"` its value and shows that value; an improper prior (such as
#'   `"jeffreys"`) has no density to draw and is left out, as the caption
#'   says;
#' * `"trace"`: the retained draws of every parameter of a class against the
#'   iteration, to judge mixing;
#' * `"fits"`: the field observations, the MAP fitted values
#'   ([predict.fbc()] with `method = "MAP"` at the field inputs) and their
#'   95% prediction intervals against each experimental input (one facet
#'   each; with several outputs or field data sets, `output =` or
#'   `source =`, a row of facets for each). `parameter` is ignored.
#' * `"failure"`: for a fit whose simulator runs failed in places, the
#'   probability that a run fails (`predict(x, type = "failure")`) over two
#'   inputs, `inputs`, the others held at the median of the runs, with the
#'   successful and failed runs marked.
#'
#' Facets and axes use the data's own names: a calibration parameter is
#' labelled by its input (`"g (kappa1)"`, and the axis `"g"`), a
#' hyperparameter of one input by its name and the input (`"thetaS1 (h)"`,
#' `"thetaS2 (g)"`); hyperparameters live on the scaled space of
#' [calibrate()], as the axis says.
#'
#' @param x An `fbc` object from [calibrate()].
#' @param parameter The parameter class: one of `"kappa"`, `"thetaS"`,
#'   `"alphaS"`, `"thetaB"`, `"alphaB"`, `"sigma2S"`, `"sigma2B"`,
#'   `"sigma2E"`, `"muB"` (the bias's classes only with a bias GP, the
#'   smoothness classes only for a family that has one).
#' @param type `"density"`, `"trace"`, `"fits"` or `"failure"`.
#' @param xlab For `"fits"`, the names of the experimental inputs (one per
#'   input; default the column names of the field data, else `x1`, ..., `xp`).
#'   For the other types, the x-axis title.
#' @param inputs For `"failure"`, the two inputs of the simulator to plot
#'   against (names; default the first two).
#' @param ... Not used: an argument given here is an error (a typo such
#'   as `lvl =` would otherwise be ignored silently).
#' @return A ggplot object; print it to draw it, or add layers and themes.
#' @export
#' @importFrom ggplot2 .data
#' @examples
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 500, nBurn = 200, thinning = 3,
#'                  nChains = 2)
#' plot(fit)
#' plot(fit, "thetaS", type = "trace")
#' plot(fit, type = "fits", xlab = "height (m)")
plot.fbc <- function(x, parameter = "kappa", type = "density", xlab = NULL, inputs = NULL,
                     ...) {
  check_dots_empty(..., fn = plot.fbc, name = "plot")
  x <- check_fbc(x, "x")
  type <- match_choice(type, c("density", "trace", "fits", "failure"), "type")
  if (type == "fits") return(plot_fits(x, xlab))
  if (type == "failure") return(plot_failure(x, inputs))
  if (!is.character(parameter) || length(parameter) != 1L || !(parameter %in% param_classes)) {
    cli::cli_abort(c(
      "{.arg parameter} must be one parameter class: {.or {.val {param_classes}}}.",
      x = "Got {format_choice(parameter)}."
    ))
  }
  if (!is.null(xlab)) xlab <- check_string(xlab, "xlab")
  vars <- colnames(x$Phi)[phi_indices(x$model$spec)[[parameter]]]
  if (!length(vars) && !class_in_model(x$model$discrepancy)[match(parameter, model_classes$class)]) {
    cli::cli_abort(c(
      "{.field {parameter}} is not a parameter of this fit: {.code discrepancy = \"{x$model$discrepancy}\"} {discrepancy_lacks(parameter, x$model$discrepancy)}.",
      i = "{discrepancy_having(parameter)}"
    ))
  }
  if (!length(vars)) {
    K <- kernel_arg(parameter)
    cli::cli_abort(c(
      "{.field {parameter}} is not a parameter of this fit: {.code {K} = \"{x$model[[K]]}\"} has no smoothness parameter.",
      i = "Only the power exponential ({.code {K} = \"powexp\"}) samples a smoothness; see {.help FBC::correlation}."
    ))
  }
  labels <- param_labels(x, vars)
  if (type == "density") plot_density(x, vars, labels, xlab) else plot_trace(x, vars, labels, xlab)
}

# Facet labels in the data's own names: a calibration parameter is named by
# its input, with FBC's name in brackets ("g (kappa1)"); a hyperparameter of
# one input by FBC's name with the input in brackets ("thetaS1 (h)",
# "thetaS2 (g)", "alphaB1 (h)"), a level correlation by its pair of levels
# ("rhoS1 (out: rate~amount)"); the others by FBC's name ("sigma2E").
param_labels <- function(x, vars) {
  nm <- x$model$scale$names
  p <- x$model$scale$p
  q <- x$model$scale$q
  inputs <- c(nm$inputs, nm$calibration)
  cls <- x$model$spec$classes[match(vars, x$model$spec$vars)]
  # (independent outputs: "thetaS1[amount]", the output in brackets)
  k <- suppressWarnings(as.integer(sub("^[A-Za-z]+([0-9]+)(\\[.*\\])?$", "\\1", vars)))
  out <- vars
  ok <- !is.na(k)
  if (length(nm$calibration) == q) {
    kap <- ok & cls == "kappa"
    out[kap] <- paste0(nm$calibration[k[kap]], " (", vars[kap], ")")
  }
  if (length(inputs) == p + q) {
    per <- ok & cls %in% per_input_classes
    out[per] <- paste0(vars[per], " (", inputs[k[per]], ")")
  }
  lev <- level_labels(level_factors(x$model))
  rho <- ok & cls %in% c("rhoS", "rhoB") & k <= length(lev)
  out[rho] <- paste0(vars[rho], " (", lev[k[rho]], ")")
  src <- level_labels(if (isTRUE(x$model$scale$sourceBias)) list(x$model$scale$source))
  rd <- ok & cls == "rhoD" & k <= length(src)
  out[rd] <- paste0(vars[rd], " (", src[k[rd]], ")")
  stats::setNames(out, vars)
}

# Axis title for the values of a class: the input's name for a single
# calibration parameter, its units otherwise.
value_label <- function(x, vars) {
  cls <- x$model$spec$classes[match(vars[1], x$model$spec$vars)]
  if (cls == "kappa") {
    cal <- x$model$scale$names$calibration
    if (length(vars) == 1L && length(cal) == x$model$scale$q) {
      return(cal[as.integer(sub("kappa", "", vars))])
    }
    return("value (each input's units)")
  }
  "value (scaled space)"
}

# Kernel density of `draws` on their support [lo, hi] (either end may be
# infinite): a Gaussian kernel with bw.nrd0's bandwidth, the mass it would
# put beyond a finite bound reflected back inside (Silverman 1986, sec.
# 3.10), f(v) = sum_i [k(v - x_i) + k(2 lo - v - x_i) + k(2 hi - v - x_i)] / n.
# The grid stops at the bounds, so the estimate is zero outside the support
# and integrates to 1 over it.
support_density <- function(draws, lo = -Inf, hi = Inf, n = 256L) {
  bw <- stats::bw.nrd0(draws)
  from <- max(lo, min(draws) - 3 * bw)
  to <- min(hi, max(draws) + 3 * bw)
  dens <- function(v) stats::density(v, bw = bw, from = from, to = to, n = n)$y
  y <- dens(draws)
  if (is.finite(lo)) y <- y + dens(2 * lo - draws)
  if (is.finite(hi)) y <- y + dens(2 * hi - draws)
  list(x = seq(from, to, length.out = n), y = y, bw = bw)
}

plot_density <- function(x, vars, labels, xlab) {
  sup <- param_support(x)
  rownames(sup) <- phi_vars(x$model$spec)
  fam <- prior_family_name(phi_spec(x)$table$family)
  names(fam) <- rownames(sup)
  fixed <- vars[fam[vars] == "fixed"]
  improper <- vars[!fam[vars] %in% "fixed" & !vapply(fam[vars], function(f) prior_registry[[f]]$proper, logical(1))]
  # a fixed parameter has no density: its facet says so and shows its value
  labels[fixed] <- sprintf("%s, fixed at %s", labels[fixed], format(signif(x$Phi[1, fixed], 4)))
  post <- list()
  prior <- list()
  for (v in setdiff(vars, fixed)) {
    d <- support_density(x$Phi[, v], sup[v, 1], sup[v, 2])
    post[[v]] <- data.frame(parameter = labels[[v]], value = d$x, density = d$y)
    # an improper prior has no density to draw
    if (!v %in% improper) {
      grid <- seq(d$x[1], d$x[length(d$x)], length.out = 256)
      prior[[v]] <- data.frame(parameter = labels[[v]], value = grid,
                               density = exp(x$model$spec$fns[[v]](grid)))
    }
  }
  empty <- data.frame(parameter = character(), value = numeric(), density = numeric())
  post <- do.call(rbind, c(list(empty), post))
  prior <- do.call(rbind, c(list(empty), prior))
  prior <- prior[is.finite(prior$density), , drop = FALSE]
  modes <- data.frame(parameter = unname(labels[vars]), mode = x$estimates[vars, "mode"])
  lev <- unname(labels[vars])
  post$parameter <- factor(post$parameter, lev)
  prior$parameter <- factor(prior$parameter, lev)
  modes$parameter <- factor(modes$parameter, lev)
  notes <- c(
    if (length(fixed)) sprintf("%s: fixed, no density.", paste(fixed, collapse = ", ")),
    if (length(improper)) sprintf("%s: improper %s prior, not drawn.",
                                  paste(improper, collapse = ", "), paste(unique(fam[improper]), collapse = ", "))
  )
  ggplot2::ggplot(mapping = ggplot2::aes(x = .data$value, y = .data$density)) +
    ggplot2::geom_area(data = post, stat = "identity", fill = "steelblue", alpha = 0.35, colour = "steelblue") +
    ggplot2::geom_line(data = prior, linetype = "dashed", colour = "grey30") +
    ggplot2::geom_vline(data = modes, mapping = ggplot2::aes(xintercept = .data$mode),
                        colour = "firebrick") +
    ggplot2::facet_wrap(ggplot2::vars(.data$parameter), scales = "free") +
    ggplot2::labs(x = xlab %||% value_label(x, vars), y = "density",
                  title = "Posterior (shaded), prior (dashed) and posterior mode",
                  caption = if (length(notes)) paste(notes, collapse = " ") else NULL) +
    ggplot2::theme_bw()
}

plot_trace <- function(x, vars, labels, xlab) {
  nd <- nrow(x$Phi)
  chain <- x$chain
  iter <- stats::ave(seq_len(nd), chain, FUN = seq_along)
  df <- do.call(rbind, lapply(vars, function(v) {
    data.frame(parameter = labels[[v]], draw = iter, value = unname(x$Phi[, v]),
               chain = factor(chain))
  }))
  df$parameter <- factor(df$parameter, unname(labels[vars]))
  p <- ggplot2::ggplot(df, ggplot2::aes(x = .data$draw, y = .data$value, group = .data$chain))
  p <- if (length(unique(chain)) > 1L) {
    p + ggplot2::geom_line(ggplot2::aes(colour = .data$chain), linewidth = 0.3)
  } else {
    p + ggplot2::geom_line(colour = "steelblue", linewidth = 0.3)
  }
  p + ggplot2::facet_wrap(ggplot2::vars(.data$parameter), scales = "free_y", ncol = 1) +
    ggplot2::labs(x = xlab %||% "retained draw", y = value_label(x, vars),
                  title = "Trace of the retained draws") +
    ggplot2::theme_bw()
}

plot_fits <- function(x, xlab) {
  sc <- x$model$scale
  p <- sc$p
  if (is.null(xlab)) {
    xlab <- sc$names$inputs
    if (length(xlab) != p) xlab <- paste0("x", seq_len(p))
  } else if (!is.character(xlab) || length(xlab) != p || anyNA(xlab)) {
    cli::cli_abort(
      "{.arg xlab} must be a character vector with one name per experimental input ({p}); got {.obj_type_friendly {xlab}} of length {length(xlab)}."
    )
  }
  X <- unscale_inputs(x$model$data$Xf, sc, seq_len(p))
  y <- field_response(x)
  fc <- field_conditionals(x, sampler_draws(x, which.max(x$logPost)), 1L)
  z <- stats::qnorm(0.975)
  # numeric inputs on the x axes; categorical inputs' indicators are not
  # axes (outputs get a row each)
  ind <- match(unlist(lapply(sc$factors, `[[`, "columns")), sc$names$inputs)
  axes <- setdiff(seq_len(p), ind)
  if (!length(axes)) axes <- seq_len(p)
  # a row of panels per output and per field data set (`source`): the
  # measurement-error groups, labelled as print() labels sigma2E1, ...
  out <- fits_rows(x)
  df <- do.call(rbind, lapply(axes, function(k) {
    data.frame(input = xlab[k], x = X[, k], observed = y, fitted = fc$mean[, 1],
               lower = fc$mean[, 1] - z * fc$sd[, 1], upper = fc$mean[, 1] + z * fc$sd[, 1],
               output = out %||% "")
  }))
  df$input <- factor(df$input, unique(xlab[axes]))
  if (!is.null(out)) df$output <- factor(df$output, unique(out[order(x$model$spec$model$noise %||% 1L)]))
  facet <- if (is.null(out)) ggplot2::facet_wrap(ggplot2::vars(.data$input), scales = "free_x") else
    ggplot2::facet_grid(ggplot2::vars(.data$output), ggplot2::vars(.data$input), scales = "free")
  ggplot2::ggplot(df, ggplot2::aes(x = .data$x)) +
    ggplot2::geom_linerange(ggplot2::aes(ymin = .data$lower, ymax = .data$upper),
                            colour = "steelblue", alpha = 0.6) +
    ggplot2::geom_point(ggplot2::aes(y = .data$fitted), colour = "steelblue", shape = 17) +
    ggplot2::geom_point(ggplot2::aes(y = .data$observed), colour = "firebrick") +
    facet +
    ggplot2::labs(x = if (length(axes) == 1L) xlab[axes] else NULL, y = sc$names$response,
                  title = "Field data (red) and MAP fits with 95% intervals (blue)") +
    ggplot2::theme_bw()
}

# The panel row of each field row in plot(type = "fits"): its output, its
# field data set ("lab A") or both ("conc, lab A"); NULL with neither.
fits_rows <- function(x) {
  sc <- x$model$scale
  out <- if (!is.null(sc$output)) sc$output$levels[x$model$data$outF]
  if (is.null(sc$source) || is.null(sc$noiseLabels)) return(out)
  # the data set of each row, from its measurement-error group's label
  # ("output:source" or "source")
  lab <- sc$noiseLabels[x$model$spec$model$noise]
  src <- if (is.null(out)) lab else substring(lab, nchar(out) + 2L)
  src <- paste(sc$source$name, src)
  if (is.null(out)) src else paste(out, src, sep = ", ")
}

# The probability of failure over two inputs (the others at the runs'
# median), with the runs marked.
plot_failure <- function(x, inputs) {
  predict_failure(x, NULL) # refuses a fit without failed runs, naming why
  cl <- x$model$design$failed$classifier
  nm <- colnames(cl$X)
  if (length(nm) < 2L) {
    cli::cli_abort("{.code type = \"failure\"} plots against two numeric inputs, and the runs have one ({.val {nm}}).")
  }
  inputs <- inputs %||% nm[1:2]
  if (!is.character(inputs) || length(inputs) != 2L || anyNA(inputs) || !all(inputs %in% nm) ||
      inputs[1] == inputs[2]) {
    cli::cli_abort(c(
      "{.arg inputs} must name two different numeric inputs of the simulator, among {.val {nm}}.",
      x = if (is.character(inputs)) "Got {.val {inputs}}." else "Got {.obj_type_friendly {inputs}}."
    ))
  }
  g <- expand.grid(a = seq(min(cl$X[, inputs[1]]), max(cl$X[, inputs[1]]), length.out = 60),
                   b = seq(min(cl$X[, inputs[2]]), max(cl$X[, inputs[2]]), length.out = 60))
  G <- matrix(apply(cl$X, 2, stats::median), nrow(g), length(nm), byrow = TRUE,
              dimnames = list(NULL, nm))
  G[, inputs] <- as.matrix(g)
  g$p <- failure_probability(cl, G)
  runs <- data.frame(a = cl$X[, inputs[1]], b = cl$X[, inputs[2]],
                     run = ifelse(cl$y_all == 1, "failed", "successful"))
  ggplot2::ggplot(g, ggplot2::aes(x = .data$a, y = .data$b)) +
    ggplot2::geom_raster(ggplot2::aes(fill = .data$p)) +
    ggplot2::geom_point(data = runs, ggplot2::aes(shape = .data$run)) +
    ggplot2::scale_fill_gradient(low = "white", high = "firebrick", limits = c(0, 1),
                                 name = "P(run fails)") +
    ggplot2::scale_shape_manual(values = c(failed = 4, successful = 1), name = NULL) +
    ggplot2::labs(x = inputs[1], y = inputs[2],
                  caption = if (length(nm) > 2L) {
                    paste("Other inputs at the runs' median:",
                          paste(setdiff(nm, inputs), collapse = ", "))
                  })
}
