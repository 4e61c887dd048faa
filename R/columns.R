# Reading the user's columns as they meant them: by name when the data carry
# names, by position otherwise; and saying what the data imply (inputs
# outside the simulator design, duplicated runs).

# Usable column names: present, none missing or empty, none repeated. NULL
# when the columns are unnamed (the positional contract applies).
usable_names <- function(x) {
  nm <- colnames(x)
  if (is.null(nm) || anyNA(nm) || any(nm == "")) return(NULL)
  nm
}

# Puts the columns of `sim` and `field` in the order calibrate() works in:
# response, experimental inputs, calibration inputs. When both carry column
# names, sim's first column is the response and field's columns are matched
# by name to sim's response and inputs, in any order; sim's other columns,
# those field does not have, are the calibration inputs. Otherwise columns
# are taken by position. Returns list(sim, field, named).
align_columns <- function(sim, field, call = parent.frame()) {
  sn <- colnames(sim)
  fn <- colnames(field)
  snu <- usable_names(sim)
  fnu <- usable_names(field)
  if (is.null(snu) || is.null(fnu)) {
    return(list(sim = sim, field = field, named = FALSE))
  }
  for (side in list(list(sn, "sim"), list(fn, "field"))) {
    dup <- unique(side[[1]][duplicated(side[[1]])])
    if (length(dup)) {
      cli::cli_abort(c(
        "The columns of {.arg {side[[2]]}} must have distinct names to be matched by name.",
        x = "{.val {dup}} appear{?s/} more than once.",
        i = "Rename them, or pass both {.arg sim} and {.arg field} without column names ({.fn unname}) to match the columns by position."
      ), call = call)
    }
  }
  response <- sn[1]
  extra <- setdiff(fn, sn)
  if (length(extra)) {
    cli::cli_abort(c(
      "The columns of {.arg field} are matched by name to those of {.arg sim}, and {.val {extra}} {?is/are} not in {.arg sim}.",
      i = "{.arg sim} has {.val {sn}} (response {.val {response}} first); {.arg field} has {.val {fn}}.",
      i = "Rename the columns, or pass both without column names ({.fn unname}) to match them by position (response first, then the same experimental inputs)."
    ), call = call)
  }
  if (!response %in% fn) {
    cli::cli_abort(c(
      "{.arg field} has no column {.val {response}}, the response (first column) of {.arg sim}.",
      i = "{.arg field} has {.val {fn}}; name its response column {.val {response}}."
    ), call = call)
  }
  inputs <- setdiff(sn[-1], setdiff(sn[-1], fn))  # sim's order
  calib <- setdiff(sn[-1], fn)
  list(sim = sim[, c(response, inputs, calib), drop = FALSE],
       field = field[, c(response, inputs), drop = FALSE], named = TRUE)
}

# Columns of `newdata` for predict(): by name when both the fit and newdata
# carry names (newdata may hold other columns too, such as the response),
# else by position. `X` is a numeric matrix.
match_newdata_columns <- function(X, scale, call = parent.frame()) {
  inputs <- scale$names$inputs
  nm <- usable_names(X)
  if (!isTRUE(scale$named) || is.null(nm)) return(X)
  miss <- setdiff(inputs, nm)
  if (length(miss)) {
    cli::cli_abort(c(
      "{.arg newdata} has no column{?s} {.val {miss}}: its columns are matched by name to the calibration's experimental inputs.",
      i = "The calibration's experimental inputs are {.val {inputs}}; {.arg newdata} has {.val {nm}}.",
      i = "Name the columns, or pass an unnamed matrix ({.fn unname}) whose columns are the inputs in this order."
    ), call = call)
  }
  dup <- intersect(nm[duplicated(nm)], inputs)
  if (length(dup)) {
    cli::cli_abort("{.arg newdata} has {cli::qty(length(dup))}{?a column/columns} {.val {dup}} more than once.", call = call)
  }
  X[, inputs, drop = FALSE]
}

# Field inputs outside the simulator design's range, by more than
# `fbc_field_margin` of the design's width (a GP emulator extrapolates a
# sliver beyond its runs well; the ball data's field heights pass the design
# by 1%): a warning naming each input and both ranges.
fbc_field_margin <- 0.05

