#' Print a calibration
#'
#' Shows a compact header (the discrepancy model by its name, e.g.
#' Kennedy-O'Hagan: see `discrepancy` in [calibrate()]; data sizes; the names of the
#' response, the experimental inputs and the calibration inputs, with the
#' range the simulator design covers for each calibration input; the MCMC
#' settings, the acceptance rates, the correlation families of the
#' simulator and bias GPs (`kernelS`, `kernelB` of [calibrate()]; the
#' bias's only when there is one) and the algebra of
#' the simulator block (Kronecker on a product design, dense, or the
#' nearest-neighbour approximation with its `neighbours`) with why it ran:
#' asked for, or chosen by `algebra = "auto"` from the projected cost of a
#' dense sweep, which it gives, with the ways towards the exact posterior
#' when the approximation ran; see `vignette("sampler", package = "FBC")`)
#' and the posterior
#' summary of every parameter ([summary.fbc()]), followed by the convergence
#' warnings of [convergence_messages()] (R-hat above 1.01, bulk ESS below
#' 400, one chain only, an interrupted run, a chain that never moved, draws
#' piling up at a bound, a posterior pressing against its prior's bound,
#' calibration parameters beyond the simulator design, a prior-data
#' conflict), each
#' with what to do. The prior-data conflict check (about 30 likelihood
#' evaluations) runs once per fit: `print()`, [summary.fbc()] and
#' [convergence_messages()] reuse its result.
#'
#' @param x An `fbc` object from [calibrate()].
#' @param digits Significant digits for the table: a whole number, at least 1.
#' @param ... Not used: an argument given here gives a warning (other code
#'   may pass arguments meant for other methods).
#' @return `x`, invisibly.
#' @export
print.fbc <- function(x, digits = 3, ...) {
  check_dots_empty(..., fn = print.fbc, name = "print", action = "warn")
  x <- check_fbc(x, "x")
  digits <- check_count(digits, "digits")
  s <- x$settings
  mo <- x$model
  sc <- x$model$scale
  gp <- mo$discrepancy != "none"  # a bias GP (every model but "none")
  cat(sprintf("<fbc> Full Bayesian calibration (%s)\n", discrepancy_info(mo$discrepancy, "label")))
  fn <- !is.null(mo$simulator)  # the simulator is a function (R/simulator_function.R)
  cat(sprintf("  data: n = %d field, %s; p = %d, q = %d\n", length(x$model$data$yf),
              if (fn) "the simulator a function" else sprintf("m = %d simulator runs", length(x$model$data$ys)),
              sc$p, sc$q))
  failed <- mo$design$failed
  if (length(failed$rows)) {
    cat(sprintf("  failed runs: %d of %d set aside (not evidence about kappa); where runs fail: predict(fit, newdata, type = \"failure\")\n",
                length(failed$rows), failed$m))
  }
  noiseLine <- sim_noise_line(mo, x$Phi, digits)
  if (!is.null(noiseLine)) cat(sprintf("  replicates: %s\n", noiseLine))
  cat(sprintf("  response: %s; experimental input%s: %s\n", sc$names$response,
              if (sc$p > 1L) "s" else "", paste(sc$names$inputs, collapse = ", ")))
  print_design(mo, sc, fn)
  chains <- length(unique(x$chain))
  cat(sprintf("  MCMC: %d iterations, %s, thinning %d -> %d draws%s (%.1f s)\n",
              s$nMCMC, warmup_text(s), s$thinning, nrow(x$Phi),
              if (chains > 1L) sprintf(" from %d chains", chains) else "", s$time))
  rw <- s$reweight
  if (isTRUE(rw$used)) {
    cat(sprintf("  draws: the fit on %d runs, reweighted by the new runs and resampled (%d draws weighed, Kish share %.2f; bulk ESS %.0f)%s\n",
                rw$runs, rw$draws, rw$kish, rw$ess,
                if (isTRUE(rw$topUp > 0)) sprintf(", then continued %d sweeps a chain", rw$topUp) else ""))
  } else if (!is.null(rw)) {
    why <- if (length(rw$stale)) {
      sprintf("their continuation's proposals were stale (%s accepting under a quarter of the target)",
              paste(rw$stale, collapse = ", "))
    } else if (isTRUE(rw$topUp > 0)) {
      sprintf("their continuation fell short of the rule in %d sweeps a chain", rw$topUp)
    } else {
      sprintf("they held %.0f of the rule's effective draws", rw$ess)
    }
    cat(sprintf("  draws: refitted; the fit on %d runs reweighted was tried, but %s\n", rw$runs, why))
  }
  print_moves(x)
  if (fn) {
    if (gp) cat(sprintf("  kernel: bias %s\n", mo$kernelB))
    cat(sprintf("  simulator: %s\n", mo$algebra$reason))
  } else {
    print_algebra(x, gp)
  }
  if (isTRUE(x$state$interrupted)) {
    done <- vapply(x$state$chains, `[[`, numeric(1), "done")
    stopped <- vapply(x$state$chains, `[[`, logical(1), "interrupted")
    cat(sprintf("  interrupted: chain %s after %s iterations\n",
                paste(which(stopped), collapse = ", "), paste(done[stopped], collapse = ", ")))
  }
  cat("\n")
  lat <- latent_summary(summary(x), digits)
  print(lat$table, digits = digits)
  if (!is.null(lat$line)) cat(lat$line, "\n", sep = "")
  cat(scale_note_line(sc), "\n", sep = "")
  msgs <- convergence_messages(x)
  if (length(msgs)) {
    cat("\nWarning", if (length(msgs) > 1L) "s", ":\n", sep = "")
    cat(paste0("! ", strwrap(msgs, width = getOption("width") - 2L, exdent = 2L,
                             simplify = FALSE) |>
                 vapply(paste, character(1), collapse = "\n")), sep = "\n")
  }
  invisible(x)
}

