# Small argument checks. Each names the argument and says what is allowed.

check_count <- function(x, arg = caller_arg(x), min = 1, call = parent.frame()) {
  if (!is.numeric(x) || length(x) != 1L || is.na(x) || !is.finite(x) ||
      x != round(x) || x < min) {
    cli::cli_abort(
      "{.arg {arg}} must be a whole number of at least {min} (got {format_value(x)}).",
      call = call
    )
  }
  as.integer(x)
}

check_flag <- function(x, arg = caller_arg(x), call = parent.frame()) {
  if (!is.logical(x) || length(x) != 1L || is.na(x)) {
    cli::cli_abort("{.arg {arg}} must be {.code TRUE} or {.code FALSE}.", call = call)
  }
  x
}

check_string <- function(x, arg = caller_arg(x), call = parent.frame()) {
  if (!is.character(x) || length(x) != 1L || is.na(x)) {
    cli::cli_abort("{.arg {arg}} must be a single string.", call = call)
  }
  x
}

# A numeric data matrix (matrix or data frame), finite, at least `min_cols`
# columns and `min_rows` rows. Returns a double matrix with column names kept.
check_data_matrix <- function(x, arg = caller_arg(x), min_cols = 2L, min_rows = 2L,
                              call = parent.frame()) {
  if (is.data.frame(x)) {
    bad <- !vapply(x, is.numeric, logical(1))
    if (any(bad)) {
      cli::cli_abort(c(
        "{.arg {arg}} must contain only numeric columns.",
        x = "Column{?s} {.val {names(x)[bad]}} {?is/are} not numeric."
      ), call = call)
    }
    x <- as.matrix(x)
  }
  if (!is.matrix(x) || !is.numeric(x)) {
    cli::cli_abort(
      "{.arg {arg}} must be a numeric matrix or data frame, not {.obj_type_friendly {x}}.",
      call = call
    )
  }
  storage.mode(x) <- "double"
  if (any(!is.finite(x))) {
    where <- which(!is.finite(x), arr.ind = TRUE)[1, ]
    cli::cli_abort(c(
      "{.arg {arg}} must not contain NA, NaN or infinite values.",
      x = "Found {sum(!is.finite(x))} such value{?s}; the first is in row {where[1]}, column {where[2]}."
    ), call = call)
  }
  if (ncol(x) < min_cols) {
    cli::cli_abort(
      "{.arg {arg}} must have at least {min_cols} columns (the response first, then the inputs); it has {ncol(x)}.",
      call = call
    )
  }
  if (nrow(x) < min_rows) {
    cli::cli_abort("{.arg {arg}} must have at least {min_rows} rows; it has {nrow(x)}.", call = call)
  }
  x
}

# `x` must have length 1 or `n`; returns it recycled to length n.
check_length <- function(x, n, arg, what, call = parent.frame()) {
  if (!(length(x) %in% c(1L, n))) {
    allowed <- if (n == 1L) "1" else paste("1 or", n)
    cli::cli_abort(
      "{.arg {arg}} must have length {allowed} (one per {what}); it has length {length(x)}.",
      call = call
    )
  }
  rep_len(x, n)
}

caller_arg <- function(x) {
  deparse(substitute(x, parent.frame()))
}

format_value <- function(x) {
  if (is.null(x)) return("NULL")
  if (length(x) != 1L) return(paste0("a vector of length ", length(x)))
  format(x)
}

# `sampler` is "blocks" or "single"; the old `blockSim` flag maps onto it.
check_sampler <- function(sampler, blockSim = NULL, call = parent.frame()) {
  if (!is.null(blockSim)) {
    check_flag(blockSim, "blockSim", call = call)
    new <- if (blockSim) "blocks" else "single"
    cli::cli_warn(c(
      "{.arg blockSim} is deprecated; use {.code sampler = \"{new}\"}.",
      i = "The default sampler ({.val blocks}) moves {.code thetaS}, {.code alphaS} and {.code sigma2S} jointly, and more (see {.help FBC::calibrate})."
    ), call = call)
    return(new)
  }
  if (!is.character(sampler) || length(sampler) < 1L || anyNA(sampler)) {
    cli::cli_abort("{.arg sampler} must be {.val blocks} or {.val single}, not {format_value(sampler)}.", call = call)
  }
  if (length(sampler) > 1L) sampler <- sampler[1L]
  if (!sampler %in% c("blocks", "single")) {
    cli::cli_abort("{.arg sampler} must be {.val blocks} or {.val single}, not {.val {sampler}}.", call = call)
  }
  sampler
}
