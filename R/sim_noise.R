#' Stochastic simulators: replicate runs and the simulator's own noise
#'
#' A stochastic simulator (an agent-based, epidemic, queueing or Monte Carlo
#' code) returns another value each time it runs at the same inputs, and its
#' users run replicates. [calibrate()] finds the replicate rows of `sim`
#' (identical inputs) and, with `simNoise = "auto"` (the default), models the
#' simulator's own noise when their responses differ beyond rounding (by
#' more than `sqrt(.Machine$double.eps)` times the response's sd); without
#' such replicates the model is the deterministic one, to the bit.
#'
#' @section Model:
#' With `simNoise = "constant"` the runs are
#' \deqn{y_s(x, t)_r = \eta(x, t) + e_r, \quad e_r \sim N(0, r),}
#' with \eqn{r} the simulator's own variance (`sigma2R`, on the scale of the
#' standardised response, its prior set by [set_hyperPriors()]: a
#' half-Cauchy on its sd, weakly informative on that scale), sampled jointly
#' with \eqn{\kappa} and every other unknown. The replicates enter through
#' their exact sufficient statistics: the emulator sees the \eqn{m} unique
#' inputs with their mean responses, whose noise variance \eqn{r / n_i} is
#' added to the simulator block, and the spread about those means adds
#' \deqn{-\tfrac12 \sum_i (n_i - 1) \log(2 \pi r) - \tfrac12 \mathrm{SSW} / r}
#' to the log-likelihood (SSW: the within sum of squares), with the constant
#' \eqn{-\tfrac12 \sum_i \log n_i}: the likelihood is that of every run,
#' at the cost of the unique inputs.
#'
#' The field is reality's mean behaviour: \eqn{y_f = \eta(x, \kappa) +
#' \delta(x) + \epsilon}, its noise measurement error only. A physical system
#' is one system, not a draw of the simulator's randomness, and its
#' departures from the simulator's mean are what \eqn{\delta} and
#' \eqn{\epsilon} describe; the simulator's noise says how well each run
#' measures \eqn{\eta}.
#'
#' `simNoise = "none"` treats the simulator as deterministic (the emulator
#' interpolates the runs, up to a tiny nugget; a message says when
#' replicates differ). `"input"` (an input-dependent \eqn{\log r \sim GP})
#' is not available yet. The simulator's noise runs on the exact dense
#' algebra: with several outputs or the nearest-neighbour algebra
#' `calibrate()` refuses it, and on a product design of the unique inputs
#' the dense algebra runs in place of the Kronecker one. `print()` says what
#' was found and modelled; `predict(fit, newdata, type = "simulator")`
#' predicts \eqn{\eta}, the simulator's mean.
#'
#' @name simulator_noise
#' @seealso [calibrate()], [set_hyperPriors()]
#' @examples
#' # a stochastic simulator: 15 inputs, 4 replicates each
#' set.seed(1)
#' x <- rep(seq(0, 3, length.out = 5), 3)
#' t <- rep(c(1, 1.8, 2.6), each = 5)
#' X <- cbind(x = rep(x, 4), t = rep(t, 4))
#' sim <- cbind(y = 5 * exp(-X[, "t"] * X[, "x"]) + rnorm(nrow(X), 0, 0.2), X)
#' field <- cbind(y = 5 * exp(-1.7 * x[1:5]) + rnorm(5, 0, 0.05), x = x[1:5])
#' model <- calibrate(sim, field, fit = FALSE)
#' model$classes[model$classes$class == "sigma2R", ]
NULL

# The choices of calibrate(simNoise =).
sim_noise_choices <- c("auto", "none", "constant", "input")

# simNoise, checked: one of the choices; "input" is refused (not built).
check_sim_noise <- function(simNoise, call = parent.frame()) {
  simNoise <- match_choice(simNoise, sim_noise_choices, "simNoise", call = call)
  if (simNoise == "input") {
    cli::cli_abort(c(
      "{.code simNoise = \"input\"} (an input-dependent simulator noise) is not available yet.",
      i = "Use {.code simNoise = \"constant\"} (one noise variance for every input) or {.code \"none\"} (a deterministic simulator)."
    ), call = call)
  }
  simNoise
}

# With a simulator given as a function there are no runs: only "auto" and
# "none" mean anything.
check_sim_noise_function <- function(simNoise, call = parent.frame()) {
  simNoise <- check_sim_noise(simNoise, call = call)
  if (simNoise == "constant") {
    cli::cli_abort(c(
      "{.code simNoise = \"constant\"} models the noise of simulator runs, but {.arg sim} is a function.",
      i = "A simulator function is called as it is: leave {.arg simNoise} at {.val auto}."
    ), call = call)
  }
  simNoise
}

# The replicate runs of `sim` (a numeric matrix: response, then inputs): each
# row's unique input (`group`, in order of first appearance), each unique
# input's first row and run count, and whether its responses differ beyond
# rounding (range above sqrt(eps) times the response's sd).
sim_replicates <- function(sim) {
  X <- sim[, -1, drop = FALSE]
  y <- sim[, 1]
  key <- row_keys(X)
  group <- match(key, unique(key))
  count <- tabulate(group)
  rng <- vapply(split(y, group), function(v) diff(range(v)), numeric(1), USE.NAMES = FALSE)
  list(group = group, first = match(seq_along(count), group), count = count,
       differ = count > 1L & rng > replicate_tolerance(y))
}

# Replicates whose responses differ by at most this differ by rounding:
# sqrt(eps) times the responses' sd (their largest size when they are
# constant).
replicate_tolerance <- function(y) {
  spread <- stats::sd(y)
  if (!is.finite(spread) || spread == 0) spread <- max(abs(y), 1)
  sqrt(.Machine$double.eps) * spread
}

