# Small argument checks. Each names the argument and says what is allowed.

check_count <- function(x, arg = caller_arg(x), min = 1, call = parent.frame()) {
  if (!is.numeric(x) || length(x) != 1L || is.na(x) || !is.finite(x) ||
      x != round(x) || x < min) {
    cli::cli_abort(
      "{.arg {arg}} must be a whole number of at least {min} (got {format_value(x)}).",
      call = call
    )
  }
  imax <- .Machine$integer.max
  if (x > imax) {
    cli::cli_abort(c(
      "{.arg {arg}} must be at most {format(imax, big.mark = ',')} (got {format(x, big.mark = ',', scientific = FALSE)}).",
      i = "Counts are stored as integers; run long chains in pieces with {.fn update}."
    ), call = call)
  }
  as.integer(x)
}

# The retained draws of a run must fit in memory: each chain's draws are one
# matrix (at most .Machine$integer.max elements), and all chains' draws (plus
# their log posterior and log likelihood, and the copy made when the chains
# are stacked) must fit in the machine's memory. `kept` is the number of
# draws each chain will hold in the end (old and new for update()), `d` the
# number of parameters, `iters` the total sweeps per chain.
check_run_size <- function(kept, d, nChains, iters, args, thin = TRUE, call = parent.frame()) {
  imax <- .Machine$integer.max
  kept <- as.numeric(kept)
  if (iters > imax) {
    cli::cli_abort(c(
      "The chains would run {format(iters, big.mark = ',', scientific = FALSE)} sweeps in all, more than the {format(imax, big.mark = ',')} a chain can count.",
      i = "Use a smaller {.arg {args[1]}}."
    ), call = call)
  }
  bytes <- 2 * nChains * kept * (d + 2) * 8
  limit <- fbc_memory_limit()
  what <- sprintf("%s draws per chain x %d parameters x %d chain%s",
                  format(kept, big.mark = ",", scientific = FALSE), d, nChains,
                  if (nChains == 1) "" else "s")
  if (kept * d > imax || bytes > limit) {
    cli::cli_abort(c(
      "The retained draws would need {format_bytes(bytes)} ({what}), more than can be stored{if (is.finite(limit)) paste0(' (memory: ', format_bytes(limit), ')') else ''}.",
      i = "Keep fewer draws: a smaller {.or {.arg {args}}}{if (thin) ', or a larger `thinning`' else ''}."
    ), call = call)
  }
  invisible(bytes)
}

# Memory the draws may use: the FBC.memory_limit option (bytes), else the
# machine's total memory where /proc/meminfo tells it, else no limit.
fbc_memory_limit <- function() {
  opt <- getOption("FBC.memory_limit")
  if (!is.null(opt)) return(as.numeric(opt))
  info <- tryCatch(readLines("/proc/meminfo", n = 1L, warn = FALSE), error = function(e) "")
  kb <- suppressWarnings(as.numeric(sub("^MemTotal:\\s+([0-9]+) kB.*$", "\\1", info)))
  if (length(kb) == 1L && is.finite(kb)) kb * 1024 else Inf
}

format_bytes <- function(x) {
  units <- c("bytes", "kB", "MB", "GB", "TB", "PB")
  k <- max(1L, min(length(units), floor(log(max(x, 1), 1000)) + 1L))
  paste(format(signif(x / 1000^(k - 1L), 3), scientific = FALSE), units[k])
}

check_flag <- function(x, arg = caller_arg(x), call = parent.frame()) {
  if (!is.logical(x) || length(x) != 1L || is.na(x)) {
    cli::cli_abort("{.arg {arg}} must be {.code TRUE} or {.code FALSE}, not {format_value(x, typed = TRUE)}.", call = call)
  }
  x
}

