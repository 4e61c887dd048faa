# Checkpoints: the files of a run directory, a run's identity, opening a
# directory to resume (the chains run in R/run.R).
#
# Files of a run directory (`checkpoint = dir`, or a temporary one under a
# parallel plan, for interrupts):
#   run.rds        what the run is: data, priors, settings, each chain's
#                  start and random stream, an id (written once, first)
#   chain-<k>.rds  chain k's latest checkpoint: sampler state, RNG state,
#                  draws kept so far, acceptance sums, finished or not
#   chain-<k>.pid  the process running chain k and its host (while it runs)
#   STOP           the main session asks the workers to stop (Ctrl-C)
# Every file is written to a temporary name in the same directory and
# renamed, so a kill at any instant leaves the previous or the new version.

check_checkpoint <- function(checkpoint, every, call = parent.frame()) {
  if (!is.null(checkpoint)) check_string(checkpoint, "checkpoint", call = call)
  if (!is.numeric(every) || length(every) != 1L || is.na(every) || every < 0) {
    cli::cli_abort(
      "{.arg checkpointEvery} must be a number of seconds, 0 or more (got {format_value(every)}).",
      call = call
    )
  }
  invisible()
}
fbc_checkpoint_format <- 1L

# ---------------------------------------------------------------- files ----

# saveRDS to a temporary file in the same directory, then rename: readers
# see the old or the new file, never half of one.
write_atomic <- function(object, path) {
  tmp <- file.path(dirname(path), paste0(".", basename(path), ".", Sys.getpid(), ".tmp"))
  saveRDS(object, tmp, compress = FALSE)
  if (!file.rename(tmp, path)) {
    unlink(tmp)
    stop("could not rename ", tmp, " to ", path)
  }
  invisible(path)
}

chain_file <- function(dir, k, ext = "rds") file.path(dir, sprintf("chain-%d.%s", k, ext))

# Reads a checkpoint file; a file that cannot be read, or is not what it
# should be, is refused with the way out.
read_checkpoint_file <- function(path, what, id = NULL, call = parent.frame()) {
  obj <- tryCatch(readRDS(path), error = function(e) NULL, warning = function(w) NULL)
  known <- is.list(obj) && is_count(obj$format) && obj$format <= fbc_checkpoint_format
  ok <- known && (is.null(id) || identical(obj$id, id))
  if (!ok) {
    why <- if (!is.list(obj)) "it is corrupt or truncated" else
      if (!known) "it was written by another version of FBC" else
        "it belongs to another run"
    fix <- if (what == "run") {
      "Remove the directory (or use another) to start a new run."
    } else {
      "Delete {.file {basename(path)}} to rerun that chain from its start (it gives the same draws), or use a new directory."
    }
    cli::cli_abort(c(
      "Cannot resume from {.file {path}}: {why}.",
      i = fix, i = "Nothing was changed."
    ), call = call)
  }
  upgrade_fbc(obj, call = call)
}

# The settings a run's identity leaves out at their defaults (the kernels,
# the discrepancy model), so that checkpoints written before the setting
# existed still match a default run.
identity_defaults <- list(kernelS = "powexp", kernelB = "powexp", discrepancy = "gp")

# What makes a run the same run: data and priors as the sampler sees them,
# and the settings (but identity_defaults at their defaults). The numeric
# `sim` and `field` carry the response, the inputs, the categorical inputs
# (outputs included) as indicator columns and the row order; what the
# model takes from the other columns, each field row's measurement-error
# group (output x data set) and data set (a bias per data set), is in
# `groups` (left out when there is none, so older checkpoints still match).
run_identity <- function(sim, field, spec, settings) {
  default <- vapply(names(settings), function(s) {
    s %in% names(identity_defaults) && identical(settings[[s]], identity_defaults[[s]])
  }, logical(1))
  settings <- settings[!default]
  groups <- Filter(Negate(is.null), list(noise = spec$model$noise, source = spec$model$source))
  c(list(sim = unname(sim), field = unname(field),
         priors = list(table = spec$table, init = spec$init, logsd = spec$logsd),
         settings = settings),
    if (length(groups)) list(groups = groups))
}

# The field rows whose group differs between two codings (NULL: one group;
# with `single = FALSE`, NULL is not compared: another setting says it), in
# words.
group_differences <- function(old, new, what, single = TRUE) {
  if (!single && (is.null(old) || is.null(new))) return(character())
  n <- max(length(old), length(new))
  a <- old %||% rep(1L, n)
  b <- new %||% rep(1L, n)
  if (identical(a, b)) return(character())
  if (length(a) != length(b) || max(a) != max(b)) {
    return(sprintf("The field rows' %s differ from the checkpoint's: %d there, %d now.", what,
                   max(a), max(b)))
  }
  rows <- which(a != b)
  shown <- paste(utils::head(rows, 5L), collapse = ", ")
  more <- if (length(rows) > 5L) sprintf(" and %d more", length(rows) - 5L) else ""
  sprintf("The field rows' %s differ from the checkpoint's (%s %s%s).", what,
          if (length(rows) == 1L) "row" else "rows", shown, more)
}

