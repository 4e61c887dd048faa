# Defaults chosen from the session.

# calibrate()'s `showProgress`: NULL (the default) shows the progress bar
# where a person waits for the run (an interactive session) and stays
# silent in scripts (Rscript, R CMD BATCH) and while knitr renders a
# document; TRUE or FALSE as given.
default_progress <- function(showProgress, interactive = base::interactive(),
                             knitting = isTRUE(getOption("knitr.in.progress")),
                             call = parent.frame()) {
  if (is.null(showProgress)) return(interactive && !knitting)
  if (!is.logical(showProgress) || length(showProgress) != 1L || is.na(showProgress)) {
    cli::cli_abort(c(
      "{.arg showProgress} must be {.code TRUE}, {.code FALSE} or {.code NULL}, not {format_value(showProgress, typed = TRUE)}.",
      i = "{.code NULL} (the default) shows progress in an interactive session and not in scripts or {.pkg knitr}."
    ), call = call)
  }
  showProgress
}
