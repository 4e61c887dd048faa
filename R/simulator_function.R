# The simulator as an R function: calibrate(f, field, ...) with
# f(x, kappa) called inside the sampler, no emulator. The model object is an
# fbc_model like any other (R/model-object.R) with:
#   - no simulator GP: the classes thetaS, alphaS, rhoS and sigma2S have
#     length 0 (class_sizes(emulator = FALSE)), no runs (m = 0);
#   - the calibration inputs' number, names and ranges from the kappa prior
#     (kappaDist = "uniform", kappaP1 = lower, kappaP2 = upper), which also
#     scale kappa to [0, 1] for the sampler as a design's range would;
#   - the response standardised by the mean of f over the field inputs at
#     the prior's centre (kappaInit when given) and the sd of the field
#     response (see vignette("model"), "The simulator as a function");
#   - several outputs (`output`, discrepancy "none" only): the output column
#     of the field becomes its indicator columns as for runs (R/factors.R),
#     f sees the column itself; each output standardised on its own, a
#     noise variance each;
#   - `simulator`: list(f, x, nonFinite), and in the compiled model the two
#     closures the compiled core calls (function_closures()): the scaled f
#     at the field rows for one kappa (once per kappa proposal), and at new
#     inputs (prediction, once per draw).

# The model of calibrate(f, field, ...): what build_model() is for runs.
build_function_model <- function(f, field, kappa, hypers, discrepancy, kernelB, sampler,
                                 blockSim, output, source, sourceBias, nonFinite,
                                 modelCall = NULL, call = parent.frame()) {
  check_simulator_function(f, call = call)
  nonFinite <- match_choice(nonFinite, c("error", "reject"), "nonFinite", call = call)
  discrepancy <- match_choice(discrepancy, names(discrepancy_codes), "discrepancy", call = call)
  refuse_function_options(output, sourceBias, discrepancy, call = call)
  src <- function_source(field, source, call = call)
  out <- function_output(src$field, output, call = call)
  field <- out$field
  fm <- check_data_matrix(field, "field", min_cols = 2L, min_rows = 1L, call = call)
  p <- ncol(fm) - 1L
  inputNames <- usable_names(fm)[-1] %||% paste0("x", seq_len(p))
  x <- function_inputs(fm[, -1, drop = FALSE], inputNames, is.data.frame(field), out$output,
                       out$codes)
  kap <- function_kappa(kappa, c(inputNames, out$output$name), call = call)
  q <- length(kap$lower)
  ng <- if (!is.null(out$output)) noise_groups(out$codes, src$source, out$output, nrow(fm)) else
    list(noise = src$noise, labels = src$noiseLabels)
  sampler <- check_sampler(sampler, blockSim, call = call)
  kernelB <- check_kernel(kernelB, "kernelB", call = call)
  if (!inherits(hypers, "fbc_hypers")) {
    cli::cli_abort("{.arg hypers} must come from {.fn set_hyperPriors}, not {.obj_type_friendly {hypers}}.", call = call)
  }
  warn_emulator_hypers(hypers, call = call)
  hypers <- kernel_hypers(discrepancy_hypers(hypers, discrepancy, kernelB, call = call),
                          "matern52", kernelB, call = call)
  # the response's scaling: f at the prior's centre (a check of f too)
  k0 <- ifelse(is.na(kap$spec$init), (kap$lower + kap$upper) / 2, kap$spec$init)
  k0 <- stats::setNames(k0, kap$names)
  f0 <- function_values(f, x, k0, nrow(fm), nonFinite)
  if (is.null(f0)) {
    cli::cli_abort(c(
      "The simulator function must be finite at the prior's centre or {.arg kappaInit} ({kappa_text(k0)}): the response is scaled by its values there.",
      i = "Give {.arg kappaInit} where the function is finite."
    ), call = call)
  }
  scale <- function_scale(fm, f0, kap, inputNames, named = !is.null(usable_names(fm)), out$codes)
  dat <- list(Xf = unname(scale_inputs(fm[, -1, drop = FALSE], scale, seq_len(p))),
              yf = unname((fm[, 1] - y_mean(scale, out$codes)) / y_sd(scale, out$codes)),
              Xs = matrix(numeric(0), 0L, p + q), ys = numeric(0))
  scale[c("source", "noiseLabels")] <- list(src$source[c("name", "levels")], ng$labels)
  if (!is.null(out$output)) {
    scale$output <- out$output
    scale$factors <- stats::setNames(list(out$output), out$output$name)
  }
  spec <- build_priors(kap$spec, hypers, scale, p, q, discrepancy,
                       noise = length(ng$labels %||% 1L), emulator = FALSE, call = call)
  spec$model <- compiled_model(p, q, kernel_codes[["matern52"]], kernel_codes[[kernelB]],
                               algebra = algebra_codes[["dense"]], discrepancy, noise = ng$noise,
                               simulator = function_closures(f, x, scale, nonFinite, out$codes),
                               Xf = dat$Xf, asked = intersect(unique(spec$classes), user_classes))
  alg <- list(name = "function", code = algebra_codes[["dense"]], neighbours = NULL,
              forced = FALSE, reason = "the simulator is a function, called once per kappa proposal (no emulator)",
              dims = NULL)
  design <- list(factors = scale$factors, output = out$output, source = src$source,
                 noise = ng$noise, noiseLabels = ng$labels, levels = NULL, biasSource = NULL)
  model <- new_fbc_model(
    data = dat, raw = list(sim = NULL, field = fm), scale = scale, design = design, spec = spec,
    kernelS = "matern52", kernelB = kernelB, discrepancy = discrepancy, sampler = sampler,
    algebra = alg,
    moves = sampler_moves(sampler, spec, large = FALSE, jump = TRUE),
    options = list(algebra = "auto", neighbours = NULL, output = output, source = source,
                   sourceBias = "shared"),
    call = modelCall)
  model$simulator <- list(f = f, x = x, nonFinite = nonFinite)
  validate_fbc_model(model, call = call)
}

