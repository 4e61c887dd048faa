# Several chains: their starting points and what their results say.
#
# Each chain is one future (run_chains() in run.R) with its own
# L'Ecuyer-CMRG stream drawn from the caller's RNG state (chain_seeds()), and
# the compiled sampler draws from whatever RNG the evaluating process has. So
# a run is reproduced by set.seed() whatever future::plan() is active, and
# sequential, multisession, cluster or batchtools plans give the same draws.

# Starting points on the sampler's scale, one per chain (a list). Chain 1
# starts at `spec$init` (the documented or user-given initial values); the
# others draw every sampled parameter from its prior, restricted to the
# central 10%-90% of the prior mass so that no start sits in a far tail where
# the covariance cannot be factored, and jitter the initial value (on the
# walk's scale) where the prior is improper. Kappa is drawn from its prior in
# native units and mapped to the sampler's [0, 1] scale. A draw at which the
# log-likelihood is not finite is redrawn (up to 20 times, then chain 1's
# start is used).
dispersed_inits <- function(nChains, dat, spec) {
  tab <- spec$table
  fam <- prior_family_name(tab$family)
  d <- length(spec$init)
  one <- function() {
    x <- spec$init
    for (j in seq_len(d)) {
      if (fam[j] == "fixed") next
      if (!prior_registry[[fam[j]]]$proper) {
        # no quantiles to draw from: jitter the start on the walk's scale
        x[j] <- from_walk(to_walk(x[j], tab$transform[j]) + stats::rnorm(1, 0, 0.5), tab$transform[j])
        next
      }
      v <- prior_quantile(stats::runif(1, 0.1, 0.9), fam[j], tab$p1[j], tab$p2[j])
      # the prior's argument is a + b * u with u the sampler's value (kappa:
      # native units against [0, 1]; a = 0, b = 1 elsewhere)
      x[j] <- (v - tab$a[j]) / tab$b[j]
    }
    x
  }
  ok <- function(x) {
    is.finite(.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, x, fbc_nugget,
                          model = spec$model)) &&
      all(is.finite(mapply(function(j) log_prior_row(tab, j, x[j]), seq_len(d))))
  }
  out <- vector("list", nChains)
  out[[1]] <- spec$init
  for (k in seq_len(nChains)[-1]) {
    x <- NULL
    for (try in 1:20) {
      cand <- one()
      if (ok(cand)) { x <- cand; break }
    }
    out[[k]] <- x %||% spec$init
  }
  out
}

# Log prior of parameter j at sampler-scale value x (as the sampler sees it).
log_prior_row <- function(tab, j, x) {
  .log_prior(tab$a[j] + tab$b[j] * x, tab$family[j], tab$p1[j], tab$p2[j]) + tab$lconst[j]
}

# Package-level flag: a chain interrupted with Ctrl-C in this process sets
# it so that the chains of the same call that have not started yet are
# skipped (sequential plan; see run_chains() in run.R).
fbc_run <- new.env(parent = emptyenv())
fbc_run$stop <- FALSE

# Keeps the chains that retained at least one draw, warns about interrupts
# (and workers lost), and aborts when nothing is left.
check_chain_results <- function(results, nMCMC, checkpoint = NULL, call = parent.frame()) {
  started <- !vapply(results, is.null, logical(1))
  kept <- vapply(results, function(r) if (is.null(r)) 0L else as.integer(r$kept), integer(1))
  interrupted <- vapply(results, function(r) !is.null(r) && isTRUE(r$interrupted), logical(1))
  died <- which(vapply(results, function(r) identical(r$status, "died"), logical(1)))
  resume <- if (is.null(checkpoint)) {
    "Continue the run with {.code update(fit, nMCMC = ...)}."
  } else {
    "Resume it with the same {.fn calibrate} call: every chain continues from its checkpoint in {.file {checkpoint}}, with the draws of an uninterrupted run."
  }
  if (any(interrupted) || any(!started)) {
    done <- vapply(results, function(r) if (is.null(r)) 0L else as.integer(r$done), integer(1))
    if (!any(kept > 0L)) {
      cli::cli_abort(c(
        "Interrupted after {max(done)} of {nMCMC} iterations, before any draw was retained.",
        if (!is.null(checkpoint)) c(i = resume)
      ), call = call)
    }
    n <- length(results)
    ids <- which(interrupted)
    its <- done[interrupted]
    msg <- c("Interrupted: {cli::qty(length(ids))}chain{?s} {ids} stopped after {its} of {nMCMC} iterations.")
    if (length(died)) {
      msg <- c(msg, "!" = "{cli::qty(length(died))}The worker{?s} running chain{?s} {died} stopped (killed or crashed): {?its/their} draws are those of {?its/their} last checkpoint.")
    }
    waiting <- which(kept > 0L & vapply(results, function(r) identical(r$status, "waiting"), logical(1)))
    if (length(waiting)) {
      msg <- c(msg, i = "{cli::qty(length(waiting))}Chain{?s} {waiting} {cli::qty(length(waiting))}{?was/were} waiting for {?its/their} turn: {?its/their} draws are those of {?its/their} last completed stretch.")
    }
    if (n > 1L) {
      msg <- c(msg, i = paste0("Keeping {sum(kept > 0L)} of {n} chain{?s} with {sum(kept)} retained draw{?s}",
                               if (any(kept == 0L)) "; chains that kept no draw (not started) are dropped" else "", "."))
    } else {
      msg <- c(msg, i = "Returning the {sum(kept)} draw{?s} retained so far.")
    }
    msg <- c(msg, i = resume)
    cli::cli_warn(msg, call = call)
  }
  results[kept > 0L]
}
