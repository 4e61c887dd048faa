# Reading the user's columns as they meant them: by name when the data carry
# names (which one is the response included), by position otherwise; and
# saying what the data imply (inputs and calibration values outside the
# simulator design, duplicated runs, newdata naming a calibration input).

# Usable column names: present, none missing or empty, none repeated. NULL
# when the columns are unnamed (the positional contract applies).
usable_names <- function(x) {
  nm <- colnames(x)
  if (is.null(nm) || anyNA(nm) || any(nm == "")) return(NULL)
  nm
}

# Puts the columns of `sim` and `field` in the order calibrate() works in:
# response, experimental inputs, calibration inputs. When both carry column
# names, field's columns are matched by name to sim's response and inputs, in
# any order; sim's other columns, those field does not have, are the
# calibration inputs; response_column() says which shared column is the
# response. Otherwise columns are taken by position. Returns list(sim,
# field, named).
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
  extra <- setdiff(fn, sn)
  if (length(extra)) {
    cli::cli_abort(c(
      "The columns of {.arg field} are matched by name to those of {.arg sim}, and {.val {extra}} {?is/are} not in {.arg sim}.",
      i = "{.arg sim} has {.val {sn}}; {.arg field} has {.val {fn}}.",
      i = "Rename the columns, or pass both without column names ({.fn unname}) to match them by position (response first, then the same experimental inputs)."
    ), call = call)
  }
  response <- response_column(sn, fn, call = call)
  inputs <- setdiff(sn, c(response, setdiff(sn, fn)))  # sim's order
  calib <- setdiff(sn, fn)
  list(sim = sim[, c(response, inputs, calib), drop = FALSE],
       field = field[, c(response, inputs), drop = FALSE], named = TRUE)
}

# The response among named columns. field holds the response and the
# experimental inputs, sim those and the calibration inputs, so the names
# alone say which columns are inputs to calibrate, not which shared column
# is the response. sim's response is at one of its ends: first (the
# documented order) or last (a sim stored as inputs then output).
# * sim's first column in field and its last not (the documented order,
#   calibration inputs last): the first, whatever field's order;
# * otherwise field's first column (field's documented order), when it is
#   one of sim's ends and field's last column is not the other.
# Anything else is refused, naming both ends: the readings left are mirror
# images ((h, g, t) with field (t, h) against (t, g, h) with field (h, t)),
# and neither can be chosen safely. A sim without a calibration input keeps
# its first column (calibrate() refuses it).
response_column <- function(sn, fn, call = parent.frame()) {
  s1 <- sn[1]
  sL <- sn[length(sn)]
  calib <- setdiff(sn, fn)
  if (s1 %in% fn && (!sL %in% fn || !length(calib))) return(s1)
  cand <- intersect(c(s1, sL), fn)
  if (!length(cand)) {
    cli::cli_abort(c(
      "{.arg field} has neither {.val {s1}} nor {.val {sL}}, the first and last columns of {.arg sim}: one of them must be the response.",
      i = "{.arg sim} has {.val {sn}}; {.arg field} has {.val {fn}}.",
      i = "Put the response first in {.arg sim} and give {.arg field} a column of that name."
    ), call = call)
  }
  other <- setdiff(c(s1, sL), fn[1])
  if (fn[1] %in% c(s1, sL) && !identical(other, fn[length(fn)])) return(fn[1])
  reorder <- vapply(cand, function(r) {
    sprintf("`sim[, c(%s)]` if \"%s\" is the response", paste0("\"", c(r, setdiff(sn, c(r, calib)), calib), "\"", collapse = ", "), r)
  }, character(1))
  cli::cli_abort(c(
    "Cannot tell which column is the response: {.val {s1}} (first column of {.arg sim}) or {.val {sL}} (last column of {.arg sim}).",
    i = "The response is a column of both {.arg sim} and {.arg field}: first in {.arg sim} (or last, for a simulator stored as inputs then output), and first in {.arg field} when the order of {.arg sim} does not say; {.arg field} has {.val {fn}}.",
    i = "Put the response first in {.arg sim} and the calibration inputs last: {paste(reorder, collapse = ', or ')}.",
    i = if (!s1 %in% fn) "If {.val {s1}} is the response, {.arg field} needs a column of that name."
  ), call = call)
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
  sc <- object$model$scale
  p <- sc$p
  Xf <- object$model$data$Xf  # scaled field inputs
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
  if (!any(dup)) return(inform_near_duplicates(X, call = call))
  key <- row_keys(X)
  groups <- split(seq_len(nrow(X)), key)
  groups <- groups[lengths(groups) > 1L]
  groups <- groups[order(vapply(groups, min, numeric(1)))]
  tol <- replicate_tolerance(sim[, 1])
  differ <- vapply(groups, function(g) diff(range(sim[g, 1])) > tol, logical(1))
  shown <- paste(vapply(utils::head(groups, 5), function(g) paste(g, collapse = " and "), character(1)),
                 collapse = "; ")
  if (length(groups) > 5L) shown <- paste0(shown, "; ...")
  cli::cli_inform(c(
    i = "{.arg sim} has {sum(dup)} duplicated run{?s} (identical input rows): rows {shown}.",
    " " = if (any(differ)) {
      "Their responses differ in {sum(differ)} group{?s}: with {.code simNoise = \"none\"} the emulator interpolates the runs (up to a tiny nugget); {.code simNoise = \"constant\"} models the simulator's own noise."
    } else {
      "They add no information; the nugget keeps the covariance invertible."
    }
  ), call = call)
  invisible(TRUE)
}

