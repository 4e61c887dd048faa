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

# CDF of a prior family in the units the family is written in (NA for the
# improper and fixed ones).
prior_cdf <- function(x, dist, p1, p2) {
  switch(dist,
    uniform = stats::punif(x, p1, p2),
    gaussian = stats::pnorm(x, p1, p2),
    gamma = stats::pgamma(x, p1, rate = p2),
    beta = stats::pbeta(x, p1, p2),
    lognormal = stats::plnorm(x, p1, p2),
    logistic = stats::plogis(x, p1, p2),
    betashift = stats::pbeta(x - 1, p1, p2),
    exponential = stats::pexp(x, p1),
    inversegamma = stats::pgamma(p2 / x, p1, lower.tail = FALSE),
    NA_real_
  )
}

# The sampler's walk scale (calibrate(), "Sampler") and back.
to_walk <- function(x, transform) {
  switch(as.character(transform), `0` = x, `1` = log(x), `2` = stats::qlogis(x - 1))
}
from_walk <- function(w, transform) {
  switch(as.character(transform), `0` = w, `1` = exp(w), `2` = 1 + stats::plogis(w))
}

# Log-likelihood of the fit's data at phi (the sampler's scale).
fit_loglik <- function(fit, phi) {
  d <- fit$data
  ll <- .fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, fit$settings$nugget %||% fbc_nugget)
  if (is.finite(ll)) ll else -Inf
}

# One row per flagged parameter: var, class, side ("lower"/"upper"), the
# prior CDF at the posterior median, the median, the value the data alone
# favour (`dataValue`; kappa in its own units), and the suggested
# prior (`suggestion`, an R call as text, or NA).
prior_conflicts <- function(fit) {
  empty <- data.frame(var = character(), class = character(), side = character(),
                      cdf = numeric(), median = numeric(), dataValue = numeric(),
                      suggestion = character())
  tab <- fit$spec$table
  if (is.null(tab) || nrow(fit$Phi) < 2L) return(empty)
  fam <- names(prior_families)[match(tab$family, prior_families)]
  phis <- sampler_scale(fit$Phi, fit$scale)
  map <- phis[which.max(fit$logPost), ]
  piled <- bound_piling(fit)$var
  out <- list()
  for (j in seq_along(fit$vars)) {
    if (fam[j] %in% c("fixed", "jeffreys") || fit$vars[j] %in% piled) next
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
      phi[j] <- from_walk(wv, tab$transform[j])
      fit_loglik(fit, phi)
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
    uL <- from_walk(wL, tab$transform[j])
    valueL <- tab$a[j] + tab$b[j] * uL  # in the prior's units
    if (fit$spec$classes[j] == "kappa") {
      k <- match(fit$vars[j], fit$vars[fit$spec$classes == "kappa"])
      lo <- fit$scale$xmin[fit$scale$p + k]
      reported <- lo + (fit$scale$xmax[fit$scale$p + k] - lo) * uL
    } else {
      reported <- valueL
    }
    out[[length(out) + 1L]] <- data.frame(
      var = fit$vars[j], class = fit$spec$classes[j], side = if (dir < 0) "lower" else "upper",
      cdf = u, median = stats::median(fit$Phi[, j]), dataValue = reported,
      suggestion = suggest_prior(fit, j, fam[j], valueL)
    )
  }
  if (length(out)) do.call(rbind, out) else empty
}

# A looser prior of the same kind that has `value` (the data's preferred
# value, in the prior's units) near its centre, as the text of an R call; NA
# when there is no obvious one.
suggest_prior <- function(fit, j, dist, value) {
  tab <- fit$spec$table
  cls <- fit$spec$classes[j]
  members <- which(fit$spec$classes == cls)
  k <- match(j, members)
  p1 <- tab$p1[members]
  p2 <- tab$p2[members]
  fams <- names(prior_families)[match(tab$family[members], prior_families)]
  init <- fit$priors[[cls]]$init %||% rep(NA_real_, length(members))
  new <- switch(dist,
    # prior median at the data's value, shape at most 1.1 (a heavy upper tail)
    inversegamma = {
      s <- min(tab$p1[j], 1.1)
      list(dist = "inversegamma", p1 = s, p2 = value * stats::qgamma(0.5, s), init = value)
    },
    gamma = {
      s <- min(tab$p1[j], 1.1)
      list(dist = "gamma", p1 = s, p2 = stats::qgamma(0.5, s) / value, init = value)
    },
    # same centre, the data's value within half a prior sd
    gaussian = list(dist = "gaussian", p1 = tab$p1[j],
                    p2 = max(tab$p2[j], 2 * abs(value - tab$p1[j])), init = value),
    lognormal = list(dist = "lognormal", p1 = log(value), p2 = max(tab$p2[j], 1), init = value),
    betashift = list(dist = "uniform", p1 = 1, p2 = 2, init = 1.5),
    NULL
  )
  if (is.null(new)) return(NA_character_)
  fams[k] <- new$dist
  p1[k] <- new$p1
  p2[k] <- new$p2
  init[k] <- new$init
  if (cls == "kappa") {
    # kappa's prior is given in calibrate(), in the calibration inputs' units
    if (new$dist != "gaussian") return(NA_character_)
    return(sprintf("calibrate(sim, field, kappaDist = %s, kappaP1 = %s, kappaP2 = %s, kappaInit = %s)",
                   r_vec(fams), r_vec(p1), r_vec(p2), r_vec(init)))
  }
  sprintf("set_hyperPriors(%sDist = %s, %sP1 = %s, %sP2 = %s, %sInit = %s)",
          cls, r_vec(fams), cls, r_vec(p1), cls, r_vec(p2), cls, r_vec(init))
}

# A vector as R code, numbers to two significant digits.
r_vec <- function(v) {
  txt <- if (is.character(v)) paste0("\"", v, "\"") else format_num(v)
  if (length(v) == 1L) txt else paste0("c(", paste(txt, collapse = ", "), ")")
}
format_num <- function(v) vapply(v, function(x) format(signif(x, 2), scientific = abs(x) < 1e-4 && x != 0),
                                 character(1))

# The convergence_messages() text for each conflict.
conflict_messages <- function(fit) {
  cf <- prior_conflicts(fit)
  vapply(seq_len(nrow(cf)), function(i) {
    r <- cf[i, ]
    j <- match(r$var, fit$vars)
    tab <- fit$spec$table
    dist <- names(prior_families)[match(tab$family[j], prior_families)]
    where <- if (r$side == "lower") "below" else "above"
    prob <- if (r$side == "lower") r$cdf else 1 - r$cdf
    head <- sprintf(
      "Prior-data conflict for %s: its posterior median, %s, sits in the far %s tail of its %s(%s, %s) prior (prior probability %s %s it), while the likelihood alone (the other parameters at the MAP draw) peaks near %s: the prior, not the data, sets %s.",
      r$var, format_num(r$median), r$side, dist, format_num(tab$p1[j]), format_num(tab$p2[j]),
      format(signif(prob, 1)), where, format_num(r$dataValue), r$var)
    tail_ <- if (is.na(r$suggestion)) {
      " Loosen or re-centre this prior and calibrate again."
    } else if (r$class == "kappa") {
      sprintf(" Loosen it, e.g. `%s`.", r$suggestion)
    } else {
      sprintf(" Loosen it, e.g. `hypers = %s`, and calibrate again.", r$suggestion)
    }
    paste0(head, tail_)
  }, character(1))
}
