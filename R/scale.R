# Scaling: inputs mapped to [0, 1] by the simulator design's range, responses
# standardised by the simulator response (see vignette("model"), "Scaling"), and
# back.

# Relative nugget added to the diagonal of the simulator correlation matrix.
fbc_nugget <- 1e-6

# Min/max of each simulator input, mean/sd of the simulator response (per
# output when `out` gives each run's output, 1-based: ymean and ysd then
# have one entry per output). `named`: whether the columns were matched by
# name (then predict() matches newdata's columns by name too).
fbc_scale <- function(sim, p, named = FALSE, out = NULL, call = parent.frame()) {
  X <- sim[, -1, drop = FALSE]
  xmin <- apply(X, 2, min)
  xmax <- apply(X, 2, max)
  const <- which(xmax == xmin)
  if (length(const)) {
    nm <- colnames(sim)[const + 1L] %||% paste0("column ", const + 1L)
    cli::cli_abort(c(
      "Every input column of {.arg sim} must vary over the simulator design.",
      x = "{.val {nm}} {?is/are} constant."
    ), call = call)
  }
  ys <- sim[, 1]
  groups <- if (is.null(out)) list(seq_along(ys)) else split(seq_along(ys), as.integer(out))
  labels <- attr(out, "labels")
  for (k in seq_along(groups)) {
    g <- groups[[k]]
    what <- if (is.null(out)) "" else
      sprintf(" for the output %s", if (is.null(labels)) k else sprintf("\"%s\"", labels[as.integer(names(groups)[k])]))
    if (length(g) < 2L || stats::sd(ys[g]) == 0) {
      cli::cli_abort(c(
        "The simulator response (first column of {.arg sim}) is constant{what}.",
        i = if (!is.null(out)) "Each output is standardised by its own runs' sd: an output the simulator never varies cannot be calibrated against; drop its rows."
      ), call = call)
    }
    warn_nearly_constant(ys[g], what = what, call = call)
  }
  names_ <- usable_names(sim) %||% c("y", paste0("x", seq_len(p)), paste0("t", seq_len(ncol(sim) - 1L - p)))
  list(xmin = unname(xmin), xmax = unname(xmax),
       ymean = vapply(groups, function(g) mean(ys[g]), numeric(1), USE.NAMES = FALSE),
       ysd = vapply(groups, function(g) stats::sd(ys[g]), numeric(1), USE.NAMES = FALSE),
       p = p, q = ncol(sim) - 1L - p, named = named,
       names = list(response = names_[1], inputs = names_[1L + seq_len(p)],
                    calibration = names_[-seq_len(p + 1L)]))
}

scale_inputs <- function(X, scale, cols) {
  sweep(sweep(X, 2, scale$xmin[cols], "-"), 2, scale$xmax[cols] - scale$xmin[cols], "/")
}

# The scaled data; with several outputs (outS, outF: each run's and each
# field row's output) each standardised by its own mean and sd, and the
# outputs kept in the data for the back-transforms.
scale_data <- function(sim, field, scale, outS = NULL, outF = NULL) {
  p <- scale$p
  out <- list(
    Xf = unname(scale_inputs(field[, -1, drop = FALSE], scale, seq_len(p))),
    yf = unname((field[, 1] - y_mean(scale, outF)) / y_sd(scale, outF)),
    Xs = unname(scale_inputs(sim[, -1, drop = FALSE], scale, seq_len(ncol(sim) - 1L))),
    ys = unname((sim[, 1] - y_mean(scale, outS)) / y_sd(scale, outS))
  )
  if (!is.null(outS)) out[c("outS", "outF")] <- list(as.integer(outS), as.integer(outF))
  out
}

# The response's mean and sd for rows of outputs `out` (NULL: the one
# output).
y_mean <- function(scale, out = NULL) if (is.null(out)) scale$ymean[1] else scale$ymean[out]
y_sd <- function(scale, out = NULL) if (is.null(out)) scale$ysd[1] else scale$ysd[out]

# Scaled inputs (columns `cols` of the inputs, on [0, 1] over the design)
# back in their own units: the one map back, for inputs and for kappa
# (whose draws the sampler keeps on [0, 1]).
unscale_inputs <- function(X, scale, cols) {
  sweep(sweep(X, 2, scale$xmax[cols] - scale$xmin[cols], "*"), 2, scale$xmin[cols], "+")
}

# Parameter draws in the sampler's parameterisation: kappa back to [0, 1].
sampler_scale <- function(Phi, scale) {
  q <- scale$q
  cal <- scale$p + seq_len(q)
  Phi[, seq_len(q)] <- sweep(sweep(Phi[, seq_len(q), drop = FALSE], 2, scale$xmin[cal], "-"),
                             2, scale$xmax[cal] - scale$xmin[cal], "/")
  unname(Phi)
}

# Relative spread of the simulator response below which it is nearly
# constant: standardising by its sd then magnifies rounding (a double holds
# about 16 digits), and the emulator fits noise.
fbc_constant_spread <- 1e-8

# Warns when the simulator response's sd is tiny against its level.
warn_nearly_constant <- function(ys, what = "", call = parent.frame()) {
  spread <- stats::sd(ys) / max(abs(ys))
  if (spread < fbc_constant_spread) {
    cli::cli_warn(c(
      "The simulator response is nearly constant{what}: its sd is {signif(spread, 2)} of its largest absolute value.",
      i = "FBC standardises the response by its sd, which here magnifies rounding in its last digits: check that {.arg sim}'s response column is the intended output, or subtract its constant part."
    ), call = call)
  }
  invisible(spread)
}

