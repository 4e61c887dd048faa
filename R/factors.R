# Categorical inputs, several outputs and several field data sets: the
# factor columns of `sim`, `field` and `newdata`, read into the numeric
# design the rest of FBC works with.
#
# A categorical input (a factor or character column of both `sim` and
# `field`: an experimental input) with levels l_1 .. l_L becomes indicator
# columns: one, [c = l_2], for two levels; one per level, [c = l_a], for
# three or more. They carry the level of each row (so product designs over
# the levels stay product designs, and newdata is matched by level name),
# but enter neither GP's separable kernel: their thetaS and thetaB are held
# at 0 (alphaS and alphaB at 2) and left out of Phi. Each GP multiplies its
# kernel instead by the levels' correlation,
#   R((x, a), (x', b)) = R(x, x') C[a, b],
# an unstructured L x L correlation matrix, positive definite by
# construction from its L (L - 1) / 2 canonical partial correlations rhoS
# (rhoB for the bias), each in (-1, 1) (src/levels.cpp). We chose the
# unstructured correlation over a structured one: 0.1.x's product of one
# factor per level (correlation f_a f_b, f in (0, 1]) could not express a
# negative correlation between outputs and, with one level uncorrelated
# with the others, left only the product of the others' factors determined
# (the 3-output benchmark's chains did not converge; see
# bench/RESULTS-outputs.md). For two levels it is one exchangeable
# correlation, now signed; with many levels the L (L - 1) / 2 parameters
# grow quickly.
#
# Several outputs: `output` names a categorical input of both `sim` and
# `field`. Besides being an input of both GPs (so the simulator GP and the
# bias correlate the outputs as above), each output is standardised on its
# own and has its own measurement-error variance.
#
# Several field data sets: `source` names a factor column of `field` only;
# each source has its own measurement-error variance. The measurement-error
# groups are the output x source combinations present in `field`.

# Is column j of a data frame categorical (factor or character)?
is_categorical <- function(x) is.factor(x) || is.character(x)

# Reads the factor columns of `sim` and `field` (data frames or matrices).
# Returns list(sim, field) with each categorical input replaced by its
# indicator columns (numeric data frames), and `factors`: the categorical
# inputs (list of name, levels, columns), `output` (its name and levels, or
# NULL), `source` (likewise) and the codes of each row: outS, outF (output
# level, 1-based), srcF (source level), noise (the measurement-error group
# of each field row, 1-based) with the groups' labels.
read_factors <- function(sim, field, output = NULL, source = NULL, call = parent.frame()) {
  none <- list(sim = sim, field = field, factors = list(), output = NULL, source = NULL,
               noise = NULL, noiseLabels = NULL)
  catS <- if (is.data.frame(sim)) names(sim)[vapply(sim, is_categorical, logical(1))] else character()
  catF <- if (is.data.frame(field)) names(field)[vapply(field, is_categorical, logical(1))] else character()
  if (!is.null(output)) check_string(output, "output", call = call)
  if (!is.null(source)) check_string(source, "source", call = call)
  if (!length(catS) && !length(catF) && is.null(output) && is.null(source)) return(none)
  check_role_columns(sim, field, output, source, call = call)
  check_no_missing_levels(sim, c(catS, output), "sim", output, source, call = call)
  check_no_missing_levels(field, c(catF, output, source), "field", output, source, call = call)
  if (!is.null(source) && is.data.frame(sim) && source %in% names(sim)) {
    cli::cli_abort("{.arg source} = {.val {source}} is a column of {.arg sim}: a field data set is not a simulator input.", call = call)
  }
  src <- NULL
  if (!is.null(source)) {
    f <- factor(field[[source]])
    src <- list(name = source, levels = levels(f), codes = as.integer(f))
    field <- field[, names(field) != source, drop = FALSE]
    catF <- setdiff(catF, source)
  }
  check_shared_categorical(sim, catS, catF, names(field), source, call = call)
  factors <- list()
  for (nm in catS) {
    levs <- if (is.factor(sim[[nm]])) levels(droplevels(sim[[nm]])) else sort(unique(sim[[nm]]))
    if (length(levs) < 2L) {
      cli::cli_abort("The categorical input {.val {nm}} has one level in {.arg sim} ({.val {levs}}): every input must vary over the simulator design.", call = call)
    }
    check_levels(field[[nm]], levs, nm, "field", call = call)
    cols <- indicator_names(nm, levs)
    factors[[nm]] <- list(name = nm, levels = levs, columns = cols)
    sim <- replace_by_indicators(sim, nm, levs, cols)
    field <- replace_by_indicators(field, nm, levs, cols)
  }
  out <- NULL
  outS <- outF <- NULL
  if (!is.null(output)) {
    out <- factors[[output]][c("name", "levels", "columns")]
    outS <- match(as.character(attr(sim, "fbc_codes")[[output]]), out$levels)
    # the outputs' names, for fbc_scale()'s messages
    attr(outS, "labels") <- out$levels
    outF <- match(as.character(attr(field, "fbc_codes")[[output]]), out$levels)
  }
  ng <- noise_groups(outF, src, out, nrow(field))
  attr(sim, "fbc_codes") <- NULL
  attr(field, "fbc_codes") <- NULL
  list(sim = sim, field = field, factors = factors, output = out, source = src,
       outS = outS, outF = outF, noise = ng$noise, noiseLabels = ng$labels)
}

