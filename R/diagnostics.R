# Convergence diagnostics: R-hat, ESS and draws piling up at a bound.

# Thresholds of convergence_messages() (Vehtari et al. 2021).
fbc_rhat_max <- 1.01
fbc_ess_min <- 400
# A parameter "piles up" at a bound when at least `fbc_pile_share` of its
# draws lie within `fbc_pile_band` times the width of its support from it.
fbc_pile_band <- 0.005
fbc_pile_share <- 0.2
# A posterior "presses against" a bound its prior sets (inside the
# parameter's domain: a uniform prior's edge, a calibration input's prior
# range) when its density there (support_density(), reflected at the bound)
# is at least `fbc_press_peak` of its highest value and at least
# `fbc_press_flat` times a flat density over the prior's range.
fbc_press_peak <- 0.5
fbc_press_flat <- 3

# Draws of each chain side by side (iterations x chains). Chains of unequal
# length (after an interrupt) are cut to the shortest.
chain_matrix <- function(x, chain) {
  ids <- sort(unique(chain))
  cols <- lapply(ids, function(k) x[chain == k])
  n <- min(lengths(cols))
  vapply(cols, function(v) v[seq_len(n)], numeric(n))
}

# posterior (1.4 on) caps an ESS above S log10(S) for S draws, a guard
# against antithetic noise in short chains, and warns each time; the capped
# value is the one to report, and one warning per column of every summary
# table would bury the user's own warnings.
ess_capped <- function(expr) {
  withCallingHandlers(expr, warning = function(w) {
    if (grepl("ESS has been capped", conditionMessage(w), fixed = TRUE)) {
      invokeRestart("muffleWarning")
    }
  })
}

# Rank-normalised split R-hat and bulk ESS of every column of Phi
# (posterior::rhat, posterior::ess_bulk); NA for constant (fixed) columns or
# when there are too few draws.
chain_diagnostics <- function(Phi, chain) {
  one <- function(x) {
    m <- chain_matrix(x, chain)
    if (nrow(m) < 4L || stats::var(as.vector(m)) == 0) return(c(NA_real_, NA_real_))
    c(posterior::rhat(m), ess_capped(posterior::ess_bulk(m)))
  }
  out <- vapply(seq_len(ncol(Phi)), function(j) one(Phi[, j]), numeric(2))
  data.frame(rhat = out[1, ], ess = out[2, ], row.names = colnames(Phi))
}

# Support of every parameter in the units of Phi (kappa native), as a
# two-column matrix of lower and upper bounds.
param_support <- function(x) {
  ps <- phi_spec(x)
  tab <- ps$table
  vars <- phi_vars(x$model$spec)
  fam <- prior_family_name(tab$family)
  d <- nrow(tab)
  lo <- hi <- numeric(d)
  for (j in seq_len(d)) {
    cls <- ps$classes[j]
    s <- family_support(fam[j], tab$p1[j], tab$p2[j])
    dom <- domain_bounds(cls)
    s <- c(max(s[1], dom[1]), min(s[2], dom[2]))
    if (cls == "kappa") {
      k <- match(vars[j], vars[ps$classes == "kappa"])
      lo0 <- x$model$scale$xmin[x$model$scale$p + k]
      rng <- x$model$scale$xmax[x$model$scale$p + k] - lo0
      # prior argument a + b * u, u = (kappa - lo0) / rng
      s <- lo0 + rng * (s - tab$a[j]) / tab$b[j]
    }
    lo[j] <- s[1]
    hi[j] <- s[2]
  }
  cbind(lower = lo, upper = hi)
}

# Parameters whose draws pile up at a finite bound of their support:
# data.frame(var, bound, share). Fixed parameters are skipped.
bound_piling <- function(x) {
  sup <- param_support(x)
  fixed <- phi_spec(x)$table$family == prior_families[["fixed"]]
  vars <- phi_vars(x$model$spec)
  out <- list()
  for (j in seq_along(vars)) {
    if (fixed[j] || !all(is.finite(sup[j, ]))) next
    v <- x$Phi[, j]
    band <- fbc_pile_band * (sup[j, 2] - sup[j, 1])
    share <- c(mean(v <= sup[j, 1] + band), mean(v >= sup[j, 2] - band))
    k <- which.max(share)
    if (share[k] >= fbc_pile_share) {
      out[[length(out) + 1]] <- data.frame(var = vars[j], bound = sup[j, k], share = share[k])
    }
  }
  if (length(out)) do.call(rbind, out) else data.frame(var = character(), bound = numeric(), share = numeric())
}