# `sim` as a function must take (x, kappa).
check_simulator_function <- function(f, call = parent.frame()) {
  args <- names(formals(f))
  if (is.primitive(f) || (length(args) < 2L && !"..." %in% args)) {
    cli::cli_abort(c(
      "{.arg sim} as a function must take two arguments, {.code f(x, kappa)}.",
      i = "{.arg x}: the field inputs (one row per point, the field's column names); {.arg kappa}: a named numeric vector of the calibration inputs. It returns one response per row of {.arg x}."
    ), call = call)
  }
  invisible(f)
}

# What the function model does not take yet: several outputs with a bias
# (the bias would need the outputs' level correlation), a bias per field
# data set.
refuse_function_options <- function(output, sourceBias, discrepancy, call = parent.frame()) {
  if (!is.null(output) && discrepancy != "none") {
    cli::cli_abort(c(
      "{.arg output} with a simulator function needs {.code discrepancy = \"none\"}, not {.val {discrepancy}}, yet.",
      i = "Several outputs of a function share kappa with a noise variance each; a bias over the outputs (their level correlation) is only built for runs: give runs as {.arg sim} for it."
    ), call = call)
  }
  if (!identical(sourceBias, c("shared", "own")) && !identical(sourceBias, "shared")) {
    cli::cli_abort(c(
      "{.arg sourceBias} cannot be used with a simulator function yet.",
      i = "A simulator function calibrates one bias shared by the field data sets ({.arg source}); give runs as {.arg sim} for a bias per data set."
    ), call = call)
  }
}

# Several outputs in long format (`output`, a factor or character column of
# field; discrepancy "none"): list(field with that column replaced by its
# indicator columns (as for runs, R/factors.R), output = list(name, levels,
# columns), codes: each row's output, 1-based). f sees the column itself.
function_output <- function(field, output, call = parent.frame()) {
  if (is.null(output)) return(list(field = field))
  check_string(output, "output", call = call)
  if (!is.data.frame(field) || !output %in% names(field) || !is_categorical(field[[output]])) {
    cli::cli_abort(c(
      "{.arg output} = {.val {output}} must name a factor or character column of {.arg field}.",
      i = "The outputs are in long format: one row per observation and output, the output's name in that column, its value in the response column."
    ), call = call)
  }
  check_no_missing_levels(field, output, "field", output, NULL, call = call)
  fo <- factor(field[[output]])
  levs <- levels(fo)
  if (length(levs) < 2L) {
    cli::cli_abort("{.arg output} = {.val {output}} has one level in {.arg field} ({.val {levs}}): several outputs need at least two.", call = call)
  }
  cols <- indicator_names(output, levs)
  num <- replace_by_indicators(field, output, levs, cols)
  attr(num, "fbc_codes") <- NULL
  list(field = num, output = list(name = output, levels = levs, columns = cols),
       codes = as.integer(fo))
}