check_string <- function(x, arg = caller_arg(x), call = parent.frame()) {
  if (!is.character(x) || length(x) != 1L || is.na(x)) {
    cli::cli_abort("{.arg {arg}} must be a single string, not {format_value(x, typed = TRUE)}.", call = call)
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

# A value for a message, with its type when that may be what is wrong: a
# string is quoted and called one ("300" given for a count), a vector or
# another object is named by its type and length. A single number is shown
# as it is, or as "the number 0.5" when `typed` (where a string was expected).
format_value <- function(x, typed = FALSE) {
  if (is.null(x)) return("NULL")
  if (length(x) != 1L || !is.atomic(x) || is.object(x)) {
    what <- if (is.object(x)) paste0("a <", class(x)[1], "> object")
            else if (is.character(x)) "a character vector" else if (is.numeric(x)) "a numeric vector"
            else if (is.logical(x)) "a logical vector" else if (is.list(x)) "a list"
            else if (is.function(x)) "a function" else paste("an object of type", typeof(x))
    return(if (is.function(x)) what else paste0(what, " of length ", length(x)))
  }
  if (is.na(x)) return("NA")
  if (is.character(x)) return(sprintf("the string \"%s\"", x))
  if (typed && is.numeric(x)) return(paste("the number", format(x)))
  format(x)
}

# A value given where one of a few names was expected: a string quoted, as
# the names are; anything else with its type (format_value(typed = TRUE)).
format_choice <- function(x) {
  if (is.character(x) && length(x) == 1L && !is.na(x)) sprintf("\"%s\"", x) else format_value(x, typed = TRUE)
}

# `sampler` is "blocks" or "single"; the old `blockSim` flag maps onto it,
# unless `sampler` is given too (not its default vector) and says otherwise.
check_sampler <- function(sampler, blockSim = NULL, call = parent.frame()) {
  if (!is.null(blockSim)) {
    check_flag(blockSim, "blockSim", call = call)
    new <- if (blockSim) "blocks" else "single"
    if (!identical(sampler, c("blocks", "single")) && !identical(sampler, new)) {
      cli::cli_abort(c(
        "{.arg blockSim} = {blockSim} and {.arg sampler} = {format_choice(sampler)} disagree.",
        i = "{.arg blockSim} is deprecated: give {.arg sampler} only."
      ), call = call)
    }
    cli::cli_warn(c(
      "{.arg blockSim} is deprecated; use {.code sampler = \"{new}\"}.",
      i = "The default sampler ({.val blocks}) moves {.code thetaS}, {.code alphaS} and {.code sigma2S} jointly, and more (see {.help FBC::calibrate})."
    ), call = call)
    return(new)
  }
  if (!is.character(sampler) || length(sampler) < 1L || anyNA(sampler)) {
    cli::cli_abort("{.arg sampler} must be {.val blocks} or {.val single}, not {format_choice(sampler)}.", call = call)
  }
  if (length(sampler) > 1L) sampler <- sampler[1L]
  if (!sampler %in% c("blocks", "single")) {
    cli::cli_abort("{.arg sampler} must be {.val blocks} or {.val single}, not {.val {sampler}}.", call = call)
  }
  sampler
}

# S3 methods take `...` because their generics do; an argument that lands
# there is a typo (`lvl =` for `level =`) or one the method does not support
# (`update(fit, sim = other)`), and silently ignoring it gives the user an
# answer to another question. `check_dots_empty(...)` refuses it, naming the
# argument and the closest formal argument of `fn` ("did you mean");
# `action = "warn"` only warns, for methods that other code calls with
# arguments meant for other methods (print(), conversions).
check_dots_empty <- function(..., fn, name, cls = "fbc", action = c("abort", "warn"),
                             call = parent.frame()) {
  n <- ...length()
  if (n == 0L) return(invisible(TRUE))
  action <- match.arg(action)
  # the names only: the arguments themselves are not evaluated
  nms <- names(as.list(substitute(list(...)))[-1L]) %||% rep("", n)
  shown <- ifelse(nms == "", paste0("an unnamed argument (position ", seq_len(n), ")"),
                  paste0("`", nms, "`"))
  formals_ <- setdiff(names(formals(fn)), "...")
  hints <- character()
  for (nm in nms[nms != ""]) {
    dist <- drop(utils::adist(nm, formals_, ignore.case = TRUE))
    close <- formals_[order(dist)][sort(dist) <= max(2, nchar(nm) %/% 3)]  # closest first
    if (!length(close)) close <- formals_[startsWith(formals_, nm)]
    if (length(close)) hints <- c(hints, sprintf("Did you mean `%s` instead of `%s`?", close[1], nm))
  }
  msg <- c(
    "{cli::qty(n)}Argument{?s} {shown} {?is/are} not used by {.fn {name}} for {.cls {cls}} objects.",
    stats::setNames(hints, rep("i", length(hints))),
    i = "Its arguments are {.arg {formals_}}."
  )
  if (action == "abort") {
    cli::cli_abort(msg, class = "fbc_unused_dots", call = call)
  } else {
    cli::cli_warn(msg, class = "fbc_unused_dots", call = call)
  }
}

# One of `choices` (the first when `x` is the default vector).
match_choice <- function(x, choices, arg, call = parent.frame()) {
  if (identical(x, choices)) return(choices[1])
  if (!is.character(x) || length(x) != 1L || is.na(x) || !(x %in% choices)) {
    cli::cli_abort(
      "{.arg {arg}} must be one of {.or {.val {choices}}}, not {format_choice(x)}.",
      call = call
    )
  }
  x
}

# Field data with the response alone (no experimental input: a few scalar
# observations of a simulator whose inputs are all calibration inputs) are
# refused by name: the model's bias GP and the field rows of the emulator
# are functions of the experimental inputs, and FBC has no model without
# one yet. (A constant input column is no way round it: the scaling needs
# every input to vary over the simulator design.)
check_experimental_input <- function(field, call = parent.frame()) {
  if ((is.matrix(field) || is.data.frame(field)) && ncol(field) == 1L) {
    cli::cli_abort(c(
      "{.arg field} has the response only: FBC needs at least one experimental input, a column that {.arg field} and {.arg sim} share.",
      i = "The discrepancy GP and the emulator's field predictions are functions of the experimental inputs (p >= 1); a simulator whose inputs are all calibration inputs (p = 0) is not supported yet.",
      i = "If the observations were made at settings of some input (a time, a position, a condition), give that input in both {.arg field} and {.arg sim}."
    ), call = call)
  }
  invisible(TRUE)
}

