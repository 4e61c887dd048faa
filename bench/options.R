# Command-line options of the benchmarks, one style for all of them:
#
#   Rscript bench/run.R <name> [--quick] [--key=value ...] [--help]
#
#   --quick        a smoke test: short runs, to see that the script works
#   --key=value    an option; a comma-separated value gives a vector
#   --key          a logical option set to TRUE
#   --help         the benchmark's options and their defaults
#
# A script declares its options with their defaults:
#   opt <- bench_options(list(reps = 3L, part = c("sweep", "kernels")))
# and gets them back overridden by the command line, each value coerced to
# its default's type (integer, numeric, logical, character). An unknown
# option is an error that names the known ones.

bench_args <- function() {
  a <- getOption("fbc.bench.args")
  if (is.null(a)) commandArgs(trailingOnly = TRUE) else a
}

bench_options <- function(defaults = list(), args = bench_args()) {
  defaults <- c(list(quick = FALSE), defaults[setdiff(names(defaults), "quick")])
  if ("--help" %in% args) {
    cat("Options (default):\n")
    for (k in names(defaults)) {
      d <- defaults[[k]]
      cat(sprintf("  --%s=%s\n", k, if (is.null(d)) "" else paste(d, collapse = ",")))
    }
    quit(save = "no", status = 0)
  }
  opt <- defaults
  for (a in args) {
    kv <- regmatches(a, regexec("^--([A-Za-z][A-Za-z0-9_.-]*)(=(.*))?$", a))[[1]]
    if (!length(kv)) stop("argument '", a, "' is not of the form --key or --key=value", call. = FALSE)
    key <- kv[2]
    if (!key %in% names(defaults)) {
      stop("unknown option --", key, "; known: ",
           paste0("--", names(defaults), collapse = ", "), call. = FALSE)
    }
    d <- defaults[[key]]
    value <- if (nzchar(kv[3])) strsplit(kv[4], ",", fixed = TRUE)[[1]] else "TRUE"
    if (!nzchar(kv[3]) && !is.logical(d)) stop("option --", key, " needs a value", call. = FALSE)
    value <- if (is.null(d)) value else methods::as(value, class(d)[1])
    if (anyNA(value)) stop("option --", key, "=", kv[4], " is not a ", class(d)[1], call. = FALSE)
    opt[[key]] <- value
  }
  opt
}

# CPU seconds of evaluating `expr`, the process's and its finished children's
# (user + system), for the benchmarks' tables.
cpu <- function(expr) {
  t0 <- proc.time()
  force(expr)
  tm <- proc.time() - t0
  sum(tm[c(1, 2)]) + sum(tm[c(4, 5)], na.rm = TRUE)
}
