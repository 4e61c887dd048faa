# Prior-data conflict: a parameter whose posterior sits in the far tail of its
# prior while the data alone point further out. See "Prior-data conflict" in
# ?convergence_messages for the rule.

# The posterior median's prior CDF below this, or above 1 - this, makes a
# parameter a candidate ...
fbc_conflict_tail <- 0.01
# ... and it is flagged when its likelihood (the other parameters at the MAP
# draw) still rises this many posterior sds beyond the median, away from the
# prior's bulk.
fbc_conflict_sds <- 3
# ... by at least this much (log-likelihood units, a likelihood ratio of
# about 7) at its peak over its value at the median: a likelihood that only
# creeps up on a plateau (a bias GP scale going to 0 along an input the bias
# does not vary with) leaves the choice to the prior, which is no conflict.
fbc_conflict_gain <- 2

# The check costs about 30 likelihood evaluations (12 s at m = 1500 on the
# dense algebra), and print(), summary() and convergence_messages() all ask
# for it: it is computed once per fit and kept in the fit's cache, an
# environment in its attribute "cache" (fit_cache(), made with the fit). A
# fit made before the cache, or a copy whose draws, data or priors were
# changed (its fingerprint differs), is checked afresh.
fit_cache <- function() new.env(parent = emptyenv())

# What the check reads, in a few numbers: the draws (weighted by position,
# so that a reordered column differs), log posteriors, data, priors and
# nugget.
conflict_key <- function(fit) {
  d <- fit$model$data
  list(dim(fit$Phi), sum(fit$Phi), sum(fit$Phi * seq_along(fit$Phi)), sum(fit$logPost),
       sum(d$yf), sum(d$ys), sum(d$Xs), sum(d$Xf), fit$model$spec$table, fit$settings$nugget)
}

# prior_conflicts() of the fit, from its cache when it has one and the fit
# is unchanged; cache$conflictRuns counts the checks run (for tests).
cached_conflicts <- function(fit) {
  cache <- attr(fit, "cache", exact = TRUE)
  if (!is.environment(cache)) return(prior_conflicts(fit))
  key <- conflict_key(fit)
  if (!identical(cache$conflictKey, key)) {
    cache$conflicts <- prior_conflicts(fit)
    cache$conflictKey <- key
    cache$conflictRuns <- (cache$conflictRuns %||% 0L) + 1L
  }
  cache$conflicts
}

# Log-likelihood of the fit's data at phi (the sampler's scale).
fit_loglik <- function(fit, phi) {
  d <- fit$model$data
  ll <- .fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, fit$settings$nugget,
                    model = fit$model$spec$model)
  if (is.finite(ll)) ll else -Inf
}

# One row per flagged parameter: var, class, side ("lower"/"upper"), the
# prior CDF at the posterior median, the median, the value where the
# likelihood alone peaks (`dataValue`, kappa in its own units; `priorValue`
# in the prior's units), and whether that is a bound of the support
# (`atBound`, `bound`), or the likelihood has no peak but rises to a limit
# (`rising`: `dataValue` is then where it comes within 1 of the limit).
# `loglik(fit, phi)`: the data's log-likelihood (a seam for tests).
prior_conflicts <- function(fit, loglik = fit_loglik) {
  empty <- data.frame(var = character(), class = character(), side = character(),
                      cdf = numeric(), median = numeric(), dataValue = numeric(),
                      atBound = logical(), bound = numeric(), priorValue = numeric(),
                      rising = logical())
  if (nrow(fit$Phi) < 2L) return(empty)
  ps <- phi_spec(fit)
  vars <- phi_vars(fit$model$spec)
  tab <- ps$table
  fam <- prior_family_name(tab$family)
  full <- sampler_draws(fit)
  phis <- full[, ps$cols, drop = FALSE]
  map <- full[which.max(fit$logPost), ]
  piled <- bound_piling(fit)$var
  support <- param_support(fit)
  out <- list()
  for (j in seq_along(vars)) {
    if (!prior_registry[[fam[j]]]$proper || vars[j] %in% piled) next
    sup_j <- support[j, ]
    x <- phis[, j]
    if (stats::var(x) == 0) next
    u <- prior_cdf(tab$a[j] + tab$b[j] * stats::median(x), fam[j], tab$p1[j], tab$p2[j])
    if (is.na(u) || (u >= fbc_conflict_tail && u <= 1 - fbc_conflict_tail)) next
    dir <- if (u < fbc_conflict_tail) -1 else 1
    w <- to_walk(x, tab$transform[j])
    wmed <- stats::median(w)
    sdw <- stats::sd(w)
    ll <- function(wv) {
      phi <- map
      phi[ps$cols[j]] <- from_walk(wv, tab$transform[j])
      loglik(fit, phi)
    }
    w3 <- wmed + dir * fbc_conflict_sds * sdw
    if (!(ll(w3 + dir * 0.1 * sdw) > ll(w3))) next
    # where the likelihood alone peaks, further out (within the prior's support)
    far <- w3 + dir * 40 * sdw
    if (tab$transform[j] == 0) {
      sup <- (family_support(fam[j], tab$p1[j], tab$p2[j]) - tab$a[j]) / tab$b[j]
      far <- min(max(far, sup[1]), sup[2])
    }
    wL <- stats::optimize(function(v) max(ll(v), -1e300), sort(c(w3, far)), maximum = TRUE,
                          tol = 0.1 * sdw)$maximum
    llL <- ll(wL)
    if (llL - ll(wmed) < fbc_conflict_gain) next
    # the value in the prior's units (`value`) and as reported (kappa in its
    # own units)
    at <- function(w) {
      u <- from_walk(w, tab$transform[j])
      value <- tab$a[j] + tab$b[j] * u
      reported <- if (ps$classes[j] == "kappa") {
        k <- match(vars[j], vars[ps$classes == "kappa"])
        drop(unscale_inputs(matrix(u), fit$model$scale, fit$model$scale$p + k))
      } else value
      list(value = value, reported = reported)
    }
    peak <- at(wL)
    bound <- sup_j[if (dir < 0) 1L else 2L]
    atBound <- all(is.finite(sup_j)) && abs(peak$reported - bound) <= fbc_pile_band * diff(sup_j)
    # away from a finite bound and as high at the end of the search: no peak
    # but a limit (a GP scale going to 0, the optimum anywhere on a
    # plateau); report where the likelihood comes within 1 of it
    rising <- !atBound && ll(far) >= llL - 0.05
    if (rising) {
      peak <- at(stats::uniroot(function(v) ll(v) - (llL - 1), sort(c(wmed, wL)),
                                tol = 0.01 * sdw)$root)
    }
    valueL <- peak$value
    reported <- peak$reported
    out[[length(out) + 1L]] <- data.frame(
      var = vars[j], class = ps$classes[j], side = if (dir < 0) "lower" else "upper",
      cdf = u, median = stats::median(fit$Phi[, j]), dataValue = reported,
      atBound = atBound, bound = if (atBound) bound else NA_real_, priorValue = valueL,
      rising = rising
    )
  }
  if (length(out)) do.call(rbind, out) else empty
}