# Several field data sets (`source`, a factor or character column of
# field): list(field without that column, source = list(name, levels,
# codes), noise: each row's measurement-error group (its data set; NULL for
# one), noiseLabels). Any other non-numeric column is refused by
# check_data_matrix().
function_source <- function(field, source, call = parent.frame()) {
  if (is.null(source)) return(list(field = field))
  check_string(source, "source", call = call)
  if (!is.data.frame(field) || !source %in% names(field) || !is_categorical(field[[source]])) {
    cli::cli_abort("{.arg source} = {.val {source}} must name a factor or character column of {.arg field}.",
                   call = call)
  }
  check_no_missing_levels(field, source, "field", NULL, source, call = call)
  f <- factor(field[[source]])
  codes <- as.integer(f)
  list(field = field[, names(field) != source, drop = FALSE],
       source = list(name = source, levels = levels(f), codes = codes),
       noise = if (nlevels(f) > 1L) codes, noiseLabels = if (nlevels(f) > 1L) levels(f))
}

# The field inputs as f receives them: a data frame when the field was one,
# else a matrix, with the field's input names; with several outputs the
# output's indicator columns become the output column again (a factor,
# levels `output$levels`, rows' codes `codes`).
function_inputs <- function(X, names, frame, output = NULL, codes = NULL) {
  X <- unname(X)
  colnames(X) <- names
  if (is.null(output)) return(if (frame) as.data.frame(X) else X)
  at <- match(output$columns, names)
  d <- as.data.frame(X[, -at, drop = FALSE])
  before <- sum(seq_along(names)[-at] < at[1])
  col <- stats::setNames(data.frame(factor(output$levels[codes], levels = output$levels)), output$name)
  cbind(d[, seq_len(before), drop = FALSE], col, d[, setdiff(seq_along(d), seq_len(before)), drop = FALSE])
}

# Each row's output (1-based) from its output's indicator columns (native
# units; indicator_codes()).
output_codes <- function(X, names, output) {
  indicator_codes(X[, match(output$columns, names), drop = FALSE])
}

# The calibration inputs from the kappa prior arguments: list(spec (as
# check_class_spec() gives it), lower, upper, names). Only uniform priors
# say the ranges.
function_kappa <- function(kappa, inputNames, call = parent.frame()) {
  nm <- names(kappa$p1) %||% names(kappa$p2) %||% names(kappa$init)
  spec <- check_class_spec(kappa, "kappa", NULL, call = call)
  q <- length(spec$dist)
  if (!all(spec$dist == "uniform")) {
    cli::cli_abort(c(
      "With a simulator function, the kappa prior must say the calibration inputs' ranges: {.arg kappaDist} must be {.val uniform}, not {.val {unique(spec$dist[spec$dist != 'uniform'])}}.",
      i = "Give {.code kappaDist = \"uniform\", kappaP1 = lower, kappaP2 = upper} (one entry per calibration input; a named vector names them). There are no runs whose range a {.val beta} prior could be stretched over."
    ), call = call)
  }
  if (is.null(nm)) nm <- paste0("kappa", seq_len(q))
  if (length(nm) != q || anyNA(nm) || any(nm == "") || anyDuplicated(nm) ||
      any(nm %in% inputNames)) {
    cli::cli_abort(c(
      "The calibration inputs' names must be {q} distinct name{?s}, none an input of {.arg field}.",
      x = "The names of {.arg kappaP1} are {.val {nm}}; {.arg field}'s inputs are {.val {inputNames}}."
    ), call = call)
  }
  list(spec = spec, lower = spec$p1, upper = spec$p2, names = nm)
}

# The scaling (as fbc_scale() gives it for runs): the experimental inputs
# over the field's range (an input the field holds constant over a unit
# range), kappa over its prior's range, the response by the mean of f at
# the prior's centre `f0` and the sd of the field response (of f0 when the
# field's is 0, e.g. one row; 1 when both are); with several outputs
# (`codes`, each row's) each output by its own.
function_scale <- function(fm, f0, kap, inputNames, named, codes = NULL) {
  X <- fm[, -1, drop = FALSE]
  xmin <- apply(X, 2, min)
  xmax <- apply(X, 2, max)
  xmax[xmax == xmin] <- xmin[xmax == xmin] + 1
  groups <- split(seq_len(nrow(fm)), codes %||% rep(1L, nrow(fm)))
  ysd <- vapply(groups, function(g) {
    sds <- c(if (length(g) > 1L) stats::sd(fm[g, 1]), if (length(g) > 1L) stats::sd(f0[g]), 1)
    sds[sds > 0][1]
  }, numeric(1), USE.NAMES = FALSE)
  list(xmin = unname(c(xmin, kap$lower)), xmax = unname(c(xmax, kap$upper)),
       ymean = vapply(groups, function(g) mean(f0[g]), numeric(1), USE.NAMES = FALSE),
       ysd = ysd, p = ncol(X), q = length(kap$lower),
       named = named,
       names = list(response = usable_names(fm)[1] %||% "y", inputs = inputNames,
                    calibration = kap$names),
       factors = list(), output = NULL, source = NULL, noiseLabels = NULL)
}