# Parameters whose posterior presses against a finite bound of their prior
# that lies inside the domain of their class (see fbc_press_peak), leaving
# out those already piling up there: data.frame(var, bound). The domain's own
# bounds (0 for a variance, 1 and 2 for a smoothness) are left to
# bound_piling(): a posterior falling from 0 is an answer there, not a
# truncation by the prior.
bound_pressing <- function(x, piled = bound_piling(x)) {
  sup <- param_support(x)
  ps <- phi_spec(x)
  fixed <- ps$table$family == prior_families[["fixed"]]
  vars <- phi_vars(x$model$spec)
  out <- list()
  for (j in seq_along(vars)) {
    v <- x$Phi[, j]
    if (fixed[j] || vars[j] %in% piled$var || stats::var(v) == 0) next
    dom <- domain_bounds(ps$classes[j])
    d <- support_density(v, sup[j, 1], sup[j, 2])
    flat <- if (all(is.finite(sup[j, ]))) 1 / (sup[j, 2] - sup[j, 1]) else 0
    ends <- c(d$y[1], d$y[length(d$y)])
    at <- c(d$x[1] == sup[j, 1], d$x[length(d$x)] == sup[j, 2]) & sup[j, ] > dom[1] &
      sup[j, ] < dom[2] & ends >= fbc_press_peak * max(d$y) & ends >= fbc_press_flat * flat
    if (any(at)) {
      k <- which(at)[which.max(ends[at])]
      out[[length(out) + 1]] <- data.frame(var = vars[j], bound = unname(sup[j, k]))
    }
  }
  if (length(out)) do.call(rbind, out) else data.frame(var = character(), bound = numeric())
}

# Sampled (not fixed) parameters that a chain never moved: all its draws of
# the parameter are equal. data.frame(var, chain, draws, value).
stuck_chains <- function(x) {
  fixed <- phi_spec(x)$table$family == prior_families[["fixed"]]
  vars <- phi_vars(x$model$spec)
  out <- list()
  for (k in sort(unique(x$chain))) {
    rows <- x$chain == k
    if (sum(rows) < 2L) next
    for (j in which(!fixed)) {
      v <- x$Phi[rows, j]
      if (all(v == v[1])) {
        out[[length(out) + 1]] <- data.frame(var = vars[j], chain = k, draws = sum(rows), value = v[1])
      }
    }
  }
  if (length(out)) do.call(rbind, out) else data.frame(var = character(), chain = integer(), draws = integer(), value = numeric())
}

# Chains in a local mode. When some R-hat is above fbc_rhat_max, a chain
# whose median log posterior lies below the fbc_mode_quantile quantile of
# the best chain's (the chain with the highest median) and at least
# fbc_mode_gap units below its median sits in a region of lower posterior
# density that it has not left: a second mode (of kappa, typically) holding
# little of the posterior's mass (two modes of about the same shape differ in
# mass by about exp(gap)), which running longer rarely leaves. Well-mixed
# chains' medians sit within a fraction of the log posterior's spread of
# each other, so neither condition fires on them; a chain still climbing
# towards them (too short a warm-up) rises from its first half to its
# second by more than half the gap, or is not low in its second half.
# data.frame(chain, logPost
# (its median), best (the best chain), bestLogPost, var (the parameter on
# which it is farthest from the best chain, in the best chain's sds),
# value and bestValue (the two chains' medians of var), draws).
fbc_mode_quantile <- 0.1
fbc_mode_gap <- 2
local_mode_chains <- function(x) {
  none <- data.frame(chain = integer(), logPost = numeric(), best = integer(), bestLogPost = numeric(),
                     var = character(), value = numeric(), bestValue = numeric(), draws = integer())
  ks <- sort(unique(x$chain))
  if (length(ks) < 2L || is.null(x$logPost) || !any(x$estimates$rhat > fbc_rhat_max, na.rm = TRUE)) {
    return(none)
  }
  lp <- split(x$logPost, factor(x$chain, levels = ks))
  med <- vapply(lp, stats::median, numeric(1))
  if (any(!is.finite(med))) return(none)
  b <- which.max(med)
  # (in the chain's second half too: a chain still climbing towards the
  # others, short of its warm-up, is not in a mode)
  half <- function(v, second) {
    h <- seq_len(length(v) %/% 2)
    stats::median(if (second) v[-h] else v[h])
  }
  early <- vapply(lp, half, numeric(1), second = FALSE)
  late <- vapply(lp, half, numeric(1), second = TRUE)
  q <- stats::quantile(lp[[b]], fbc_mode_quantile, names = FALSE)
  low <- which(med < q & med < med[b] - fbc_mode_gap & late < q & late < med[b] - fbc_mode_gap &
                 late - early < fbc_mode_gap / 2)
  if (!length(low)) return(none)
  best <- x$Phi[x$chain == ks[b], , drop = FALSE]
  sdBest <- apply(best, 2, stats::sd)
  medBest <- apply(best, 2, stats::median)
  out <- lapply(low, function(k) {
    own <- x$Phi[x$chain == ks[k], , drop = FALSE]
    medOwn <- apply(own, 2, stats::median)
    z <- abs(medOwn - medBest) / ifelse(sdBest > 0, sdBest, NA)
    j <- if (all(is.na(z))) 1L else which.max(z)
    data.frame(chain = ks[k], logPost = unname(med[k]), best = ks[b], bestLogPost = unname(med[b]),
               var = colnames(x$Phi)[j], value = unname(medOwn[j]), bestValue = unname(medBest[j]),
               draws = nrow(own))
  })
  do.call(rbind, out)
}