# Runs closer than the nugget can carry: inputs that agree to within
# fbc_near_runs of each input's design range but are not identical. Their
# correlation is 1 to about 1e-12, far inside the relative nugget (1e-6),
# so they act as one run whose responses must agree; a message says where
# (near_groups(): every pair within the distance, however it falls on a
# grid; rounding to a grid missed pairs on either side of a grid line).
fbc_near_runs <- 1e-7

inform_near_duplicates <- function(X, call = parent.frame()) {
  rng <- apply(X, 2, function(v) diff(range(v)))
  rng[rng == 0] <- 1
  U <- sweep(sweep(X, 2, apply(X, 2, min), "-"), 2, rng, "/")
  groups <- near_groups(U, fbc_near_runs)
  if (!length(groups)) return(invisible(FALSE))
  shown <- paste(vapply(utils::head(groups, 5), paste, character(1), collapse = " and "),
                 collapse = "; ")
  if (length(groups) > 5L) shown <- paste0(shown, "; ...")
  cli::cli_inform(c(
    i = "{.arg sim} has {length(groups)} group{?s} of runs whose inputs differ by less than {fbc_near_runs} of each input's range: rows {shown}.",
    " " = "The emulator treats such runs as one (their correlation is 1 far inside its tiny nugget): their responses must agree, and they add no information."
  ), call = call)
  invisible(TRUE)
}

# The groups of rows of U (the runs' inputs scaled to [0, 1]) linked by
# pairs closer than `eps` in every input but not identical: a list of row
# sets, each sorted, in order of their first row. Candidates come from
# splitting the rows, input by input, where the sorted values jump by `eps`
# or more (a pair closer than eps in every input stays in one block); each
# block's pairs are then checked. O(m log m) per input for scattered
# designs.
near_groups <- function(U, eps) {
  U <- as.matrix(U)
  d <- ncol(U)
  blocks <- list(seq_len(nrow(U)))
  for (j in seq_len(d)) {
    blocks <- unlist(lapply(blocks, function(idx) {
      o <- idx[order(U[idx, j])]
      split(o, cumsum(c(TRUE, diff(U[o, j]) >= eps)))
    }), recursive = FALSE)
    blocks <- blocks[lengths(blocks) > 1L]
    if (!length(blocks)) return(list())
  }
  parent <- seq_len(nrow(U))
  find <- function(i) {
    while (parent[i] != i) i <- parent[i]
    i
  }
  for (b in blocks) {
    for (a in seq_len(length(b) - 1L)) {
      for (c in (a + 1L):length(b)) {
        dif <- abs(U[b[a], ] - U[b[c], ])
        if (all(dif < eps) && any(dif > 0)) {
          ra <- find(b[a]); rc <- find(b[c])
          if (ra != rc) parent[max(ra, rc)] <- min(ra, rc)
        }
      }
    }
  }
  root <- vapply(seq_along(parent), find, integer(1))
  linked <- which(root != seq_along(root))
  if (!length(linked)) return(list())
  groups <- split(seq_along(root), root)
  groups <- unname(groups[lengths(groups) > 1L])
  groups[order(vapply(groups, min, integer(1)))]
}

