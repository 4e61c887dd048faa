# The one way R evaluates a fit at its posterior draws (prediction, the
# posterior predictive checks, held-out runs, leave-one-out): the compiled
# entry point `entry` (.fbc_predict, .fbc_heldout or .fbc_loo, whose C++
# side runs the one per-draw loop, for_each_draw() in src/fbc.h: each draw's
# factors built once, then the entry's work at that draw) called with the
# fit's data, nugget and model description and the draws `phis` (rows, on
# the sampler's scale: sampler_draws()); `...` the entry's own arguments, by
# name.
at_draws <- function(fit, entry, phis, ...) {
  d <- fit$model$data
  entry(Xf = d$Xf, yf = d$yf, Xs = d$Xs, ys = d$ys, phis = phis,
        nugget = fit$settings$nugget, model = fit$model$spec$model, ...)
}

# `fun(idx)` for the indices 1..n in blocks of `size` (memory bounded
# whatever n), with a progress bar named `name` when there is more than one
# block and the session is interactive (or option FBC.progress is TRUE);
# the list of the blocks' results.
in_blocks <- function(n, size, name, fun) {
  blocks <- split(seq_len(n), (seq_len(n) - 1L) %/% size)
  bar <- NULL
  if (length(blocks) > 1L && (interactive() || isTRUE(getOption("FBC.progress")))) {
    bar <- cli::cli_progress_bar(name, total = n, clear = TRUE)
  }
  out <- lapply(blocks, function(idx) {
    r <- fun(idx)
    if (!is.null(bar)) cli::cli_progress_update(id = bar, set = max(idx))
    r
  })
  if (!is.null(bar)) cli::cli_progress_done(id = bar)
  out
}