# The design's lines of print.fbc(): categorical inputs, outputs, data
# sets, measurement-error groups and the calibration inputs (`fn`: the
# simulator is a function, whose kappa ranges are its prior's).
print_design <- function(mo, sc, fn) {
  fac <- level_factors(mo)
  lev <- level_labels(fac)
  pos <- level_positions(fac)
  for (i in seq_along(fac)) {
    f <- fac[[i]]
    k <- pos[[i]]
    cat(sprintf("  categorical input %s: levels %s; level correlation %s\n", f$name,
                paste(f$levels, collapse = ", "),
                if (mo$dims$outputs > 1L) "rhoS (one per output)" else rho_list("rhoS", k, lev)))
  }
  if (!is.null(sc$output)) cat(sprintf("  outputs (%s): %s, each standardised on its own\n    %s\n",
                                       sc$output$name, paste(sc$output$levels, collapse = ", "),
                                       outputs_line(mo)))
  if (!is.null(sc$source)) {
    own <- if (isTRUE(sc$sourceBias)) {
      lab <- level_labels(list(sc$source))
      sprintf("; a bias each, correlated by %s", rho_list("rhoD", seq_along(lab), lab))
    } else ""
    cat(sprintf("  field data sets (%s): %s%s\n", sc$source$name,
                paste(sc$source$levels, collapse = ", "), own))
  }
  des <- kappa_design(sc)
  cat(sprintf("  calibration input%s: %s\n", if (sc$q > 1L) "s" else "",
              paste0("kappa", seq_len(sc$q), " = ", des$names, if (fn) " (prior " else " (design ",
                     des$range, ")", collapse = ", ")))
}

# The note under print.fbc()'s table: the hyperparameters are on the
# standardised scale (each output's response divided by its sd), so a
# variance (sigma2E, sigma2S, sigma2B) times sd^2 is in the response's units.
scale_note_line <- function(sc) {
  sds <- sc$ysd
  what <- if (!is.null(sc$output) && length(sds) > 1L) {
    paste0(sc$output$levels, " ", vapply(sds, fmt_num, ""), collapse = ", ")
  } else {
    sprintf("%s %s", sc$names$response, fmt_num(sds[1]))
  }
  sprintf("hyperparameters on the standardised scale (response / its sd: %s): a variance such as sigma2E times sd^2 is in the response's units",
          what)
}