# Outputs given in wide format (several response columns) are read as a
# response and inputs: an output column shared with `field` becomes an
# experimental input. A design input is set independently of the
# calibration inputs; an output varies with them. Warns, naming the
# column, when the calibration inputs (with their squares and products with
# the other experimental inputs) explain at least `fbc_wide_share` of a
# shared column's variation in `sim` beyond what the other experimental
# inputs explain, and at least `fbc_wide_alone` of it on their own. With
# few runs a design input explains by chance a large share: the share must
# also exceed what chance gives with probability fbc_wide_chance (the
# partial R^2 of k added regressors to r columns on m runs, under
# independence and Gaussian variation Beta(k / 2, (m - r - k) / 2);
# wide_share()): 0.94 at m = 8 (p = q = 1), where the fixed 50% warned on
# 7.5% of maximin designs; 0.5 from m = 23. `sim`: the numeric matrix
# (response, p experimental, q calibration inputs, named when `named`).
# Runs chosen by design_loop() or added by update_runs() are never suspect
# (their inputs were set as inputs): those muffle the warning, a condition
# of class fbc_wide_outputs (muffle_wide_outputs()).
fbc_wide_share <- 0.5
fbc_wide_alone <- 0.1
fbc_wide_chance <- 0.001
wide_share <- function(m, r, k) max(fbc_wide_share, stats::qbeta(1 - fbc_wide_chance, k / 2, (m - r - k) / 2))

warn_wide_outputs <- function(sim, p, named = TRUE, call = parent.frame()) {
  m <- nrow(sim)
  q <- ncol(sim) - 1L - p
  if (!named || q < 1L || p < 1L) return(invisible(FALSE))
  nm <- colnames(sim)
  exper <- 1L + seq_len(p)
  calib <- 1L + p + seq_len(q)
  Tm <- scale(sim[, calib, drop = FALSE])
  flagged <- character()
  share <- numeric()
  for (j in exper) {
    v <- sim[, j]
    if (length(unique(v)) <= 2L) next  # indicators, two-level inputs
    others <- scale(sim[, setdiff(exper, j), drop = FALSE])
    others <- others[, colSums(is.finite(others)) == m, drop = FALSE]
    reduced <- cbind(1, others, others^2)
    full <- cbind(reduced, Tm, Tm^2,
                  if (ncol(others)) do.call(cbind, lapply(seq_len(ncol(Tm)), function(k) others * Tm[, k])))
    if (ncol(full) >= m - 2L) next
    rss <- function(X) sum(stats::lm.fit(X, v)$residuals^2)
    r0 <- rss(reduced)
    if (!(r0 > 0)) next
    gain <- (r0 - rss(full)) / r0
    # alone, too: given an output among the others, a design input is
    # "explained" by the calibration inputs through it
    alone <- 1 - rss(cbind(1, Tm, Tm^2)) / sum((v - mean(v))^2)
    if (gain >= wide_share(m, ncol(reduced), ncol(full) - ncol(reduced)) && alone >= fbc_wide_alone) {
      flagged <- c(flagged, nm[j])
      share <- c(share, gain)
    }
  }
  if (!length(flagged)) return(invisible(FALSE))
  cli::cli_warn(c(
    "{cli::qty(length(flagged))}Column{?s} {.val {flagged}} of {.arg sim}, read as {?an experimental input/experimental inputs} (shared with {.arg field}), {?varies/vary} with the calibration {cli::qty(q)}input{?s} {.val {nm[calib]}} in the simulator runs: {?it explains/they explain} {fmt_share(share)} of {cli::qty(length(flagged))}{?its/their} variation beyond the other inputs.",
    i = "A design input is set independently of the calibration inputs; an output is not. Is it a second output given in wide format?",
    i = "Several outputs go in long format: one response column, a column naming the output of each row, and {.code calibrate(output = \"<that column>\")} (see {.topic FBC::calibrate}, \"Categorical inputs, outputs and data sets\")."
  ), class = "fbc_wide_outputs", call = call)
  invisible(TRUE)
}

muffle_wide_outputs <- function(expr) {
  withCallingHandlers(expr, fbc_wide_outputs = function(w) invokeRestart("muffleWarning"))
}

fmt_num <- function(x) format(signif(x, 4), trim = TRUE)

# Calibration values beyond the simulator design. The emulator knows the
# simulator only over the range its runs cover for each calibration input;
# a kappa beyond it rests on the emulator's extrapolation. As for field
# inputs, a sliver of `fbc_field_margin` of the design's width beyond it is
# tolerated. A prior reaches beyond the design when it puts more than
# `fbc_kappa_beyond_share` of its mass beyond that widened range (an
# improper prior: when its support does); the posterior, when more than
# that share of its draws lie there. A prior that puts less than
# `fbc_kappa_min_mass` of its mass on the design's range has no support
# there: refused. The default beta prior is stretched over the design's
# range and never reaches beyond it.
fbc_kappa_beyond_share <- 0.01
fbc_kappa_min_mass <- 1e-9