# `output` and `source` name a factor or character column: the output of
# both `sim` and `field`, the data set of `field` only.
check_role_columns <- function(sim, field, output, source, call = parent.frame()) {
  for (nm in c(output, source)) {
    where <- if (identical(nm, output)) c("sim", "field") else "field"
    for (w in where) {
      d <- if (w == "sim") sim else field
      if (!is.data.frame(d) || !nm %in% names(d) || !is_categorical(d[[nm]])) {
        arg <- if (identical(nm, output)) "output" else "source"
        cli::cli_abort(c(
          "{.arg {arg}} = {.val {nm}} must name a factor or character column of {.arg {w}}.",
          i = if (arg == "output") "The outputs are in long format: one row per run (or observation) and output, the output's name in that column, its value in the response column." else
            "The field data sets are stacked in {.arg field}, the data set of each row in that column; {.arg sim} has no such column.",
          i = if (arg == "output" && w == "sim" && is.data.frame(field) && nm %in% names(field)) {
            "{.val {nm}} is a column of {.arg field} only: if it says which field data set each row comes from, name it with {.arg source} instead."
          }
        ), call = call)
      }
    }
  }
}

# A categorical column is an experimental input: in both `sim` and `field`
# (`catS`, `catF` their categorical columns; `fieldNames` the columns of
# `field`, the data sets' column removed).
check_shared_categorical <- function(sim, catS, catF, fieldNames, source, call = parent.frame()) {
  onlySim <- setdiff(catS, fieldNames)
  if (length(onlySim)) {
    cli::cli_abort(c(
      "{.arg sim} has categorical {cli::qty(length(onlySim))}column{?s} {.val {onlySim}} that {.arg field} lacks: a calibration input must be numeric.",
      i = "A categorical input is an experimental input: give it in both {.arg sim} and {.arg field}."
    ), call = call)
  }
  onlyField <- setdiff(catF, catS)
  numInSim <- intersect(onlyField, if (is.data.frame(sim)) names(sim) else colnames(sim))
  if (length(numInSim)) {
    cli::cli_abort(c(
      "{cli::qty(length(numInSim))}Column{?s} {.val {numInSim}} {?is/are} numeric in {.arg sim} but not in {.arg field}.",
      i = "{cli::qty(length(numInSim))}Convert {?it/them} in {.arg field} (e.g. with {.fn as.numeric}), or make {?it/them} categorical in both."
    ), call = call)
  }
  if (length(onlyField)) {
    cli::cli_abort(c(
      "{.arg field} has categorical {cli::qty(length(onlyField))}column{?s} {.val {onlyField}} that {.arg sim} lacks: a column of {.arg field} alone is not an input of the simulator.",
      i = if (is.null(source)) "If it says which field data set each row comes from, name it with {.arg source}; if it is an input, give it in {.arg sim} too; else drop it." else
        "Give each categorical input in both {.arg sim} and {.arg field}; the field data sets' column ({.val {source}}) is the only column of {.arg field} alone."
    ), call = call)
  }
}

