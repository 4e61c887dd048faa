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
#' By default (`calibrate(fieldLink = "mean")`) the field is reality's mean
#' behaviour: \eqn{y_f = \eta(x, \kappa) + \delta(x) + \epsilon}, its noise
#' measurement error only. A physical system is one system, not a draw of
#' the simulator's randomness, and its departures from the simulator's mean
#' are what \eqn{\delta} and \eqn{\epsilon} describe; the simulator's noise
#' says how well each run measures \eqn{\eta}. With `fieldLink =
#' "realization"` the field is one realization of the same stochastic
#' process (an epidemic that happened once, one queue's day): its noise
#' variance is \eqn{\sigma^2_E + r}, the simulator's own variance added to
#' the measurement error's (a constant noise only; with `simNoise =
#' "input"` it would need the latent log-variance at every \eqn{\kappa},
#' and is refused). [loo()][loo.fbc] compares the two links on the same
#' field data.
#'
#' With `simNoise = "input"` the noise variance depends on the inputs,
#' \eqn{r(x, t) = \exp(g(x, t))}, and the log-variance is a GP,
#' \deqn{g \sim GP(\mu_g, \sigma^2_g R_g),}
#' \eqn{R_g} the Matérn 5/2 correlation (as in [correlation], with
#' \eqn{h_k = \sqrt{\theta_{g,k}} d_k}) over the inputs scaled to
#' \eqn{[0, 1]} (experimental and calibration), with its own ranges
#' (`thetaG`): a noise level is a property of the simulator's randomness,
#' not of its mean, so it need not vary on the emulator's length-scales; the
#' Matérn 5/2 makes it smooth (twice differentiable) without the Gaussian
#' kernel's near-singular correlations, under which the latent values'
#' roughness (each input's replicates measure its own) drove
#' \eqn{\sigma^2_g} to absurd values. Its values `gR` at the \eqn{m}
#' unique inputs are sampled with every other unknown, by elliptical slice
#' sampling on the whitened GP (an exact move of all of them at once, with
#' no scale to tune), and \eqn{\mu_g}, \eqn{\sigma^2_g}, \eqn{\theta_g}
#' (`muG`, `sigma2G`, `thetaG`, priors in [set_hyperPriors()]) by
#' Metropolis walks. Input \eqn{i}'s mean has noise variance
#' \eqn{e^{g_i} / n_i} and the within term is
#' \eqn{-\tfrac12 \sum_i (n_i - 1)(\log 2\pi + g_i) - \tfrac12 \sum_i
#' \mathrm{SSW}_i e^{-g_i}}; the GP's log density is part of the fit's
#' log-likelihood. `predict(fit, newdata, type = "simulator")` gives the
#' noise sd at new inputs from the GP given \eqn{g} at each draw,
#' integrated over its conditional (log-normal) law: `noiseSd` is the root
#' of the posterior mean of the noise variance.
#'
#' With replicates that differ, `simNoise = "auto"` models a constant
#' noise. On a simulator whose noise sd varies fourfold over its inputs
#' (`bench/sim-noise.R`, 50 unique inputs x 20 replicates, the defaults
#' otherwise), \eqn{\kappa}'s posterior was the same under `"constant"` and
#' `"input"` (the field is the system's mean behaviour, so the noise model
#' reaches \eqn{\kappa} only through the emulator's mean, which the
#' replicates pin down either way), while `"input"` took about 110 times the
#' CPU to converge (its latent values and their GP's hyperparameters mix
#' slowly). Choose `"input"` when the noise itself matters: its sd at each
#' input (within 7% there, a constant one off by 40%), predictions of a
#' single run.
#'
#' `simNoise = "none"` treats the simulator as deterministic (the emulator
#' interpolates the runs, up to a tiny nugget; a message says when
#' replicates differ). The algebra is chosen by the unique inputs, as for a
#' deterministic simulator: the exact dense algebra, or the
#' nearest-neighbour one on many scattered inputs, whose conditionals carry
#' each mean's noise variance as they carry the nugget (so 1,000 unique
#' inputs with 100 replicates each cost about what 1,000 runs do). On a
#' product design of the unique inputs the dense algebra runs in place of
#' the Kronecker one; with several outputs `calibrate()` refuses the noise,
#' and `"input"` on more than 2,000 unique inputs (its latent GP over them
#' is dense). `print()` says what
#' was found and modelled; `predict(fit, newdata, type = "simulator")`
#' predicts \eqn{\eta}, the simulator's mean, and the noise sd.
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
# What simNoise = "auto" models when replicates differ (see ?simulator_noise).
sim_noise_auto <- "constant"