# The run's lines of print.fbc(): the stopping rule and each move's
# acceptance.
print_moves <- function(x) {
  s <- x$settings
  mo <- x$model
  cv <- s$converge
  if (!is.null(cv)) {
    cat(sprintf("  stopping rule: every R-hat < %g and bulk ESS >= %d, checked %s: %s\n",
                cv$rhat, cv$ess, check_schedule(cv),
                if (isTRUE(cv$reweighted)) {
                  paste0(if (isTRUE(cv$converged)) "met" else "not met", " by the reweighted draws",
                         if (isTRUE(s$reweight$topUp > 0)) " and their continuation")
                }
                else if (isTRUE(cv$converged)) sprintf("met at %d sweeps per chain (check %d)", cv$sweeps, cv$checks)
                else sprintf("not met by %d sweeps per chain (%d checks)", cv$sweeps, cv$checks)))
  }
  mv <- move_report(x)
  if (!is.null(mv) && nrow(mv)) {
    # each move by name with its acceptance (targets: 0.44 for one
    # parameter, 0.234 for a joint move; an exact draw always accepts)
    what <- ifelse(mv$kind == "gibbs", "exact", sprintf("%.2f", mv$acceptance))
    cat(paste(strwrap(paste0(mv$move, " ", what, collapse = ", "), width = getOption("width") - 4L,
                      initial = "  acceptance: ", prefix = "    "), collapse = "\n"), "\n", sep = "")
  } else {
    acc <- x$acceptance[!is.na(x$acceptance)]
    if (length(acc)) {
      cat(sprintf("  acceptance: %.2f to %.2f (target 0.44%s)\n", min(acc), max(acc),
                  if (length(mo$moves$blocks)) "; joint moves 0.234" else ""))
    }
  }
}

# The kernels' and the algebra's lines of print.fbc() (a fit of runs).
print_algebra <- function(x, gp) {
  mo <- x$model
  cat(sprintf("  kernels: simulator %s%s\n", mo$kernelS, if (gp) paste(", bias", mo$kernelB) else ""))
  alg <- mo$algebra
  # why it ran (choose_algebra()'s reason; a fit made before it has none)
  reason <- alg$reason
  why <- if (!is.null(reason)) paste0(": ", reason) else if (alg$name == "vecchia" && identical(mo$options$algebra, "auto")) {
    sprintf(" (chosen for more than %d scattered runs; `algebra = \"dense\"` is exact)", fbc_vecchia_m)
  } else ""
  cat(sprintf("  algebra: %s%s\n", switch(alg$name,
    kronecker = kronecker_label(alg, mo$scale$names$inputs, mo$scale$names$calibration),
    vecchia = sprintf("Vecchia nearest-neighbour approximation, k = %d", alg$neighbours),
    "dense"), why))
}

# "Kronecker, 6 x 5 (experimental x calibration settings)", or for another
# split of the inputs "Kronecker: height (16) x R, C (25)".
kronecker_label <- function(alg, inputs, calibration) {
  a <- alg$split
  if (is.null(a) || identical(as.integer(a), seq_along(inputs))) {
    return(sprintf("Kronecker, %d x %d (experimental x calibration settings)", alg$dims[1], alg$dims[2]))
  }
  nm <- c(inputs, calibration)
  sprintf("Kronecker: %s (%d) x %s (%d)", paste(nm[a], collapse = ", "), alg$dims[1],
          paste(nm[-a], collapse = ", "), alg$dims[2])
}

# "rhoS1 (b~a), rhoS2 (c~a)": the parameters cls k with what each
# correlates, from level_labels() without the input's name.
rho_list <- function(cls, k, labels) {
  paste0(cls, k, " (", sub("^[^:]*: ", "", labels[k]), ")", collapse = ", ")
}