# The advice for a power-exponential smoothness at 2: a smooth family,
# whose correlation matrices are better conditioned than exp(-theta d^2) with
# a tiny nugget and which has no smoothness to sample.
smooth_kernel_hint <- function(cls) {
  K <- kernel_arg(cls)
  sprintf("use a smooth correlation family, `%s = \"matern52\"` (or `\"gaussian\"`, alpha = 2) in calibrate()", K)
}

#' Convergence warnings for a calibration
#'
#' Checks the chains of an `fbc` object and returns the warnings worth
#' showing, each with what to do: any rank-normalised split R-hat above 1.01
#' or bulk effective sample size below 400 (the thresholds of Vehtari et al.
#' 2021, computed by the \pkg{posterior} package and shown in the `rhat` and
#' `ess` columns of `x$estimates`), a single chain (R-hat then compares only
#' its two halves), a run interrupted before the end, and parameters whose
#' draws pile up at a bound of their support (at least 20% of the draws within
#' 0.5% of the support's width from it), such as a smoothness \eqn{\alpha} at
#' 2 or a calibration parameter at the edge of its prior range, a posterior
#' pressing against a bound set by its prior (a uniform prior's edge inside
#' the parameter's domain, where the posterior density is at least half its
#' highest and three times a flat density over the prior's range), a chain that
#' never moved a sampled parameter (all its draws equal: a stuck chain, whose
#' R-hat and ESS would otherwise look like a fixed parameter's), a chain in
#' a local mode (with some R-hat above 1.01, a chain whose median log
#' posterior lies below the 10% quantile of the best chain's and at least 2
#' units below its median: a second mode that the chain did not leave, where
#' running longer rarely helps; the R-hat message then says so instead of
#' advising a longer run), calibration
#' parameters with more than 1% of their draws beyond the range the
#' simulator design covers (by more than 5% of its width; there the
#' posterior rests on the emulator's extrapolation: see "Checks" in
#' `vignette("model", package = "FBC")`), calibration parameters confounded with the bias, and
#' prior-data conflicts. Also: calibration parameters that trade off (draws
#' correlated at \eqn{|r| \ge 0.9}; the message gives the combination the data
#' identify, and replaces "run longer" in the R-hat and ESS messages), a
#' calibration parameter whose draws are multimodal (each mode's share), and
#' an emulator bent by the field data (at 30 draws, the field data's pull on
#' the emulator's mean at the field inputs, in runs-only predictive sds, has
#' a median above 3: the posterior rests on an emulator fitted towards the
#' field data; more runs where kappa's draws lie are the remedy).
#'
#' @section Confounding:
#' With a bias GP (any `discrepancy` of [calibrate()] that has one), a calibration
#' parameter is flagged when the field data barely inform it -- its central
#' 95% posterior interval covers at least 70% of the range the simulator
#' design covers, or its posterior sd is at least 70% of its prior's --
#' while the posterior median of `sigma2B` exceeds that of `sigma2E` (with
#' several measurement-error groups, `output =` or `source =`, that of any
#' group: the message names it). The data then cannot separate \eqn{\kappa}
#' from a bias (Kennedy and O'Hagan 2001): another calibration explains the
#' data as well with another bias. This says what the data cannot tell
#' apart, not that there is a bias: with none in the data, `sigma2B`'s prior
#' alone can hold it above `sigma2E`. The message gives the calls that fit the other
#' discrepancy models and compare them with [loo.fbc()]. On the ball data
#' the default fit is flagged (the 95% interval of `g` covers about 90% of
#' the design's range); its S-GaSP and no-discrepancy fits are not.
#'
#' A power-exponential smoothness piling up at 2 says the response is smooth:
#' the advice is then a smooth correlation family, `kernelS = "matern52"`
#' (or `"gaussian"`, the power exponential at \eqn{\alpha = 2}) in
#' [calibrate()] (`kernelB` for \eqn{\alpha_B}), which has no smoothness to
#' sample and, for the Matérn, better conditioned correlation matrices (see
#' [correlation()]); fixing \eqn{\alpha} at 2 is the other way.
#'
#' @section Prior-data conflict:
#' A parameter is flagged when its prior, not the data, sets it: (1) its
#' posterior median lies in the far tail of its prior (prior CDF below 0.01
#' or above 0.99), and (2) the data pull further out: with the other
#' parameters at the MAP draw, the log-likelihood still increases 3
#' posterior standard deviations (on the sampler's walk scale: log for
#' positive parameters) beyond the median, away from the prior, and (3) at
#' its peak there it is at least 2 log-likelihood units above its value at
#' the median (a likelihood that only creeps up on a plateau, as a bias GP
#' scale `thetaB` does towards 0 along an input the bias does not vary
#' with, leaves the choice to the prior: no conflict). The message
#' gives the value where that likelihood peaks and a looser prior with that
#' value near its centre, as a call to [set_hyperPriors()] (an inverse-gamma
#' or gamma prior with shape at most 1.1 and median at that value; a wider
#' Gaussian; a uniform smoothness on `[1, 2]`). Parameters already piling up
#' at a bound, fixed ones and those with an improper prior are skipped.
#'
#' The typical case is the measurement error variance: the default
#' inverse-gamma(1.5, 1.5) prior on the standardised \eqn{\sigma^2_E} puts
#' almost no mass below about 0.1 (its CDF there is \eqn{3 \times 10^{-6}}),
#' so when the field noise is small (sd below roughly 30% of the simulator
#' response's sd) it holds \eqn{\sigma^2_E} near 0.15 whatever the data say,
#' and the predictive intervals are too wide. On the ball data the posterior
#' median of \eqn{\sigma^2_E} also lies in the prior's tail (CDF about
#' \eqn{10^{-4}}) but the likelihood peaks within 3 posterior sds (at about
#' 0.1, against a median of 0.15): the prior moves it, without deciding it,
#' and no message is given.
#'
#' @param x An `fbc` object from [calibrate()] or [update.fbc()].
#' @return A character vector of messages, empty when nothing is wrong.
#' @export
#' @examples
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 600, nBurn = 200, nChains = 2)
#' convergence_messages(fit)
convergence_messages <- function(x) {
  x <- check_fbc(x, "x")
  est <- x$estimates
  nChains <- length(unique(x$chain))
  msgs <- if (isTRUE(x$state$interrupted)) {
    "The run was interrupted before the end; continue it with `update(fit, nMCMC = ...)`."
  }
  bad <- which(est$rhat > fbc_rhat_max)
  low <- which(est$ess < fbc_ess_min)
  modes <- local_mode_chains(x)
  ridge <- kappa_ridge(x, rownames(est)[union(bad, low)])
  msgs <- c(msgs, mixing_messages(est, bad, low, modes, ridge, nChains),
            ridge_messages(ridge), shape_messages(x, rownames(est)[union(bad, low)]))
  if (nChains == 1L) {
    msgs <- c(msgs, "Only one chain: R-hat compares its two halves only. Use `nChains = 4` to check that independent chains agree.")
  }
  c(msgs, local_mode_messages(modes), stuck_messages(x), bound_messages(x),
    kappa_modes_messages(x), field_pull_messages(x),
    kappa_beyond_messages(x), confounding_messages(x), conflict_messages(x))
}