# The design's range of each calibration input, its widened bounds, the
# inputs' names and labels ("g (kappa1)").
kappa_design <- function(scale) {
  cal <- scale$p + seq_len(scale$q)
  lo <- scale$xmin[cal]
  hi <- scale$xmax[cal]
  margin <- fbc_field_margin * (hi - lo)
  nm <- scale$names$calibration
  list(lo = lo, hi = hi, lo_wide = lo - margin, hi_wide = hi + margin,
       names = nm, label = sprintf("%s (kappa%d)", nm, seq_len(scale$q)),
       range = sprintf("%s to %s", vapply(lo, fmt_num, ""), vapply(hi, fmt_num, "")))
}

# At calibrate(): refuses a kappa prior with no support on the design's
# range (naming kappaDist, kappaP1, kappaP2 and the range) and warns about a
# prior reaching beyond it, or a fixed kappa beyond it. `kappa` holds the
# checked dist, init, p1, p2 (native units) of each calibration parameter.
check_kappa_design <- function(kappa, scale, call = parent.frame()) {
  des <- kappa_design(scale)
  none <- beyond <- character()
  for (j in seq_len(scale$q)) {
    d <- kappa$dist[j]
    p1 <- kappa$p1[j]
    p2 <- kappa$p2[j]
    if (d == "beta") next  # stretched over the design's range
    if (d == "fixed") {
      v <- kappa$init[j]
      if (!is.na(v) && (v < des$lo_wide[j] || v > des$hi_wide[j])) {
        beyond <- c(beyond, sprintf("%s: the simulator design covers %s; %s is fixed at %s",
                                    des$label[j], des$range[j], des$names[j], fmt_num(v)))
      }
      next
    }
    f <- prior_registry[[d]]
    sup <- f$support(p1, p2)
    pars <- c(p1 = p1, p2 = p2)[names(f$params)]
    what <- sprintf("the %s prior%s", d, if (length(pars)) {
      sprintf(" (%s)", paste(f$params, "=", vapply(pars, fmt_num, ""), collapse = ", "))
    } else " (improper)")
    if (f$proper) {
      finite <- all(is.finite(sup))
      reach <- if (finite) sup else f$quantile(c(0.005, 0.995), p1, p2)
      on <- f$cdf(des$hi[j], p1, p2) - f$cdf(des$lo[j], p1, p2)
      out <- 1 - (f$cdf(des$hi_wide[j], p1, p2) - f$cdf(des$lo_wide[j], p1, p2))
      far <- out > fbc_kappa_beyond_share
      desc <- sprintf("puts %s of its mass beyond it, %s %s to %s", fmt_share(out),
                      if (finite) "reaching" else "its central 99% reaching",
                      fmt_num(reach[1]), fmt_num(reach[2]))
    } else {
      on <- if (min(sup[2], des$hi[j]) > max(sup[1], des$lo[j])) 1 else 0
      far <- sup[1] < des$lo_wide[j] || sup[2] > des$hi_wide[j]
      desc <- sprintf("reaches %s to %s", fmt_num(sup[1]), fmt_num(sup[2]))
    }
    line <- sprintf("%s: the simulator design covers %s; %s %s", des$label[j], des$range[j],
                    what, desc)
    if (on < fbc_kappa_min_mass) {
      none <- c(none, line)
    } else if (far) {
      beyond <- c(beyond, line)
    }
  }
  if (length(none)) {
    cli::cli_abort(c(
      "The prior of {cli::qty(length(none))}{?a calibration parameter/calibration parameters} has no support on the range the simulator design covers.",
      stats::setNames(none, rep("x", length(none))),
      i = "The emulator knows the simulator only where it was run: give {.arg kappaDist}, {.arg kappaP1} and {.arg kappaP2} a prior on that range (the default beta prior is stretched over it), or extend the simulator design."
    ), call = call)
  }
  if (length(beyond)) {
    cli::cli_warn(c(
      "Calibration values beyond the simulator design: where the posterior goes there, it rests on the emulator's extrapolation.",
      stats::setNames(beyond, rep("*", length(beyond))),
      i = "{.fn print} and {.fn convergence_messages} say how much of the posterior lies beyond; keep the prior (or the fixed value) within the design's range (the default beta prior is stretched over it) or extend the simulator design."
    ), class = "fbc_extrapolation", call = call)
  }
  invisible(length(beyond) > 0L)
}