# The measurement-error groups: the output x data-set combinations present
# in `field` (`outF` each field row's output, `src` the data sets, `out`
# the outputs), as each row's group (1-based) and the groups' labels; NULL
# for one group.
noise_groups <- function(outF, src, out, n) {
  # measurement-error groups: output x source combinations present in field
  go <- if (is.null(outF)) rep(1L, n) else outF
  gs <- if (is.null(src)) rep(1L, n) else src$codes
  key <- paste(go, gs)
  ukey <- unique(key[order(go, gs)])
  noise <- match(key, ukey)
  first <- match(ukey, key)
  labels <- vapply(first, function(i) paste(c(if (!is.null(out)) out$levels[go[i]],
                                              if (!is.null(src)) src$levels[gs[i]]), collapse = ":"),
                   character(1))
  if (length(ukey) < 2L) return(list(noise = NULL, labels = NULL))
  list(noise = noise, labels = labels)
}

# A missing value (NA, or "") in a categorical column (a categorical input,
# the `output` or `source` column) is refused naming the column and rows:
# it would otherwise become a level of its own (a data set "NA" with its own
# noise) or fail later.
check_no_missing_levels <- function(d, cols, arg, output = NULL, source = NULL,
                                    call = parent.frame()) {
  if (!is.data.frame(d)) return(invisible(TRUE))
  for (nm in intersect(unique(cols), names(d))) {
    x <- d[[nm]]
    bad <- which(is.na(x) | (is.character(x) & x == ""))
    if (!length(bad)) next
    role <- if (identical(nm, output)) "named by {.arg output}" else
      if (identical(nm, source)) "named by {.arg source}" else "a categorical input"
    n <- length(bad)
    rows <- paste(utils::head(bad, 10L), collapse = ", ")
    more <- if (n > 10L) sprintf(" and %d more", n - 10L) else ""
    cli::cli_abort(c(
      paste0("Column {.val {nm}} of {.arg {arg}} (", role, ") has {cli::qty(n)}{?a missing value/missing values}: {cli::qty(n)}row{?s} {rows}{more}."),
      i = "{cli::qty(n)}Each row needs its level: fill {?it/them} in or drop {?that row/those rows}."
    ), call = call)
  }
  invisible(TRUE)
}

# What each partial correlation of the categorical inputs' levels (rhoS1,
# rhoS2, ...; the same for rhoB) correlates, in order: "mat: b~a" for the
# correlation of levels b and a, "mat: c~b | a" for the partial correlation
# of c and b given a (column by column, as src/levels.cpp takes them).
level_labels <- function(factors) {
  unlist(lapply(factors, function(f) {
    l <- f$levels
    L <- length(l)
    unlist(lapply(seq_len(L - 1L), function(j) {
      given <- if (j > 1L) paste0(" | ", paste(l[seq_len(j - 1L)], collapse = ", ")) else ""
      sprintf("%s: %s~%s%s", f$name, l[(j + 1L):L], l[j], given)
    }))
  }), use.names = FALSE)
}

# Where each categorical input's partial correlations sit among its class's
# (rhoS1, rhoS2, ...: L (L - 1) / 2 per input, inputs in order): a list of
# positions, one per input.
level_positions <- function(factors) {
  n <- vapply(factors, function(f) (length(f$levels) * (length(f$levels) - 1L)) %/% 2L, integer(1))
  unname(split(seq_len(sum(n)), factor(rep(seq_along(n), n), levels = seq_along(n))))
}

# The indicator columns' names of a categorical input: one for two levels,
# one per level from three.
indicator_names <- function(nm, levs) {
  use <- if (length(levs) == 2L) levs[2] else levs
  sprintf("%s[%s]", nm, use)
}

