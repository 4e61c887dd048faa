# How several outputs are modelled (calibrate(outputs =)).
#
# "independent": each output has its own simulator GP and its
# own bias GP (its own thetaS, alphaS, sigma2S, thetaB, alphaB, sigma2B, muB,
# ...: the model table's perOutput classes, one copy per output, output
# after output in phi), the GPs of different outputs independent; only
# kappa is shared (and each output x data set has its sigma2E, as before).
# The covariance of (yf, ys) is then block diagonal over the outputs, so
# the log-likelihood is the sum of each output's KOH log-likelihood at the
# common kappa, and each block keeps its own algebra (Kronecker on a product
# design, dense otherwise): src/outputs.cpp.
#
# "shared" (the default): one simulator GP over the inputs and the output, the outputs
# correlated by the output's level correlation (rhoS), one bias GP likewise
# (rhoB); one set of length-scales, smoothness and variance for every
# output (R/factors.R).
#
# Why shared stays the default: measured (bench/RESULTS-outputs.md),
# independent outputs pooled as well as shared on two-output known-truth
# problems at about 1.4 times the CPU, and gave wider intervals than shared
# on the 3-output benchmark; the case feared (pooling wider than the
# better output) was not reproduced under either.

# The `outputs` choice, checked: NULL without an `output` column; with
# "independent" every output needs field rows (an output without them is
# independent of kappa and would inform nothing).
check_outputs <- function(outputs, dd, algebra, call = parent.frame()) {
  outputs <- match_choice(outputs, c("shared", "independent"), "outputs", call = call)
  out <- dd$fac$output
  if (is.null(out)) return(NULL)
  if (outputs == "independent") {
    lacking <- out$levels[!seq_along(out$levels) %in% dd$fac$outF]
    if (length(lacking)) {
      cli::cli_abort(c(
        "With {.code outputs = \"independent\"} every output needs field data, but {cli::qty(length(lacking))}output{?s} {.val {lacking}} {?has/have} none.",
        i = "An output modelled on its own and never observed says nothing about {.field kappa}: drop its runs from {.arg sim}, or use {.code outputs = \"shared\"} to let it inform the others through the shared simulator GP."
      ), call = call)
    }
    if (algebra == "vecchia") {
      cli::cli_abort(c(
        "{.code outputs = \"independent\"} has no nearest-neighbour algebra yet ({.code algebra = \"vecchia\"}).",
        i = "Use {.code algebra = \"auto\"} or {.code \"dense\"} (each output's block is factored on its own), or {.code outputs = \"shared\"}."
      ), call = call)
    }
  }
  outputs
}

# The categorical inputs as the compiled core takes them (model_levels()):
# with independent outputs the output's indicator columns go apart
# (`outputs`, list(col, ncol, L)) and `levels` holds the others.
output_levels <- function(fac, names, outputs) {
  if (!identical(outputs, "independent")) {
    return(list(levels = model_levels(fac$factors, names), outputs = NULL))
  }
  isOut <- names(fac$factors) == fac$output$name
  list(levels = model_levels(fac$factors[!isOut], names),
       outputs = model_levels(fac$factors[isOut], names))
}

# The rows of each output (a list over the outputs of row numbers) of the
# simulator data (`which = "sim"`) or the field data, of a model.
output_rows <- function(model, which = c("sim", "field")) {
  codes <- if (match.arg(which) == "sim") model$data$outS else model$data$outF
  split(seq_along(codes), factor(codes, levels = seq_along(model$scale$output$levels)))
}

# The simulator runs of the output with the most of them (the block the
# algebra is chosen for under independent outputs), or all of them.
largest_output_sim <- function(dat, outputs) {
  if (!identical(outputs, "independent")) return(dat$Xs)
  big <- which.max(tabulate(dat$outS))
  dat$Xs[dat$outS == big, , drop = FALSE]
}

# How the outputs are modelled, in a line (print() of a model and a fit).
outputs_line <- function(model) {
  out <- model$scale$output
  lev <- paste(out$levels, collapse = ", ")
  if (!is.null(model$simulator)) {
    return(sprintf("%d (%s) of the simulator function (it sees the output column), kappa shared, a noise variance each, no discrepancy",
                   length(out$levels), lev))
  }
  if (identical(model$options$outputs, "independent")) {
    # the classes each output's GPs have (no smoothness under a Matern or Gaussian kernel)
    gp <- function(k, kernel) paste0("theta", k, if (kernel_has_alpha(kernel)) paste0(", alpha", k), ", sigma2", k)
    sprintf("%d (%s), independent: each its own simulator GP (%s)%s; only kappa shared",
            length(out$levels), lev, gp("S", model$kernelS),
            if (model$discrepancy == "none") "" else sprintf(" and bias GP (%s)", gp("B", model$kernelB)))
  } else {
    sprintf("%d (%s), shared: one simulator GP over the inputs and the output (one set of length-scales), outputs correlated by rhoS%s",
            length(out$levels), lev, if (model$discrepancy == "none") "" else " (bias: rhoB)")
  }
}

# The categorical inputs that have level correlations (rhoS, rhoB): all but
# the output with independent outputs (each output its own GPs); none for a
# simulator function (no GP over its output).
level_factors <- function(model) {
  if (!is.null(model$simulator)) return(list())
  fac <- model$scale$factors
  if (!identical(model$options$outputs, "independent")) return(fac)
  fac[names(fac) != model$scale$output$name]
}

# The data frame X with each row repeated at every output in turn (`out`:
# the output's name and levels), its output column a factor: a run's rows
# (design_loop()) or a target's points at every output (propose_runs()).
at_every_output <- function(X, out) {
  K <- length(out$levels)
  X <- X[rep(seq_len(nrow(X)), each = K), , drop = FALSE]
  X[[out$name]] <- factor(rep(out$levels, length.out = nrow(X)), levels = out$levels)
  rownames(X) <- NULL
  X
}