# Draws (rows of Phi) with a kappa beyond its design's widened range:
# data.frame(var, label, range, share, lower, upper, fixed) of the
# calibration parameters with more than `fbc_kappa_beyond_share` of their
# draws there (lower, upper: the range of their draws; fixed: a fixed prior).
kappa_beyond <- function(x, rows = seq_len(nrow(x$Phi))) {
  des <- kappa_design(x$model$scale)
  cols <- x$indices$kappa
  fixed <- phi_spec(x)$table$family[cols] == prior_families[["fixed"]]
  out <- list()
  for (j in seq_along(cols)) {
    v <- x$Phi[rows, cols[j]]
    far <- v < des$lo_wide[j] | v > des$hi_wide[j]
    if (mean(far) > fbc_kappa_beyond_share) {
      out[[length(out) + 1L]] <- data.frame(
        var = colnames(x$Phi)[cols[j]], label = des$label[j], range = des$range[j],
        share = mean(far), lower = min(v), upper = max(v), fixed = fixed[j])
    }
  }
  if (length(out)) do.call(rbind, out) else NULL
}

# The posterior's kappa beyond the design, as convergence_messages() says it.
kappa_beyond_messages <- function(x) {
  b <- kappa_beyond(x)
  if (is.null(b)) return(character())
  ifelse(b$fixed,
         sprintf("%s is fixed at %s, beyond the simulator design's %s: the fit and its predictions rest on the emulator's extrapolation. Fix it within the design or extend the simulator design.",
                 b$label, fmt_num(b$lower), b$range),
         sprintf("%s of the draws of %s lie beyond the simulator design's %s (the draws range from %s to %s): there the posterior rests on the emulator's extrapolation. Narrow the prior to the design's range or extend the simulator design.",
                 fmt_share(b$share), b$label, b$range, fmt_num(b$lower), fmt_num(b$upper)))
}

# At predict(): the draws used with a kappa beyond the design.
warn_kappa_beyond <- function(x, rows, call = parent.frame()) {
  b <- kappa_beyond(x, rows)
  if (is.null(b)) return(invisible(FALSE))
  at <- ifelse(b$lower == b$upper, paste("at", vapply(b$lower, fmt_num, "")),
               sprintf("from %s to %s", vapply(b$lower, fmt_num, ""), vapply(b$upper, fmt_num, "")))
  lines <- sprintf("%s: %s of the draws used, %s; the simulator design covers %s",
                   b$label, fmt_share(b$share), at, b$range)
  cli::cli_warn(c(
    "The prediction uses calibration values beyond the simulator design: there it rests on the emulator's extrapolation.",
    stats::setNames(lines, rep("*", length(lines)))
  ), class = "fbc_extrapolation", call = call)
  invisible(TRUE)
}

# A share as a percentage: "37%", "< 1%" below 1% (never "0%" for a share above 0).
fmt_share <- function(x) ifelse(x > 0 & x < 0.01, "< 1%", sprintf("%.0f%%", 100 * x))

# Columns of `newdata` named like a calibration input: predict() predicts at
# the posterior draws of kappa (the simulator too: eta(x, kappa) at each
# draw), so a value given there would be ignored. Refused, saying why.
refuse_calibration_columns <- function(nm, scale, call = parent.frame()) {
  if (!isTRUE(scale$named) || is.null(nm)) return(invisible(TRUE))
  cal <- intersect(scale$names$calibration, nm)
  if (!length(cal)) return(invisible(TRUE))
  keep <- paste0("\"", scale$names$inputs, "\"", collapse = ", ")
  cli::cli_abort(c(
    "{.arg newdata} has {cli::qty(length(cal))}{?a column/columns} {.val {cal}} named like {?a calibration input/calibration inputs}, which {.fn predict} cannot set.",
    i = "Every prediction, {.code type = \"simulator\"} included, is made at the posterior draws of the calibration parameters (the calibrated simulator is {.code eta(x, kappa)} at each draw), so {cli::qty(length(cal))}{?this column/these columns} would be ignored.",
    i = "Drop {cli::qty(length(cal))}{?it/them} ({.code newdata[, c({keep})]}) to predict at the calibrated values; {.fn emulator_cv} shows how the emulator predicts the simulator runs."
  ), call = call)
}