# Each row's level (1-based) from its indicator columns `ind` (a matrix,
# native units, indicator_names()' layout): one column for two levels, one
# per level from three.
indicator_codes <- function(ind) {
  if (ncol(ind) == 1L) 1L + as.integer(round(ind[, 1])) else max.col(ind, "first")
}

# Levels of x not among `levs` are refused, naming the column and levels.
check_levels <- function(x, levs, nm, arg, call = parent.frame()) {
  bad <- setdiff(unique(as.character(x)), levs)
  if (length(bad)) {
    cli::cli_abort(c(
      "Column {.val {nm}} of {.arg {arg}} has {cli::qty(length(bad))}{?a level/levels} the simulator runs do not: {.val {bad}}.",
      i = "The levels of {.val {nm}} in {.arg sim} are {.val {levs}}; the emulator knows nothing of another."
    ), call = call)
  }
  invisible(TRUE)
}

# The indicator columns `cols` (indicator_names()' layout, a matrix) of the
# levels x (character).
indicator_matrix <- function(x, cols) {
  ind <- vapply(sub("^.*\\[(.*)\\]$", "\\1", cols), function(l) as.numeric(x == l),
                numeric(length(x)))
  matrix(ind, nrow = length(x), dimnames = list(NULL, cols))
}

# The data frame d with column nm (categorical, levels levs) replaced, in
# place, by its indicator columns `cols`; the codes are kept in an
# attribute for the output's per-row level.
replace_by_indicators <- function(d, nm, levs, cols) {
  x <- as.character(d[[nm]])
  ind <- indicator_matrix(x, cols)
  j <- match(nm, names(d))
  codes <- attr(d, "fbc_codes") %||% list()
  codes[[nm]] <- x
  out <- cbind(d[, seq_len(j - 1L), drop = FALSE], as.data.frame(ind, check.names = FALSE),
               d[, setdiff(seq_along(d), seq_len(j)), drop = FALSE])
  attr(out, "fbc_codes") <- codes
  out
}

# A data frame's categorical inputs (columns named as in `sim`, levels as
# its) replaced by their indicator columns; `arg` names it in errors.
levels_to_indicators <- function(X, sc, arg, call = parent.frame()) {
  if (!is.data.frame(X)) {
    cli::cli_abort("{.arg {arg}} must be a data frame with the categorical {cli::qty(length(sc$factors))}input{?s} {.val {names(sc$factors)}} as columns.", call = call)
  }
  for (f in sc$factors) {
    if (!f$name %in% names(X)) {
      cli::cli_abort("{.arg {arg}} has no column {.val {f$name}}, a categorical input of the calibration (levels {.val {f$levels}}).", call = call)
    }
    check_levels(X[[f$name]], f$levels, f$name, arg, call = call)
    X <- replace_by_indicators(X, f$name, f$levels, f$columns)
  }
  attr(X, "fbc_codes") <- NULL
  X
}

# propose_runs()'s points with each categorical input's indicator columns
# back to one column of its levels (a factor, where its first indicator
# was).
indicators_to_levels <- function(out, sc) {
  for (f in sc$factors) {
    j <- match(f$columns, names(out))
    lev <- factor(f$levels[indicator_codes(as.matrix(out[j]))], levels = f$levels)
    out[[j[1]]] <- lev
    names(out)[j[1]] <- f$name
    if (length(j) > 1L) out <- out[-j[-1]]
  }
  out
}