# f(x, kappa) checked: one finite number per row of x. Errors name kappa
# (native units); a non-finite value is an error, or NULL (a rejected
# proposal) with nonFinite = "reject".
function_values <- function(f, x, kappa, n, nonFinite) {
  y <- tryCatch(f(x, kappa), error = function(e) {
    at <- kappa_text(kappa)
    cli::cli_abort("The simulator function failed at {at}.",
                   parent = e, call = NULL)
  })
  if (is.numeric(y) && length(y) == n && all(is.finite(y))) return(as.numeric(y))
  at <- kappa_text(kappa)
  if (!is.numeric(y) || length(y) != n) {
    cli::cli_abort(c(
      "The simulator function must return one number per row of {.arg x} ({n}); at {at} it returned {.obj_type_friendly {y}} of length {length(y)}.",
      i = "It is called once per kappa with all the field rows (vectorised), not once per row."
    ), call = NULL)
  }
  bad <- which(!is.finite(y))
  if (length(bad)) {
    if (nonFinite == "reject") return(NULL)
    cli::cli_abort(c(
      "The simulator function returned {length(bad)} non-finite value{?s} at {at} (row{?s} {utils::head(bad, 5)}).",
      i = "If the simulator is undefined there, {.code nonFinite = \"reject\"} in {.fn calibrate} rejects such kappa as proposals and the chain goes on."
    ), call = NULL)
  }
  as.numeric(y)
}

# "theta = 1.234567, b = 2": kappa in native units, for messages.
kappa_text <- function(kappa) {
  paste(sprintf("%s = %s", names(kappa), format(signif(kappa, 7))), collapse = ", ")
}

# The closures the compiled core calls (src/function.cpp), scaled like the
# data: field(u), f at the field rows for kappa u on the sampler's scale
# ([0, 1] over the prior's range), NULL for a rejected proposal; at(Xnew,
# u), f at new scaled experimental inputs (prediction). Built here, with
# only what they need in their environment (they travel to parallel
# workers with the model).
function_closures <- function(f, x, scale, nonFinite, codes = NULL) {
  p <- scale$p
  cal <- p + seq_len(scale$q)
  lo <- scale$xmin[cal]
  rng <- scale$xmax[cal] - lo
  kn <- scale$names$calibration
  inputs <- scale$names$inputs
  out <- scale$output
  frame <- is.data.frame(x)
  kappa_of <- function(u) {
    if (length(u) != length(lo)) stop("internal error: the compiled core gave kappa of length ", length(u))
    stats::setNames(lo + rng * u, kn)
  }
  ym <- y_mean(scale, codes)
  ys <- y_sd(scale, codes)
  list(
    field = function(u) {
      y <- function_values(f, x, kappa_of(u), NROW(x), nonFinite)
      if (is.null(y)) NULL else (y - ym) / ys
    },
    at = function(Xnew, u) {
      X <- unscale_inputs(Xnew, scale, seq_len(p))
      cn <- if (!is.null(out)) output_codes(X, inputs, out)
      xn <- function_inputs(X, inputs, frame, out, cn)
      (function_values(f, xn, kappa_of(u), nrow(Xnew), "error") - y_mean(scale, cn)) / y_sd(scale, cn)
    }
  )
}

# A prior given for the simulator GP's classes is not used: warn.
warn_emulator_hypers <- function(hypers, call = parent.frame()) {
  default <- set_hyperPriors()
  given <- emulator_classes[!vapply(emulator_classes, function(cls)
    identical(hypers[[cls]], default[[cls]]), logical(1))]
  if (length(given)) {
    cli::cli_warn(c(
      "A simulator function has no emulator: the priors of {.val {given}} in {.arg hypers} are not used.",
      i = "They describe the simulator GP of runs; drop them, or calibrate runs of the function as {.arg sim}."
    ), call = call)
  }
}

# What makes a run with a simulator function the same run (checkpoints):
# the function's code and what a non-finite value does.
function_identity <- function(sim) {
  list(code = paste(deparse(sim$f), collapse = "\n"), nonFinite = sim$nonFinite)
}