# The classes of the simulator's noise: constant (sigma2R) or
# input-dependent (the latent log-variances gR and their GP's muG, sigma2G,
# thetaG); a model without that noise has none of them.
sim_noise_classes <- c("sigma2R", "gR", "muG", "sigma2G", "thetaG")

# The sizes of the noise classes (class_sizes()'s `replicates`) from the
# replicates' sufficient statistics (collapse_replicates(), or a compiled
# model's): 0 without noise, 1 for a constant one, c(0, m) for an
# input-dependent one over m unique inputs.
noise_sizes <- function(replicates) {
  if (is.null(replicates)) 0L
  else if (isTRUE(replicates$latent)) c(0L, length(replicates$count))
  else 1L
}

# simNoise, checked: one of the choices.
check_sim_noise <- function(simNoise, call = parent.frame()) {
  match_choice(simNoise, sim_noise_choices, "simNoise", call = call)
}

# With a simulator given as a function there are no runs: only "auto" and
# "none" mean anything.
check_sim_noise_function <- function(simNoise, call = parent.frame()) {
  simNoise <- check_sim_noise(simNoise, call = call)
  if (simNoise %in% c("constant", "input")) {
    cli::cli_abort(c(
      "{.code simNoise = \"{simNoise}\"} models the noise of simulator runs, but {.arg sim} is a function.",
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

# The simulator noise the model has: "none", "constant" or "input"
# (simNoise "auto": sim_noise_auto when replicates differ beyond
# rounding), with the replicates
# found (`reps`) and what print() says of them (`info`, NULL without
# replicates and noise).
sim_noise_model <- function(simNoise, sim, fieldLink = "mean", call = parent.frame()) {
  simNoise <- check_sim_noise(simNoise, call = call)
  link <- match_choice(fieldLink, field_link_choices, "fieldLink", call = call)
  reps <- sim_replicates(sim)
  mode <- if (simNoise == "auto") if (any(reps$differ)) sim_noise_auto else "none" else simNoise
  check_field_link(link, mode, call = call)
  info <- if (mode != "none" || any(reps$count > 1L)) {
    list(mode = mode, asked = simNoise, runs = length(reps$group), unique = length(reps$count),
         replicated = sum(reps$count > 1L), differ = sum(reps$differ), link = link)
  }
  list(mode = mode, reps = reps, info = info, link = link)
}

# The choices of calibrate(fieldLink =): the field is the system's mean
# behaviour, or one realization of the stochastic simulator.
field_link_choices <- c("mean", "realization")

# A field that is one realization carries the simulator's noise at
# (x, kappa): a constant noise adds sigma2R to the field's variance; an
# input-dependent one would need the latent GP at the field's inputs and
# kappa, which the sampler does not carry: refused, as is a realization of
# a simulator without noise.
check_field_link <- function(link, mode, call = parent.frame()) {
  if (link == "mean" || mode == "constant") return(invisible(link))
  cli::cli_abort(c(
    if (mode == "input") "{.code fieldLink = \"realization\"} is available with a constant simulator noise only, not with {.code simNoise = \"input\"}."
    else "{.code fieldLink = \"realization\"} needs the simulator's own noise, which this model does not have ({.code simNoise} gives {.val none}).",
    i = if (mode == "input") "The field's variance would need the latent log-variance at every kappa. Use {.code simNoise = \"constant\"}, or {.code fieldLink = \"mean\"}."
        else "Give replicate runs that differ, with {.code simNoise = \"auto\"} or {.val constant}, or leave {.arg fieldLink} at {.val mean}."
  ), call = call)
}

# With a simulator function there is no noise model: only "mean".
check_field_link_function <- function(fieldLink, call = parent.frame()) {
  link <- match_choice(fieldLink, field_link_choices, "fieldLink", call = call)
  if (link != "mean") {
    cli::cli_abort(c(
      "{.code fieldLink = \"realization\"} needs the noise of simulator runs, but {.arg sim} is a function.",
      i = "Leave {.arg fieldLink} at {.val mean}."
    ), call = call)
  }
  link
}

# The scaled data on the unique inputs: Xs their rows, ys their mean
# responses, and the sufficient statistics the compiled model takes (count
# per unique input, the within sum of squares: one, or with an
# input-dependent noise (`latent`) one per unique input).
collapse_replicates <- function(dat, reps, latent = FALSE) {
  g <- reps$group
  mean <- as.vector(rowsum(dat$ys, g, reorder = FALSE)) / reps$count
  sswi <- as.vector(rowsum((dat$ys - mean[g])^2, g, reorder = FALSE))
  ssw <- sum((dat$ys - mean[g])^2)
  dat$Xs <- dat$Xs[reps$first, , drop = FALSE]
  dat$ys <- mean
  list(dat = dat,
       replicates = if (latent) list(count = reps$count, ssw = sswi, latent = TRUE)
                    else list(count = reps$count, ssw = ssw),
       pooled = if (sum(reps$count - 1L) > 0) ssw / sum(reps$count - 1L),
       sswi = sswi, count = reps$count)
}

# The simulator's noise runs on the dense and nearest-neighbour algebras
# (the runs' means carry their noise variance r_i / n_i on the diagonal of
# their covariance, which the Vecchia conditionals hold as they hold the
# nugget); several outputs are refused, and so is an input-dependent noise
# on more than fbc_latent_max unique inputs (its latent GP over them is
# dense: O(m^3) per move of its hyperparameters), naming simNoise. (The
# classes of the noise say which algebras compute with them, src/model.cpp:
# on a product design the rule's dense or nearest-neighbour algebra replaces
# the Kronecker one, choose_algebra().)
fbc_latent_max <- 2000L
refuse_sim_noise_options <- function(noise, outputs, m, call = parent.frame()) {
  if (noise$mode == "none") return(invisible(noise))
  asked <- noise$info$asked
  why <- if (asked == "auto") {
    sprintf("The replicate runs differ at %d input%s, so {.code simNoise = \"auto\"} models the simulator's own noise", noise$info$differ, if (noise$info$differ == 1L) "" else "s")
  } else "{.code simNoise = \"{asked}\"} models the simulator's own noise"
  if (!is.null(outputs)) {
    cli::cli_abort(c(
      paste0(why, ", which is not available with several outputs."),
      i = "Use {.code simNoise = \"none\"} to treat the simulator as deterministic."
    ), call = call)
  }
  if (noise$mode == "input" && m > fbc_latent_max) {
    cli::cli_abort(c(
      paste0(why, ", whose latent log-variances over the {m} unique inputs have a dense GP prior (at most {fbc_latent_max} unique inputs)."),
      i = "Use {.code simNoise = \"constant\"} (one noise variance) or {.code simNoise = \"none\"} (deterministic)."
    ), call = call)
  }
  invisible(noise)
}

# sigma2R's prior (from an fbc_hypers made before the class existed: the
# default), started at the pooled within-replicate variance unless an
# initial value was given (without replicates at 0.01, a tenth of the
# standardised response's sd). Replicates that all agree leave nothing to
# estimate r from but the emulator's fit, and the within term grows without
# bound as r goes to 0: refused.
sim_noise_prior <- function(h, cr, mode = "constant", call = parent.frame()) {
  h <- h %||% set_hyperPriors()$sigma2R
  if (identical(cr$pooled, 0) && h$dist != "fixed") {
    cli::cli_abort(c(
      "{.code simNoise = \"{mode}\"} models the simulator's own noise, but its replicate runs all agree.",
      i = "Their spread is the evidence about the noise: with none, its posterior piles up at 0. Use {.code simNoise = \"none\"} (or {.val auto}) for a deterministic simulator."
    ), call = call)
  }
  if (is.na(h$init)) h$init <- cr$pooled %||% 0.01
  h
}

# The priors of the simulator's noise classes in `hypers` (an fbc_hypers)
# for noise `mode`: sigma2R's (sim_noise_prior()) for a constant noise; for
# an input-dependent one the latent GP's (muG, sigma2G, thetaG: those of
# set_hyperPriors(), the defaults for an fbc_hypers made before the classes
# existed) and gR's own, flat on [-50, 50] (the GP is its prior: the
# compiled core adds its density), gR started at each unique input's
# log within-replicate variance (the pooled one where it has no spread)
# and muG at their mean.
sim_noise_priors <- function(hypers, cr, mode, call = parent.frame()) {
  pr <- sim_noise_prior(hypers$sigma2R, cr, mode, call = call)
  if (mode == "constant") {
    hypers$sigma2R <- pr
    return(hypers)
  }
  df <- cr$count - 1L
  v <- ifelse(df > 0 & cr$sswi > 0, cr$sswi / pmax(df, 1L), pr$init)
  g0 <- log(v)
  dflt <- set_hyperPriors()
  for (cls in c("muG", "sigma2G", "thetaG")) hypers[[cls]] <- hypers[[cls]] %||% dflt[[cls]]
  if (all(is.na(hypers$muG$init))) hypers$muG$init <- mean(g0)
  hypers$gR <- list(dist = "uniform", init = g0, p1 = -50, p2 = 50)
  hypers
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
  ysd <- model$scale$ysd[1]
  noise <- if (info$mode == "constant") {
    sd <- if (!is.null(Phi) && "sigma2R" %in% colnames(Phi)) {
      sprintf(", sd %s (posterior median, response units)",
              format(signif(sqrt(stats::median(Phi[, "sigma2R"])) * ysd, digits)))
    } else ""
    paste0("constant", sd)
  } else if (info$mode == "input") {
    g <- if (!is.null(Phi)) Phi[, startsWith(colnames(Phi), "gR"), drop = FALSE]
    sd <- if (length(g)) {
      r <- range(exp(apply(g, 2, stats::median) / 2) * ysd)
      sprintf(", sd %s to %s over the unique inputs (posterior medians, response units)",
              format(signif(r[1], digits)), format(signif(r[2], digits)))
    } else ""
    paste0("input-dependent (log-variance a GP)", sd)
  } else if (info$differ) {
    sprintf("none (their responses differ at %d input%s; the emulator interpolates them)",
            info$differ, if (info$differ == 1L) "" else "s")
  } else "none (the replicates agree)"
  link <- if (identical(info$link, "realization")) "; the field one realization (its variance carries the noise)" else ""
  sprintf("%s; simulator noise: %s%s", found, noise, link)
}

# The noise variance a run is expected to have at the rows of Z (all the
# run inputs, scaled) under one draw ph (the sampler's scale), from the
# latent log-variances' GP (standardised units): log r(z) given g at the
# unique inputs is normal with mean muG + k' Kg^-1 (g - muG) and variance
# sigma2G (1 + jitter) - sigma2G k' Kg^-1 k (Kg = Rg + jitter I, k =
# Rg(X, z)), so E r(z) = exp(mean + var / 2).
latent_noise_mean <- function(model, ph, Z) {
  cls <- model$spec$classes
  Xs <- model$data$Xs
  jitter <- 1e-6  # as src/latent_noise.cpp
  th <- ph[cls == "thetaG"]
  two <- rep(2, ncol(Xs))
  L <- t(chol(.corr_matrix(Xs, Xs, th, two, 4L) + jitter * diag(nrow(Xs))))
  A <- forwardsolve(L, .corr_matrix(Xs, Z, th, two, 4L))
  muG <- ph[cls == "muG"]
  w <- forwardsolve(L, ph[cls == "gR"] - muG)
  exp(muG + drop(crossprod(A, w)) + 0.5 * ph[cls == "sigma2G"] * (1 + jitter - colSums(A^2)))
}

# The noise sd of a run at new experimental inputs Xn (scaled) and each
# draw's kappa: the root of latent_noise_mean()'s mean over the draws
# (phis, on the sampler's scale), the posterior mean of the noise variance.
latent_noise_sd <- function(model, phis, Xn) {
  kap <- which(model$spec$classes == "kappa")
  r <- vapply(seq_len(nrow(phis)), function(i) {
    Z <- cbind(Xn, matrix(phis[i, kap], nrow(Xn), length(kap), byrow = TRUE))
    latent_noise_mean(model, phis[i, ], Z)
  }, numeric(nrow(Xn)))
  sqrt(rowMeans(matrix(r, nrow(Xn))))
}

# emulator_cv() of a fit with the simulator's own noise: the runs' unique
# inputs (sim_replicates() of the runs the model was built from), NULL for
# a fit without that noise.
noise_cv_groups <- function(model) {
  if (is.null(model$spec$model$replicates)) return(NULL)
  sim_replicates(model$raw$sim)
}

# emulator_cv()'s folds over the m unique inputs of a fit with the
# simulator's noise (NULL: leave-one-out): `folds` NULL or a number of folds
# as for a deterministic fit, but over the unique inputs; a vector has one
# label per run and must keep each input's replicates in one fold (a
# replicate left in the training set would predict its own input).
noise_cv_folds <- function(folds, reps, m, call = parent.frame()) {
  n <- length(reps$group)
  if (length(folds) <= 1L) return(emulator_folds(folds, m, call = call))
  if (length(folds) != n || anyNA(folds)) {
    cli::cli_abort(c(
      "{.arg folds} must be a number of folds or one fold label per simulator run ({n}).",
      x = "It has length {length(folds)}{if (anyNA(folds)) ' and missing values' else ''}."
    ), call = call)
  }
  split_at <- which(vapply(split(folds, reps$group), function(f) length(unique(f)) > 1L,
                           logical(1)))
  if (length(split_at)) {
    cli::cli_abort(c(
      "{.arg folds} splits the replicates of {length(split_at)} unique input{?s} over several folds (the first: the runs of input {split_at[1]}).",
      i = "A held-out run's replicates would stay in the training set and predict it: give each input's replicates one fold."
    ), call = call)
  }
  emulator_folds(folds[reps$first], m, call = call)
}

# The simulator's noise variance at each unique input for each draw (rows
# of phis, the sampler's scale: standardised units): m x draws.
noise_variances <- function(model, phis) {
  cls <- model$spec$classes
  m <- nrow(model$data$Xs)
  if (isTRUE(model$spec$model$replicates$latent)) {
    exp(t(phis[, cls == "gR", drop = FALSE]))
  } else {
    matrix(phis[, cls == "sigma2R"], m, nrow(phis), byrow = TRUE)
  }
}

# Every run's response on the standardised scale (the model holds the
# unique inputs' means).
run_responses <- function(model) {
  (model$raw$sim[, 1] - model$scale$ymean[1]) / model$scale$ysd[1]
}

# print() of a fit: the summary table without the latent log-variances gR
# (one per unique input, hundreds of them), and a line that summarises
# them (count, range of the medians, worst R-hat and bulk ESS); NULL line
# without them.
latent_summary <- function(sm, digits = 3) {
  rows <- grepl("^gR[0-9]+$", attr(sm, "row.names"))
  if (!any(rows)) return(list(table = sm, line = NULL))
  g <- as.data.frame(unclass(sm), stringsAsFactors = FALSE)[rows, , drop = FALSE]
  lab <- attr(sm, "noiseLabels")
  table <- sm[!rows, , drop = FALSE]
  attr(table, "noiseLabels") <- lab
  f <- function(v) format(signif(v, digits))
  line <- sprintf("gR: %d latent log-variances (one per unique input), posterior medians %s to %s; largest R-hat %s, smallest bulk ESS %s (all in summary(fit))",
                  sum(rows), f(min(g$median)), f(max(g$median)), f(max(g$rhat)),
                  format(round(min(g$ess))))
  list(table = table, line = line)
}