# newdata for predict(): its categorical columns replaced by the fit's
# indicator columns (unknown levels refused), and the measurement-error
# group of each row (needed for type = "field" with several groups).
read_newdata_factors <- function(newdata, scale, type, call = parent.frame()) {
  fac <- scale$factors
  if (!length(fac) && is.null(scale$source)) return(list(newdata = newdata, noise = integer()))
  # (the output's codes read before its column becomes indicators; a matrix,
  # a missing column or an unknown level is refused by levels_to_indicators())
  outF <- if (!is.null(scale$output)) fac[[scale$output$name]]
  outCodes <- if (!is.null(outF) && outF$name %in% names(newdata)) {
    match(as.character(newdata[[outF$name]]), outF$levels)
  }
  newdata <- levels_to_indicators(newdata, scale, "newdata", call)
  srcCodes <- NULL
  if (!is.null(scale$source)) {
    s <- scale$source
    if (s$name %in% names(newdata)) {
      check_levels(newdata[[s$name]], s$levels, s$name, "newdata", call = call)
      srcCodes <- match(as.character(newdata[[s$name]]), s$levels)
      newdata <- newdata[, names(newdata) != s$name, drop = FALSE]
    } else if (type == "field" || (isTRUE(scale$sourceBias) && type != "simulator")) {
      cli::cli_abort(c(
        "{.code type = \"{type}\"} needs the field data set of each new point: {.arg newdata} has no column {.val {s$name}}.",
        i = if (isTRUE(scale$sourceBias)) "Each data set has its own bias ({.val {s$levels}}); only {.code type = \"simulator\"} does not depend on it." else
          "Each data set has its own measurement error ({.val {s$levels}}); the other types do not depend on it."
      ), call = call)
    }
  }
  noise <- integer()
  if (!is.null(scale$noiseLabels) && type == "field") {
    lab <- vapply(seq_len(nrow(newdata)), function(i) paste(c(
      if (!is.null(outCodes)) scale$output$levels[outCodes[i]],
      if (!is.null(srcCodes)) scale$source$levels[srcCodes[i]]), collapse = ":"), character(1))
    noise <- match(lab, scale$noiseLabels)
    if (anyNA(noise)) {
      cli::cli_abort("{.arg newdata} asks for the field at {.val {unique(lab[is.na(noise)])}}, a combination with no field data: its measurement error is unknown.", call = call)
    }
  }
  list(newdata = newdata, noise = noise, output = outCodes,
       source = if (isTRUE(scale$sourceBias) && type != "simulator") srcCodes else integer())
}