# The simulator noise the model has: "none" or "constant" (simNoise "auto":
# "constant" when replicates differ beyond rounding), with the replicates
# found (`reps`) and what print() says of them (`info`, NULL without
# replicates and noise).
sim_noise_model <- function(simNoise, sim, call = parent.frame()) {
  simNoise <- check_sim_noise(simNoise, call = call)
  reps <- sim_replicates(sim)
  mode <- if (simNoise == "auto") if (any(reps$differ)) "constant" else "none" else simNoise
  info <- if (mode != "none" || any(reps$count > 1L)) {
    list(mode = mode, asked = simNoise, runs = length(reps$group), unique = length(reps$count),
         replicated = sum(reps$count > 1L), differ = sum(reps$differ))
  }
  list(mode = mode, reps = reps, info = info)
}

# The scaled data on the unique inputs: Xs their rows, ys their mean
# responses, and the sufficient statistics the compiled model takes (count
# per unique input, the within sum of squares).
collapse_replicates <- function(dat, reps) {
  g <- reps$group
  mean <- as.vector(rowsum(dat$ys, g, reorder = FALSE)) / reps$count
  ssw <- sum((dat$ys - mean[g])^2)
  dat$Xs <- dat$Xs[reps$first, , drop = FALSE]
  dat$ys <- mean
  list(dat = dat, replicates = list(count = reps$count, ssw = ssw),
       pooled = if (sum(reps$count - 1L) > 0) ssw / sum(reps$count - 1L))
}

# The simulator's noise runs on the dense algebra: several outputs and the
# nearest-neighbour algebra are refused (naming simNoise and the algebra);
# on a product design the dense algebra replaces the Kronecker one.
sim_noise_algebra <- function(alg, noise, outputs, call = parent.frame()) {
  if (noise$mode == "none") return(alg)
  asked <- noise$info$asked
  why <- if (asked == "auto") {
    sprintf("The replicate runs differ at %d input%s, so {.code simNoise = \"auto\"} models the simulator's own noise", noise$info$differ, if (noise$info$differ == 1L) "" else "s")
  } else "{.code simNoise = \"constant\"} models the simulator's own noise"
  if (!is.null(outputs)) {
    cli::cli_abort(c(
      paste0(why, ", which is not available with several outputs."),
      i = "Use {.code simNoise = \"none\"} to treat the simulator as deterministic."
    ), call = call)
  }
  if (alg$name == "vecchia") {
    cli::cli_abort(c(
      paste0(why, ", which the nearest-neighbour algebra ({.code algebra = \"vecchia\"}) does not have."),
      i = "Use {.code algebra = \"dense\"} (exact) to model it, or {.code simNoise = \"none\"} to treat the simulator as deterministic."
    ), call = call)
  }
  if (alg$name == "kronecker") {
    alg <- list(name = "dense", code = algebra_codes[["dense"]], neighbours = NULL,
                reason = "exact; the unique runs are a product design, but the simulator's noise needs the dense algebra",
                forced = FALSE, dims = NULL)
  }
  alg
}

# sigma2R's prior (from an fbc_hypers made before the class existed: the
# default), started at the pooled within-replicate variance unless an
# initial value was given (without replicates at 0.01, a tenth of the
# standardised response's sd). Replicates that all agree leave nothing to
# estimate r from but the emulator's fit, and the within term grows without
# bound as r goes to 0: refused.
sim_noise_prior <- function(h, cr, call = parent.frame()) {
  h <- h %||% set_hyperPriors()$sigma2R
  if (identical(cr$pooled, 0) && h$dist != "fixed") {
    cli::cli_abort(c(
      "{.code simNoise = \"constant\"} models the simulator's own noise, but its replicate runs all agree.",
      i = "Their spread is the evidence about the noise: with none, its posterior piles up at 0. Use {.code simNoise = \"none\"} (or {.val auto}) for a deterministic simulator."
    ), call = call)
  }
  if (is.na(h$init)) h$init <- cr$pooled %||% 0.01
  h
}

# print()'s line on the replicates and the noise modelled (NULL without
# either): "12 of 25 unique inputs with replicates (250 runs); simulator
# noise: constant, sd 0.201 (posterior median, response units)".
sim_noise_line <- function(model, Phi = NULL, digits = 3) {
  info <- model$design$simNoise
  if (is.null(info)) return(NULL)
  found <- if (info$replicated) {
    sprintf("%d of %d unique inputs with replicates (%d runs)", info$replicated, info$unique,
            info$runs)
  } else sprintf("no replicates (%d runs)", info$runs)
  noise <- if (info$mode == "constant") {
    sd <- if (!is.null(Phi) && "sigma2R" %in% colnames(Phi)) {
      sprintf(", sd %s (posterior median, response units)",
              format(signif(sqrt(stats::median(Phi[, "sigma2R"])) * model$scale$ysd[1], digits)))
    } else ""
    paste0("constant", sd)
  } else if (info$differ) {
    sprintf("none (their responses differ at %d input%s; the emulator interpolates them)",
            info$differ, if (info$differ == 1L) "" else "s")
  } else "none (the replicates agree)"
  sprintf("%s; simulator noise: %s", found, noise)
}

# What has no model of the simulator's own noise yet refuses a fit that has
# it (`fn`: the function's name): the design of new runs scores a run as if
# it were noiseless.
check_no_sim_noise <- function(model, fn, call = parent.frame()) {
  if (is.null(model$spec$model$replicates)) return(invisible(TRUE))
  cli::cli_abort(c(
    "{.fn {fn}} does not model the simulator's own noise yet, which this fit samples ({.code simNoise = \"constant\"}).",
    i = "It would score new runs as if they were noiseless. Choose runs from a fit with {.code simNoise = \"none\"}, or by a design of your own."
  ), call = call)
}