warn_field_outside <- function(sim, field, scale, call = parent.frame()) {
  p <- scale$p
  out <- character()
  for (k in seq_len(p)) {
    rf <- range(field[, k + 1L])
    margin <- fbc_field_margin * (scale$xmax[k] - scale$xmin[k])
    if (rf[1] < scale$xmin[k] - margin || rf[2] > scale$xmax[k] + margin) {
      out <- c(out, sprintf("%s: field %s to %s, simulator design %s to %s",
                            scale$names$inputs[k], fmt_num(rf[1]), fmt_num(rf[2]),
                            fmt_num(scale$xmin[k]), fmt_num(scale$xmax[k])))
    }
  }
  if (length(out)) {
    cli::cli_warn(c(
      "Field inputs lie outside the range of the simulator design (by more than 5% of its width): the emulator extrapolates there.",
      stats::setNames(out, rep("*", length(out))),
      i = "Extend the simulator design to cover the field inputs if you can."
    ), class = "fbc_extrapolation", call = call)
  }
  invisible(length(out) > 0L)
}

# New inputs far outside both designs (beyond the range covered by the
# simulator design and the field data together, widened by
# `fbc_extrapolation_margin` of its width on each side): a warning naming
# each input and the range.
fbc_extrapolation_margin <- 0.1

warn_newdata_outside <- function(X, object, call = parent.frame()) {
  sc <- object$scale
  p <- sc$p
  Xf <- object$data$Xf  # scaled field inputs
  out <- character()
  for (k in seq_len(p)) {
    w <- sc$xmax[k] - sc$xmin[k]
    fk <- sc$xmin[k] + w * range(Xf[, k])
    lo <- min(sc$xmin[k], fk[1])
    hi <- max(sc$xmax[k], fk[2])
    margin <- fbc_extrapolation_margin * (hi - lo)
    rn <- range(X[, k])
    if (rn[1] < lo - margin || rn[2] > hi + margin) {
      nOut <- sum(X[, k] < lo - margin | X[, k] > hi + margin)
      out <- c(out, sprintf("%s: newdata %s to %s (%d point%s far outside); simulator design and field data cover %s to %s",
                            sc$names$inputs[k], fmt_num(rn[1]), fmt_num(rn[2]), nOut,
                            if (nOut == 1L) "" else "s", fmt_num(lo), fmt_num(hi)))
    }
  }
  if (length(out)) {
    cli::cli_warn(c(
      "{.arg newdata} lies far outside the inputs the calibration has seen: the predictions extrapolate there and rest on the GP prior.",
      stats::setNames(out, rep("*", length(out)))
    ), class = "fbc_extrapolation", call = call)
  }
  invisible(length(out) > 0L)
}

# Identical input rows in the simulator design: legal (the nugget keeps the
# covariance positive definite) but worth a word, more so when their
# responses differ (the emulator interpolates the runs).
inform_duplicated_runs <- function(sim, call = parent.frame()) {
  X <- sim[, -1, drop = FALSE]
  dup <- duplicated(X)
  if (!any(dup)) return(invisible(FALSE))
  key <- apply(X, 1, function(r) paste(format(r, digits = 17), collapse = "\r"))
  groups <- split(seq_len(nrow(X)), key)
  groups <- groups[lengths(groups) > 1L]
  groups <- groups[order(vapply(groups, min, numeric(1)))]
  differ <- vapply(groups, function(g) length(unique(sim[g, 1])) > 1L, logical(1))
  shown <- paste(vapply(utils::head(groups, 5), function(g) paste(g, collapse = " and "), character(1)),
                 collapse = "; ")
  if (length(groups) > 5L) shown <- paste0(shown, "; ...")
  cli::cli_inform(c(
    i = "{.arg sim} has {sum(dup)} duplicated run{?s} (identical input rows): rows {shown}.",
    " " = if (any(differ)) {
      "Their responses differ in {sum(differ)} group{?s}: FBC's emulator interpolates the runs (up to a tiny nugget), so a noisy simulator is outside its model."
    } else {
      "They add no information; the nugget keeps the covariance invertible."
    }
  ), call = call)
  invisible(TRUE)
}

fmt_num <- function(x) format(signif(x, 4), trim = TRUE)