# The R-hat and bulk ESS messages (parameters `bad`, `low` of the estimates
# `est`), with what to do: a chain in a local mode (`modes`) or calibration
# inputs that trade off (`ridge`, kappa_ridge()) is the cause, not the
# run's length; else run longer.
mixing_messages <- function(est, bad, low, modes, ridge, nChains) {
  msgs <- character()
  cause <- if (nrow(modes)) "mode" else if (length(ridge$vars)) "ridge" else "length"
  if (length(bad)) {
    msgs <- c(msgs, sprintf(
      "R-hat above %.2f for %s (max %.3f): the chains disagree. %s.",
      fbc_rhat_max, paste(rownames(est)[bad], collapse = ", "), max(est$rhat[bad]),
      switch(cause,
        mode = sprintf("Chain%s %s %s in a local mode (below): running longer rarely moves %s",
                       if (nrow(modes) > 1) "s" else "", paste(modes$chain, collapse = " and "),
                       if (nrow(modes) > 1) "are" else "is", if (nrow(modes) > 1) "them" else "it"),
        ridge = "Calibration inputs that trade off (below) are the cause",
        paste0("Run longer with `update(fit, nMCMC = ...)`",
               if (nChains < 4) " or use more chains (`nChains = 4`)" else ""))
    ))
  }
  if (length(low)) {
    msgs <- c(msgs, sprintf(
      "Bulk ESS below %d for %s (min %.0f): too few effective draws for stable intervals. %s.",
      fbc_ess_min, paste(rownames(est)[low], collapse = ", "), min(est$ess[low]),
      switch(cause,
        mode = "A chain in a local mode (below) is the cause, not the run's length",
        ridge = "Calibration inputs that trade off (below) are the cause",
        "Run longer with `update(fit, nMCMC = ...)`")
    ))
  }
  msgs
}