# Differences between a checkpoint's identity and the call's, in words.
identity_differences <- function(old, new, vars) {
  out <- character()
  if (!identical(old$sim, new$sim)) out <- c(out, "{.arg sim} differs from the checkpoint's simulator runs.")
  if (!identical(old$field, new$field)) out <- c(out, "{.arg field} differs from the checkpoint's field data.")
  if (identical(old$field, new$field)) {
    out <- c(out,
             group_differences(old$groups$noise, new$groups$noise,
                               "measurement-error groups (outputs x data sets, columns `output` and `source`)"),
             group_differences(old$groups$source, new$groups$source, "data sets (column `source`)",
                               single = FALSE))
  }
  if (!identical(nrow(old$priors$table), nrow(new$priors$table))) {
    out <- c(out, sprintf("The model has %d parameters in the checkpoint and %d now.",
                          nrow(old$priors$table), nrow(new$priors$table)))
  } else if (!identical(old$priors, new$priors)) {
    rows <- vapply(seq_along(vars), function(j) {
      !identical(old$priors$table[j, ], new$priors$table[j, ]) ||
        !identical(old$priors$init[j], new$priors$init[j])
    }, logical(1))
    who <- if (any(rows)) paste(vars[rows], collapse = ", ") else "the proposals"
    out <- c(out, paste0("The priors or initial values differ (", who, ")."))
  }
  for (s in union(names(old$settings), names(new$settings))) {
    a <- old$settings[[s]]
    b <- new$settings[[s]]
    if (s %in% names(identity_defaults)) {  # left out when the default
      a <- a %||% identity_defaults[[s]]
      b <- b %||% identity_defaults[[s]]
    }
    if (!identical(a, b)) {
      out <- c(out, sprintf("`%s` differs: %s in the checkpoint, %s now.", s, format_setting(a),
                            format_setting(b)))
    }
  }
  out
}

# A setting's value in a checkpoint message: a number or string as is, a
# list (converge's rule) as its fields (a NULL field as the R value, e.g.
# `every = NULL`: the growing stretches), a NULL setting as "not set".
format_setting <- function(x) {
  if (is.null(x)) return("not set")
  if (is.atomic(x) && length(x) == 1L) return(format(x))
  if (is.atomic(x)) return(paste0("c(", paste(format(x), collapse = ", "), ")"))
  if (is.list(x) && !is.null(names(x))) {
    fields <- vapply(x, function(v) if (is.null(v)) "NULL" else format_setting(v), character(1))
    return(paste(names(x), fields, sep = " = ", collapse = ", "))
  }
  "another value"
}

# The message of a resumed run: where each chain is, out of nMCMC, or under
# a `converge` rule out of nMCMC at first and up to the rule's maxMCMC.
inform_resumed <- function(dir, starts, nMCMC, converge = NULL) {
  at <- vapply(starts, function(s) as.integer(s$state$iter), integer(1))
  of <- if (is.null(converge)) sprintf("of %d", nMCMC) else
    sprintf("(`converge`: a first stretch of %d, then on until converged or %d)", nMCMC,
            converge$maxMCMC)
  cli::cli_inform("Resuming the run in {.file {dir}}: {cli::qty(length(at))}chain{?s} at iteration{?s} {at} {of}.")
}

# Opens (or creates) the run directory of calibrate(checkpoint = dir).
# Returns list(dir, id, every, user = TRUE, resumed, starts, seeds): the
# chains' starts and streams, from the checkpoint when the directory holds
# one of the same run (else those given). Refuses, changing nothing, when
# the directory holds something else.
open_checkpoint <- function(dir, every, identity, starts, seeds, vars, call = parent.frame()) {
  # workers may start elsewhere (a cluster job's directory): an absolute path
  if (dir.exists(dir)) dir <- normalizePath(dir)
  runFile <- file.path(dir, "run.rds")
  if (file.exists(runFile)) {
    run <- read_checkpoint_file(runFile, "run", call = call)
    diffs <- identity_differences(run$identity, identity, vars)
    if (length(diffs)) {
      cli::cli_abort(c(
        "{.arg checkpoint} {.file {dir}} holds another run: refusing to continue it.",
        stats::setNames(diffs, rep("x", length(diffs))),
        i = "Call {.fn calibrate} with the checkpoint's data and settings to resume it, or give a new directory for a new run.",
        i = "Nothing was changed."
      ), call = call)
    }
    starts <- run$starts
    seeds <- run$seeds
    for (k in seq_along(starts)) {
      f <- chain_file(dir, k)
      if (file.exists(f)) {
        ck <- read_checkpoint_file(f, "chain", id = run$id, call = call)
        starts[[k]] <- ck$start
        seeds[[k]] <- ck$seed
      }
    }
    return(list(dir = dir, id = run$id, every = every, user = TRUE, resumed = TRUE,
                starts = starts, seeds = seeds))
  }
  if (dir.exists(dir) && length(list.files(dir, all.files = TRUE, no.. = TRUE))) {
    cli::cli_abort(c(
      "{.arg checkpoint} {.file {dir}} is not empty and holds no FBC checkpoint ({.file run.rds}).",
      i = "Give a new or empty directory."
    ), call = call)
  }
  if (!dir.exists(dir) && !dir.create(dir, recursive = TRUE, showWarnings = FALSE)) {
    cli::cli_abort("Cannot create the checkpoint directory {.file {dir}}.", call = call)
  }
  dir <- normalizePath(dir)
  id <- basename(tempfile("run-"))
  write_atomic(list(format = fbc_checkpoint_format, id = id, identity = identity,
                    starts = starts, seeds = seeds, fbc = as.character(utils::packageVersion("FBC")),
                    created = Sys.time()), runFile)
  list(dir = dir, id = id, every = every, user = TRUE, resumed = FALSE,
       starts = starts, seeds = seeds)
}

