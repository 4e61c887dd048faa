# Interop: the draws of an fbc object as coda and posterior objects.

# The draws of each chain as a list of matrices (iterations x parameters),
# with lp__ (log posterior) appended when `lp` is TRUE.
chain_draws <- function(x, lp = FALSE) {
  lapply(split_chains(x), function(ch) if (lp) cbind(ch$Phi, lp__ = ch$logPost) else ch$Phi)
}

#' Draws of a calibration for coda and posterior
#'
#' Convert the retained draws of an `fbc` object, one chain each, to a
#' [coda::mcmc.list()] or to a [posterior::draws_df()] so that coda's
#' diagnostics, the posterior package's summaries and bayesplot's plots work
#' on them. The parameters are the columns of `x$Phi` (calibration parameters
#' in their own units, hyperparameters on the scaled space); the posterior
#' draws also carry `lp__`, the log posterior density.
#'
#' @param x An `fbc` object from [calibrate()].
#' @param ... Not used: an argument given here gives a warning (other code
#'   may pass arguments meant for other methods).
#' @return `as.mcmc.list()`: a `coda` `mcmc.list` with one `mcmc` per chain
#'   (iteration numbers count sweeps from the start, burn-in included).
#'   `as_draws()` and `as_draws_df()`: a `draws_df`.
#' @name fbc-draws
#' @examples
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 600, nBurn = 200, nChains = 2)
#' d <- posterior::as_draws_df(fit)
#' posterior::summarise_draws(d)
#' if (requireNamespace("coda", quietly = TRUE)) {
#'   coda::gelman.diag(coda::as.mcmc.list(fit))
#' }
NULL

#' @rdname fbc-draws
#' @exportS3Method coda::as.mcmc.list
as.mcmc.list.fbc <- function(x, ...) {
  check_dots_empty(..., fn = as.mcmc.list.fbc, name = "as.mcmc.list", action = "warn")
  rlang_check_installed("coda")
  x <- check_fbc(x, "x")
  s <- x$settings
  out <- lapply(chain_draws(x), function(m) {
    coda::mcmc(m, start = s$nBurn + s$thinning, thin = s$thinning)
  })
  coda::mcmc.list(out)
}

#' @rdname fbc-draws
#' @exportS3Method posterior::as_draws
as_draws.fbc <- function(x, ...) {
  check_dots_empty(..., fn = as_draws.fbc, name = "as_draws", action = "warn")
  as_draws_df.fbc(x)
}

#' @rdname fbc-draws
#' @exportS3Method posterior::as_draws_df
as_draws_df.fbc <- function(x, ...) {
  check_dots_empty(..., fn = as_draws_df.fbc, name = "as_draws_df", action = "warn")
  ms <- chain_draws(check_fbc(x, "x"), lp = TRUE)
  df <- do.call(rbind, lapply(seq_along(ms), function(k) {
    d <- as.data.frame(ms[[k]])
    d$.chain <- k
    d$.iteration <- seq_len(nrow(d))
    d
  }))
  rownames(df) <- NULL
  posterior::as_draws_df(df)
}

rlang_check_installed <- function(pkg) {
  if (!requireNamespace(pkg, quietly = TRUE)) {
    cli::cli_abort("The {.pkg {pkg}} package is needed for this; install it with {.code install.packages(\"{pkg}\")}.")
  }
}