# A chain in a local mode (local_mode_chains()), one message each.
local_mode_messages <- function(modes) {
  vapply(seq_len(nrow(modes)), function(i) {
    md <- modes[i, ]
    sprintf(
      "Chain %d sits in a local mode: its log posterior is lower than chain %d's (median %s against %s), with %s at %s (chain %d: %s), and it did not leave it in %d draws. Such a mode likely holds little of the posterior's mass (about %s of the other's if of the same shape), yet the summaries give it a chain's share. Rerun with another seed (`set.seed()`), or with more chains (`nChains = 8`) to see how often chains fall into it.",
      md$chain, md$best, format(md$logPost, digits = 4), format(md$bestLogPost, digits = 4),
      md$var, format(md$value, digits = 3), md$best, format(md$bestValue, digits = 3), md$draws,
      format(exp(md$logPost - md$bestLogPost), digits = 2))
  }, character(1))
}

# A chain that never moved (stuck_chains()), one message each.
stuck_messages <- function(x) {
  stuck <- stuck_chains(x)
  vapply(unique(stuck$chain), function(k) {
    st <- stuck[stuck$chain == k, ]
    sprintf(
      "Chain %d never moved %s in its %d draws: it is stuck (every proposal rejected), not converged, and R-hat and ESS cannot be trusted. Rerun with another seed or a longer burn-in (`nBurn`), and check the priors and initial values.",
      k, paste(sprintf("%s (at %s)", st$var, signif(st$value, 4)), collapse = " and "), st$draws[1])
  }, character(1))
}