# A looser prior for the flagged members `js` (positions in phi, as in
# fit$model$spec$vars) of one class, each of the same
# kind with the data's value (`values`, in the prior's units) near its
# centre, or fixed at a bound the data press against (`bounds`, NA when
# none); other members keep their priors. Returns the text of an R call, or
# NA when there is no obvious one.
suggest_prior <- function(fit, js, values, bounds = rep(NA_real_, length(js))) {
  tab <- fit$model$spec$table
  cls <- fit$model$spec$classes[js[1]]
  members <- which(fit$model$spec$classes == cls)
  fams <- prior_family_name(tab$family[members])
  p1 <- tab$p1[members]
  p2 <- tab$p2[members]
  init <- fit$model$spec$priors[[cls]]$init
  for (i in seq_along(js)) {
    j <- js[i]
    k <- match(j, members)
    value <- values[i]
    new <- if (!is.na(bounds[i])) {
      if (cls == "kappa") return(NA_character_)  # widen the range instead
      list(dist = "fixed", p1 = p1[k], p2 = p2[k], init = bounds[i])
    } else switch(fams[k],
      # prior median at the data's value, shape at most 1.1 (a heavy upper tail)
      inversegamma = {
        sh <- min(p1[k], 1.1)
        list(dist = "inversegamma", p1 = sh, p2 = value * stats::qgamma(0.5, sh), init = value)
      },
      gamma = {
        sh <- min(p1[k], 1.1)
        list(dist = "gamma", p1 = sh, p2 = stats::qgamma(0.5, sh) / value, init = value)
      },
      # same centre, the data's value within half a prior sd
      gaussian = list(dist = "gaussian", p1 = p1[k], p2 = max(p2[k], 2 * abs(value - p1[k])),
                      init = value),
      lognormal = list(dist = "lognormal", p1 = log(value), p2 = max(p2[k], 1), init = value),
      # the data's sd well inside the half-t's scale
      halft_sd = list(dist = "halft_sd", p1 = p1[k], p2 = max(p2[k], 2 * sqrt(value)), init = value),
      betashift = list(dist = "uniform", p1 = 1, p2 = 2, init = 1.5),
      NULL
    )
    if (is.null(new)) return(NA_character_)
    fams[k] <- new$dist
    p1[k] <- new$p1
    p2[k] <- new$p2
    init[k] <- new$init
  }
  if (cls == "kappa") {
    # kappa's prior is given in calibrate(), in the calibration inputs' units
    if (any(fams != "gaussian")) return(NA_character_)
    return(sprintf("calibrate(sim, field, kappaDist = %s, kappaP1 = %s, kappaP2 = %s, kappaInit = %s)",
                   r_vec(fams), r_vec(p1), r_vec(p2), r_vec(init)))
  }
  if (all(fams[match(js, members)] == "fixed")) {
    return(sprintf("set_hyperPriors(%sDist = %s, %sInit = %s)", cls, r_vec(fams), cls, r_vec(init)))
  }
  sprintf("set_hyperPriors(%sDist = %s, %sP1 = %s, %sP2 = %s, %sInit = %s)",
          cls, r_vec(fams), cls, r_vec(p1), cls, r_vec(p2), cls, r_vec(init))
}