#' Correlation between the levels of a categorical input
#'
#' The correlation the simulator GP (or the bias GP) puts between the levels
#' of a categorical input of a calibration (see "Categorical inputs,
#' outputs and data sets" in `vignette("model", package = "FBC")`), at each posterior draw's
#' correlation parameters, averaged over the draws.
#'
#' @param fit An `fbc` object from [calibrate()] with a categorical input.
#' @param input The input's name (a column of `sim` and `field`), or with
#'   `sourceBias = "own"` the field data sets' column (`gp = "bias"`).
#' @param gp `"simulator"` (default) or `"bias"`.
#' @return A square matrix with the levels as row and column names. When a
#'   correlation's draws sit both near +1 and near -1 (at least 10% within
#'   0.1 of each), a warning says so: the average is then neither answer.
#' @export
#' @examples
#' \donttest{
#' set.seed(1)
#' sim <- data.frame(y = 0, x = runif(60), out = rep(c("a", "b"), 30), t = runif(60))
#' sim$y <- sin(4 * sim$x * sim$t) + (sim$out == "b") * sim$x
#' field <- data.frame(y = sin(4 * (1:10) / 10 * 0.5) + rnorm(10, 0, 0.05),
#'                     x = (1:10) / 10, out = "a")
#' fit <- calibrate(sim, field, nMCMC = 600, nBurn = 300, nChains = 2,
#'                  kernelS = "matern52")
#' level_correlation(fit, "out")
#' }
level_correlation <- function(fit, input, gp = c("simulator", "bias")) {
  fit <- check_fbc(fit, "fit")
  gp <- match_choice(gp, c("simulator", "bias"), "gp")
  fac <- fit$model$scale$factors
  src <- fit$model$scale$source
  own <- isTRUE(fit$model$scale$sourceBias)
  if (!length(fac) && !own) {
    cli::cli_abort(c(
      "{.arg fit} has no categorical input.",
      i = if (!is.null(src) && identical(input, src$name)) {
        "{.val {input}} names the field data sets, which share one bias ({.code sourceBias = \"shared\"}): there is no correlation between their biases to show. {.code calibrate(source = \"{input}\", sourceBias = \"own\")} gives each data set its own bias, correlated by {.field rhoD}."
      }
    ))
  }
  if (!own && !is.null(src) && identical(input, src$name)) {
    cli::cli_abort(c(
      "{.val {input}} names the field data sets, not a categorical input: they share one bias ({.code sourceBias = \"shared\"}), so there is no correlation between their biases to show.",
      i = "{.code calibrate(source = \"{input}\", sourceBias = \"own\")} gives each data set its own bias, correlated by {.field rhoD}; the categorical {cli::qty(length(fac))}input{?s} of {.arg fit} {?is/are} {.val {names(fac)}}."
    ))
  }
  input <- match_choice(input, c(names(fac), if (own) src$name), "input")
  if (identical(fit$model$options$outputs, "independent")) {
    if (identical(input, fit$model$scale$output$name)) {
      cli::cli_abort(c(
        "The outputs ({.val {input}}) of {.arg fit} are modelled independently ({.code outputs = \"independent\"}): each has its own GPs, uncorrelated with the others'.",
        i = "{.code calibrate(..., outputs = \"shared\")} correlates them through one simulator GP, whose level correlation this shows."
      ))
    }
    fac <- level_factors(fit$model)
  }
  if (gp == "bias" && identical(fit$model$discrepancy, "none")) {
    cli::cli_abort("{.arg fit} has no bias GP ({.code discrepancy = \"none\"}).")
  }
  if (own && identical(input, src$name)) {
    # the field data sets' biases (sourceBias = "own"): rhoD
    if (gp != "bias") {
      cli::cli_abort("The field data sets {.val {input}} enter the bias only: use {.code gp = \"bias\"}.")
    }
    draws <- sampler_draws(fit)[, fit$model$spec$classes == "rhoD", drop = FALSE]
    warn_split_rho(draws, fit$model$spec$vars[fit$model$spec$classes == "rhoD"])
    return(mean_level_corr(draws, src$levels))
  }
  cls <- if (gp == "simulator") "rhoS" else "rhoB"
  if (!any(fit$model$spec$classes == cls)) {
    cli::cli_abort(c(
      "{.arg fit} has no level correlations ({.field {cls}}): it was made by a version of FBC that correlated levels through the indicators' {.field {if (gp == 'simulator') 'thetaS' else 'thetaB'}}.",
      i = "Refit it with this version to get the levels' correlation."
    ))
  }
  k <- match(input, names(fac))
  pos <- level_positions(fac)[[k]]
  draws <- sampler_draws(fit)[, fit$model$spec$classes == cls, drop = FALSE][, pos, drop = FALSE]
  warn_split_rho(draws, fit$model$spec$vars[fit$model$spec$classes == cls][pos])
  mean_level_corr(draws, fac[[k]]$levels)
}

# A correlation whose draws sit both near +1 and near -1 (at least
# `fbc_split_share` of them within 0.1 of each) has two answers, the levels
# moving together or oppositely; their average, near 0, is neither: said
# with the shares.
fbc_split_share <- 0.1
warn_split_rho <- function(draws, vars, call = parent.frame()) {
  for (j in seq_len(ncol(draws))) {
    up <- mean(draws[, j] > 0.9)
    down <- mean(draws[, j] < -0.9)
    if (up >= fbc_split_share && down >= fbc_split_share) {
      cli::cli_warn(c(
        "{.field {vars[j]}} has two answers: {round(100 * up)}% of its draws lie near +1 (the levels move together) and {round(100 * down)}% near -1 (they move oppositely).",
        i = "The average correlation returned is neither; look at the draws ({.code plot(fit, \"rhoS\", type = \"trace\")}, or {.val rhoB}, {.val rhoD}) before reading it, and compare chains: each may have settled on one sign."
      ), call = call)
    }
  }
  invisible()
}

# The level correlation averaged over the rows of `draws` (each row one
# draw's partial correlations), named by `levels`.
mean_level_corr <- function(draws, levels) {
  L <- length(levels)
  acc <- matrix(0, L, L)
  for (d in seq_len(nrow(draws))) acc <- acc + .level_corr(L, draws[d, ])[[1]]
  matrix(acc / nrow(draws), L, L, dimnames = list(levels, levels))
}