# Draws piling up at a bound (bound_piling()) and a posterior pressing
# against its prior's bound (bound_pressing()), one message each.
bound_messages <- function(x) {
  kappaHint <- "The posterior wants values outside the prior's range: widen the prior or the simulator design, or check for a discrepancy the model cannot absorb."
  pile <- bound_piling(x)
  msgs <- vapply(seq_len(nrow(pile)), function(i) {
    v <- pile$var[i]
    cls <- x$model$spec$classes[match(v, x$model$spec$vars)]
    hint <- switch(cls,
      alphaS = , alphaB = paste0(
        "The data favour this smoothness; ",
        if (pile$bound[i] == 2) paste0(smooth_kernel_hint(cls), ", or fix it") else "consider fixing it",
        sprintf(" (e.g. `%sDist = \"fixed\", %sInit = %g` in set_hyperPriors()).",
                cls, cls, pile$bound[i])),
      kappa = kappaHint,
      rhoS = , rhoB = , rhoD = rho_bound_hint(x, v, cls, pile$bound[i]),
      "Check that this prior's support is wide enough."
    )
    sprintf("%.0f%% of the draws of %s lie at its bound %g. %s", 100 * pile$share[i], v,
            pile$bound[i], hint)
  }, character(1))
  press <- bound_pressing(x, pile)
  c(msgs, vapply(seq_len(nrow(press)), function(i) {
    v <- press$var[i]
    cls <- x$model$spec$classes[match(v, x$model$spec$vars)]
    hint <- if (cls == "kappa") kappaHint else {
      sprintf("Widen its prior (`%sDist`, `%sP1`, `%sP2` in set_hyperPriors()) unless this bound is known.", cls, cls, cls)
    }
    sprintf(
      "The posterior of %s presses against its prior's bound %g (its density is highest there): the prior, not the data, sets this edge. %s",
      v, press$bound[i], hint)
  }, character(1)))
}

# What a level correlation (rhoS, rhoB: levels of a categorical input;
# rhoD: the field data sets' biases) at +1 or -1 means, in words: the two
# levels move together (or oppositely), one a shifted and scaled copy (or
# mirror image) of the other. An answer about the data, not a prior whose
# support is too narrow (it is the whole of (-1, 1)).
rho_bound_hint <- function(x, v, cls, bound) {
  pos <- match(v, x$model$spec$vars[x$model$spec$classes == cls])
  src <- x$model$scale$source
  factors <- if (cls == "rhoD") list(list(name = src$name, levels = src$levels)) else level_factors(x$model)
  lab <- level_labels(factors)
  lab <- lab[(pos - 1L) %% length(lab) + 1L]  # independent outputs: a copy per output
  input <- sub(":.*$", "", lab)
  pair <- sub("^[^:]*: ", "", lab)
  given <- if (grepl(" | ", pair, fixed = TRUE)) paste0(" given ", sub("^.* \\| ", "", pair)) else ""
  pair <- sub("~", " and ", sub(" \\| .*$", "", pair))
  who <- if (cls == "rhoD") "data sets' biases" else "levels"
  head <- switch(cls,
    rhoS = sprintf("the simulator GP's correlation between levels %s of `%s`", pair, input),
    rhoB = sprintf("the bias GP's correlation between levels %s of `%s`", pair, input),
    rhoD = sprintf("the correlation between the biases of data sets %s (`%s`)", pair, input))
  if (nzchar(given)) head <- paste0(head, " (a partial correlation,", given, ")")
  how <- if (bound > 0) "move together: across the inputs, one is a shifted and scaled copy of the other" else
    "move oppositely: across the inputs, one is a mirror image of the other (up where it goes down)"
  gp <- if (cls == "rhoS") "" else ", gp = \"bias\""
  paste0(v, " is ", head, ": at ", sprintf("%+g", bound), " the two ", who, " ", how,
         ". This is what the data say (or that they are too few to tell the ", who,
         " apart), not a prior too narrow: it spans all of -1 to 1. See `level_correlation(fit, \"",
         input, "\"", gp, ")`; if the ", who, " should differ, check that each has enough runs and field data.")
}

# A joint move whose parameters have not converged (`slow`: R-hat or ESS
# short) and whose acceptance after burn-in, in some chain, is far from its
# target 0.234 (above 0.4 or below 0.1): the proposal's shape, learned in the
# second half of burn-in, does not fit the posterior, and a longer burn-in
# is the cure, not a longer run (update() keeps the proposals). Measured at
# m = 1000 (bench/RESULTS-vecchia.md): a burn-in of 1000 left the
# simulator block at acceptance 0.30-0.68 over the chains and bulk ESS 62
# per 12,000 draws; 4000 gave 0.22-0.24 and 634.
shape_messages <- function(x, slow) {
  if (!length(slow)) return(character())
  ms <- lapply(x$state$chains, function(s) s$sampler$moves)
  if (!length(ms) || any(vapply(ms, is.null, logical(1)))) return(character())
  first <- ms[[1]]
  out <- character()
  for (i in which(first$kind == "joint")) {
    pars <- strsplit(first$params[i], ",", fixed = TRUE)[[1]]
    acc <- vapply(ms, function(m) if (m$tries[i] > 0) m$accepted[i] / m$tries[i] else NA_real_,
                  numeric(1))
    off <- is.finite(acc) & (acc > 0.4 | acc < 0.1)
    if (!any(pars %in% slow) || !any(off)) next
    nBurn <- x$settings$nBurn
    out <- c(out, sprintf(
      "The joint move of %s accepted %s of its proposals after burn-in (by chain; target about 23%%): its proposal did not learn the posterior's shape in %d burn-in sweeps. Rerun with a longer burn-in (e.g. `nBurn = %d`): `update()` keeps the proposals as they are.",
      paste(pars, collapse = ", "), paste0(sprintf("%.0f", 100 * acc), "%", collapse = ", "),
      nBurn, max(3L * nBurn, 3000L)))
  }
  out
}