# A vector as R code, numbers to two significant digits.
r_vec <- function(v) {
  txt <- if (is.character(v)) paste0("\"", v, "\"") else format_num(v)
  if (length(v) == 1L) txt else paste0("c(", paste(txt, collapse = ", "), ")")
}
format_num <- function(v) vapply(v, function(x) format(signif(x, 2), scientific = (abs(x) < 1e-4 || abs(x) >= 1e5) && x != 0),
                                 character(1))

# The convergence_messages() text: one message per class of parameters
# (`cf`: the rows of prior_conflicts()).
conflict_messages <- function(fit, cf = cached_conflicts(fit)) {
  tab <- fit$model$spec$table
  vapply(unique(cf$class), function(cls) {
    rows <- cf[cf$class == cls, , drop = FALSE]
    one <- nrow(rows) == 1L
    j <- match(rows$var, fit$model$spec$vars)
    dist <- prior_family_name(tab$family[j])
    priors <- unique(sprintf("%s(%s, %s)", dist, format_num(tab$p1[j]), format_num(tab$p2[j])))
    prob <- ifelse(rows$side == "lower", rows$cdf, 1 - rows$cdf)
    side <- if (length(unique(rows$side)) == 1L) paste(rows$side[1], "tail") else "tails"
    where <- if (length(unique(rows$side)) == 1L) {
      if (rows$side[1] == "lower") " below" else " above"
    } else ""
    peak <- if (all(rows$atBound)) {
      sprintf("peaks at the bound %s", paste(unique(format_num(rows$bound)), collapse = ", "))
    } else if (all(rows$rising %||% FALSE)) {
      positive <- class_domain[[cls]] == "positive"
      sprintf("keeps rising %s (it comes within 1 log-likelihood unit of its limit %s %s)",
              if (rows$side[1] == "lower" && positive) "towards 0" else "without bound",
              if (rows$side[1] == "lower") "below about" else "above about",
              paste(format_num(rows$dataValue), collapse = ", "))
    } else {
      sprintf("peaks near %s", paste(format_num(rows$dataValue), collapse = ", "))
    }
    parts <- sprintf(
      "%s posterior median%s, %s, sit%s in the far %s of %s %s prior%s (prior probability %s%s), while the likelihood alone (the other parameters at the MAP draw) %s",
      if (one) "its" else "their", if (one) "" else "s",
      paste(format(signif(rows$median, 3)), collapse = ", "), if (one) "s" else "",
      side, if (one) "its" else "their", paste(priors, collapse = ", "), if (one) "" else "s",
      paste(format(signif(prob, 1)), collapse = ", "), where, peak)
    vars <- paste(rows$var, collapse = ", ")
    verdict <- if (all(rows$atBound) && cls %in% smooth_classes) {
      "the data favour this smoothness"
    } else if (all(rows$atBound) && cls == "kappa") {
      "the posterior wants values outside the prior's range"
    } else {
      sprintf("the prior, not the data, sets %s", vars)
    }
    sugg <- suggest_prior(fit, match(rows$var, fit$model$spec$vars), rows$priorValue,
                          ifelse(rows$atBound, rows$bound, NA_real_))
    advice <- if (cls == "kappa" && all(rows$atBound)) {
      " Widen the prior or the simulator design, or check for a discrepancy the model cannot absorb."
    } else if (is.na(sugg)) {
      " Loosen or re-centre this prior and calibrate again."
    } else if (cls == "kappa") {
      sprintf(" Loosen %s, e.g. `%s`.", if (nrow(rows) == 1L) "it" else "them", sugg)
    } else if (all(rows$atBound) && cls %in% smooth_classes && all(rows$bound == 2)) {
      sprintf(" Consider %s, or fixing %s, e.g. `hypers = %s`.",
              sub("^use", "using", smooth_kernel_hint(cls)),
              if (nrow(rows) == 1L) "it" else "them", sugg)
    } else if (all(rows$atBound)) {
      sprintf(" Consider fixing %s, e.g. `hypers = %s`.", if (nrow(rows) == 1L) "it" else "them", sugg)
    } else if (all(dist %in% c("gaussian", "halft_sd"))) {
      # same centre, a wider spread
      sprintf(" Loosen %s, e.g. `hypers = %s`, and calibrate again.",
              if (nrow(rows) == 1L) "it" else "them", sugg)
    } else {
      # suggest_prior() moves the median to the likelihood's peak with a
      # heavy tail: a re-centred prior, possibly narrower in absolute terms
      # (gamma rate 0.1 -> 610), so it is not called a looser one
      sprintf(" Re-centre %s on the likelihood's peak (a heavy-tailed prior with its median there), e.g. `hypers = %s`, and calibrate again.",
              if (nrow(rows) == 1L) "it" else "them", sugg)
    }
    sprintf("Prior-data conflict for %s: %s: %s.%s", vars, parts, verdict, advice)
  }, character(1), USE.NAMES = FALSE)
}
