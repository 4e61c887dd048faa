# The confounding check of convergence_messages(): the calibration
# parameters barely informed while the bias GP's variance is larger than the
# measurement error's, so the data cannot separate a change of the
# calibration from a bias.
#
# With a bias GP (any discrepancy model with one), a calibration parameter is
# flagged when its posterior is nearly what its prior says or spans most of
# the range the simulator design covers -- its central 95% covers at least
# `fbc_confound_cover` of the design's range, or its posterior sd is at
# least `fbc_confound_sd` of its prior's -- while the bias GP's variance
# exceeds the measurement error's (posterior medians of sigma2B and
# sigma2E; with several measurement-error groups, `output =` or `source =`,
# sigma2E1, sigma2E2, ..., that of the group where the ratio is largest):
# the data cannot separate the calibration from a bias (Kennedy and
# O'Hagan 2001; Brynjarsdottir and O'Hagan 2014). The finding is worded as
# that, not as "the bias carries the signal": with no bias in the data,
# sigma2B's prior alone can hold it above sigma2E. The message points to
# the comparison of discrepancy models by loo().

fbc_confound_cover <- 0.7
fbc_confound_sd <- 0.7

# The flagged calibration parameters: a data frame with the label, the
# share of the design's range the 95% interval covers, the ratio of the
# posterior to the prior sd, the ratio of sigma2B to sigma2E (medians; the
# largest over the measurement-error groups) and the sigma2E it is to
# (`noise`: "sigma2E", or "sigma2E2 (conc:B)"); NULL when nothing is
# flagged.
confounded_kappa <- function(x) {
  if (identical(x$model$discrepancy, "none")) return(NULL)
  Phi <- x$Phi
  noiseCols <- grep("^sigma2E[0-9]*$", colnames(Phi), value = TRUE)
  labels <- x$model$scale$noiseLabels
  # each group's bias variance: sigma2B, or with independent outputs its
  # output's sigma2B[output] (the group's label starts with the output)
  biasCols <- if ("sigma2B" %in% colnames(Phi)) rep("sigma2B", length(noiseCols)) else
    sprintf("sigma2B[%s]", sub(":.*$", "", labels %||% ""))
  if (!all(biasCols %in% colnames(Phi)) || !length(noiseCols)) return(NULL)
  ratios <- vapply(seq_along(noiseCols), function(i) {
    stats::median(Phi[, biasCols[i]]) / stats::median(Phi[, noiseCols[i]])
  }, numeric(1))
  g <- which.max(ratios)
  if (!length(g) || !(ratios[g] > 1)) return(NULL)
  ratio <- unname(ratios[g])
  noise <- if (length(noiseCols) > 1L && length(labels) == length(noiseCols)) {
    sprintf("%s (%s)", noiseCols[g], labels[g])
  } else noiseCols[g]
  des <- kappa_design(x$model$scale)
  ps <- phi_spec(x)
  fam <- prior_family_name(ps$table$family)
  out <- NULL
  for (j in seq_len(x$model$scale$q)) {
    col <- which(ps$classes == "kappa")[j]
    if (fam[col] == "fixed") next
    k <- Phi[, col]
    rng <- des$hi[j] - des$lo[j]
    ci <- stats::quantile(k, c(0.025, 0.975), names = FALSE)
    cover <- (min(ci[2], des$hi[j]) - max(ci[1], des$lo[j])) / rng
    tab <- ps$table[col, ]
    v <- prior_quantile(stats::ppoints(2000), fam[col], tab$p1, tab$p2)
    sdRatio <- if (all(is.finite(v))) stats::sd(k) / stats::sd(des$lo[j] + rng * (v - tab$a) / tab$b) else NA_real_
    if (cover >= fbc_confound_cover || isTRUE(sdRatio >= fbc_confound_sd)) {
      out <- rbind(out, data.frame(label = des$label[j], lower = ci[1], upper = ci[2],
                                   cover = cover, sdRatio = sdRatio, biasRatio = ratio,
                                   noise = noise, stringsAsFactors = FALSE))
    }
  }
  out
}

confounding_messages <- function(x) {
  b <- confounded_kappa(x)
  if (is.null(b)) return(character())
  other <- setdiff(names(discrepancy_codes), x$model$discrepancy)
  fits <- paste(sprintf("`fit_%s <- calibrate(sim, field, discrepancy = \"%s\")`", other, other),
                collapse = " and ")
  cmp <- paste(c("loo::loo(fit)", sprintf("loo::loo(fit_%s)", other)), collapse = ", ")
  sprintf(paste(
    "%s is barely informed by the field data: its 95%% interval [%s, %s] covers %s of the simulator design's range%s, while the bias GP's variance sigma2B is %s times the measurement error's %s.",
    "Under this discrepancy model the data cannot separate a change of %s from a bias (Kennedy and O'Hagan 2001); a large sigma2B may come from its prior rather than from a bias in the data.",
    "Compare the discrepancy models, e.g. %s (with the same data and settings), by `loo::loo_compare(%s)` (see ?loo.fbc)."),
    b$label, fmt_num(b$lower), fmt_num(b$upper), fmt_share(pmin(b$cover, 1)),
    ifelse(is.na(b$sdRatio), "", sprintf(" and its sd is %s of its prior's", fmt_share(b$sdRatio))),
    format(signif(b$biasRatio, 2)), b$noise, b$label, fits, cmp)
}