# Posterior summary of each column of Phi, with the rank-normalised split
# R-hat and the bulk ESS over the chains given by `chain` (see diagnostics.R).
estimate_table <- function(Phi, chain = rep(1L, nrow(Phi))) {
  qs <- function(x) stats::quantile(x, c(0.5, 0.25, 0.75, 0.1, 0.9), names = FALSE)
  out <- t(apply(Phi, 2, function(x) {
    qq <- qs(x)
    c(mean = mean(x), median = qq[1], mode = pmode(x), lwr50 = qq[2], upr50 = qq[3],
      lwr80 = qq[4], upr80 = qq[5], sd = stats::sd(x))
  }))
  out <- as.data.frame(out)
  diag <- chain_diagnostics(Phi, chain)
  out$rhat <- diag$rhat
  out$ess <- diag$ess
  out
}

# Calibration inputs that trade off: kappa columns whose pooled draws
# correlate at |r| >= fbc_ridge_cor form groups (pairs linked into
# components). For each group, what the data identify: the combination
# along the direction of least posterior variance (the covariance's last
# eigenvector, scaled so that its first kappa has coefficient 1) and its
# posterior sd, beside the sd of each kappa alone. `flagged`: the
# parameters with too high R-hat or too low ESS (the cause then, not the
# run's length). list(groups, vars) with `vars` the flagged kappas in a
# group; NULL groups when there are none.
fbc_ridge_cor <- 0.9
kappa_ridge <- function(x, flagged = character()) {
  k <- grep("^kappa[0-9]+$", colnames(x$Phi), value = TRUE)
  k <- k[apply(x$Phi[, k, drop = FALSE], 2, stats::sd) > 0]
  none <- list(groups = list(), vars = character())
  if (length(k) < 2L) return(none)
  r <- suppressWarnings(stats::cor(x$Phi[, k, drop = FALSE]))
  link <- abs(r) >= fbc_ridge_cor & !is.na(r)
  comp <- seq_along(k)
  for (it in seq_along(k)) for (i in seq_along(k)) comp[i] <- min(comp[link[i, ]])
  groups <- lapply(Filter(function(g) length(g) > 1L, split(seq_along(k), comp)), function(g) {
    v <- k[g]
    S <- stats::cov(x$Phi[, v, drop = FALSE])
    e <- eigen(S, symmetric = TRUE)
    a <- e$vectors[, length(v)]
    a <- a / a[1]
    list(vars = v, cor = r[g, g, drop = FALSE], coef = a, sd = sqrt(max(e$values[length(v)], 0)),
         sdEach = sqrt(diag(S)))
  })
  list(groups = unname(groups),
       vars = intersect(unlist(lapply(groups, `[[`, "vars")), flagged))
}

# One message per group of kappa_ridge(): which inputs trade off, what the
# data identify, what to do.
ridge_messages <- function(ridge) {
  vapply(ridge$groups, function(g) {
    lab <- g$vars
    pair <- if (length(lab) == 2L) sprintf("correlation %.2f", g$cor[1, 2]) else
      sprintf("correlations %.2f to %.2f", min(abs(g$cor[upper.tri(g$cor)])), max(abs(g$cor[upper.tri(g$cor)])))
    comb <- paste0(ifelse(seq_along(lab) == 1L, "", ifelse(g$coef < 0, " - ", " + ")),
                   ifelse(seq_along(lab) == 1L | abs(abs(g$coef) - 1) < 0.005, "",
                          paste0(format(signif(abs(g$coef), 3)), " ")), lab, collapse = "")
    sprintf(
      "The calibration inputs %s trade off (%s): the data identify %s (posterior sd %s) much better than each alone (sd %s), and a summary of one of them mostly shows where the ridge meets the prior. Report the combination, or fix one of them (or give it an informative prior), or add field data that separate them.",
      paste(lab, collapse = ", "), pair, comb, fmt_num(g$sd),
      paste(vapply(g$sdEach, fmt_num, ""), collapse = ", "))
  }, character(1))
}

