# Defaults chosen from the session.

# calibrate()'s `showProgress`: NULL (the default) shows the progress bar
# where a person waits for the run (an interactive session) and stays
# silent in scripts (Rscript, R CMD BATCH) and while knitr renders a
# document; TRUE or FALSE as given.
default_progress <- function(showProgress, interactive = base::interactive(),
                             knitting = isTRUE(getOption("knitr.in.progress")),
                             call = parent.frame()) {
  if (is.null(showProgress)) return(interactive && !knitting)
  check_flag(showProgress, "showProgress", call = call)
}