# Kappa's draws with more than one mode: each calibration input's pooled
# draws, a kernel density (Silverman's bandwidth, which oversmooths a
# mixture: a mode it shows is there) on 512 points; a mode is a local
# maximum whose basin (down to the lowest points between it and its
# neighbours) holds at least fbc_mode_share of the draws, with a valley
# between two modes below fbc_mode_dip of the lower peak. One row per
# kappa with two or more such modes: var, the modes' locations and shares,
# and the chains that visited each (a draw in its basin).
fbc_mode_share <- 0.02
fbc_mode_dip <- 0.5
kappa_modes <- function(x) {
  k <- grep("^kappa[0-9]+$", colnames(x$Phi), value = TRUE)
  out <- list()
  for (v in k) {
    d <- x$Phi[, v]
    if (length(d) < 100L || stats::sd(d) == 0) next
    m <- draw_modes(d)
    if (nrow(m) < 2L) next
    basin <- findInterval(d, c(-Inf, m$cut[-1], Inf))
    m$chains <- vapply(seq_len(nrow(m)), function(i) length(unique(x$chain[basin == i])), integer(1))
    out[[v]] <- cbind(var = v, m)
  }
  if (length(out)) do.call(rbind, unname(out)) else NULL
}

# The modes of draws `d` (see kappa_modes()): location, share, and the
# lower edge of each basin (`cut`, the first -Inf).
draw_modes <- function(d) {
  den <- stats::density(d, n = 512)
  y <- den$y
  n <- length(y)
  peak <- which(diff(sign(diff(y))) < 0) + 1L
  if (y[1] > y[2]) peak <- c(1L, peak)
  if (y[n] > y[n - 1]) peak <- c(peak, n)
  repeat {  # merge neighbours without a deep enough valley, or a small basin
    if (length(peak) < 2L) break
    valley <- vapply(seq_len(length(peak) - 1L), function(i) {
      peak[i] - 1L + which.min(y[peak[i]:peak[i + 1]])
    }, integer(1))
    edges <- c(-Inf, den$x[valley], Inf)
    share <- as.vector(table(factor(findInterval(d, edges), levels = seq_along(peak)))) / length(d)
    shallow <- y[valley] > fbc_mode_dip * pmin(y[peak[-1]], y[peak[-length(peak)]])
    small <- share < fbc_mode_share
    if (!any(shallow) && !any(small)) break
    # drop the lowest peak of the worst offence
    i <- if (any(small)) which(small)[which.min(y[peak[small]])] else {
      j <- which(shallow)[1]
      c(j, j + 1L)[which.min(y[peak[c(j, j + 1L)]])]
    }
    peak <- peak[-i]
  }
  if (length(peak) < 2L) return(data.frame(at = den$x[peak], share = 1, cut = -Inf))
  data.frame(at = den$x[peak], share = share, cut = edges[-length(edges)])
}

# One message per multimodal kappa (kappa_modes()).
kappa_modes_messages <- function(x) {
  m <- kappa_modes(x)
  if (is.null(m)) return(character())
  nChains <- length(unique(x$chain))
  vapply(unique(m$var), function(v) {
    r <- m[m$var == v, ]
    rare <- r$chains < nChains
    sprintf(
      "The draws of %s are multimodal: modes near %s. Its mean and sd average over them; report the modes (see `plot(fit, \"kappa\")`).%s R-hat cannot see a mode that every chain visits too rarely: more chains (`nChains = 8`) show how stable the shares are.",
      v, paste(sprintf("%s (%s of the draws)", vapply(r$at, fmt_num, ""), fmt_share(r$share)), collapse = ", "),
      if (any(rare)) sprintf(" Not every chain visited every mode (of the %d chains: %s).", nChains,
                             paste(sprintf("%d near %s", r$chains, vapply(r$at, fmt_num, "")),
                                   collapse = ", ")) else "")
  }, character(1))
}
