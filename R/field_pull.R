# An emulator bent by the field data. The joint model lets the field data
# move the emulator wherever the runs leave it room: at kappa's draws, the
# emulator's mean at the field inputs given the runs and the field data
# can sit several runs-only predictive sds from its mean given the runs
# alone, the emulator absorbing the simulator's misfit (Tuo and Wu's
# problem, a simulator wrong for every kappa: a mode of kappa where the
# field data pull the emulator 3.4 sd at the field inputs). The check, from
# the fit alone: at fbc_pull_draws of the draws, the pull at each field
# input x_i,
#   (E[eta(x_i, kappa) | ys, yf] - E[eta(x_i, kappa) | ys]) / sd[eta(x_i, kappa) | ys],
# with the draw's hyperparameters, its largest absolute value over the
# field inputs. The runs-only conditional is the same prediction with the
# field data made uninformative (sigma2E at 1e10 on the standardised
# scale). Flagged when the median over the draws exceeds fbc_pull_max:
# then the posterior rests on an emulator bent towards the field data, and
# more runs where kappa's draws lie are the remedy.
fbc_pull_draws <- 30L
fbc_pull_max <- 3

# The pull of each of the draws checked (largest over the field inputs),
# the draws' rows and kappa there; NULL for a simulator function (no
# emulator) or where the prediction cannot be made.
field_pull <- function(x) {
  if (!is.null(x$model$simulator) || !nrow(x$Phi)) return(NULL)
  rows <- unique(round(seq(1, nrow(x$Phi), length.out = min(fbc_pull_draws, nrow(x$Phi)))))
  phis <- sampler_draws(x, rows)
  noise <- which(x$model$spec$classes == "sigma2E")
  if (!length(noise)) return(NULL)
  runs <- phis
  runs[, noise] <- 1e10
  Xn <- x$model$data$Xf
  pred <- function(ph) at_draws(x, .fbc_predict, ph, Xnew = Xn, type = predict_type_codes[["simulator"]],
                                block = 500L, noise = integer(), source = integer())
  res <- tryCatch(list(joint = pred(phis), runs = pred(runs)), error = function(e) NULL)
  if (is.null(res)) return(NULL)
  z <- abs(res$joint$mean - res$runs$mean) / sqrt(pmax(res$runs$var, 1e-300))
  pull <- apply(z, 2, max)
  if (!all(is.finite(pull))) return(NULL)
  k <- grep("^kappa[0-9]+$", colnames(x$Phi), value = TRUE)
  list(pull = pull, rows = rows, kappa = x$Phi[rows, k, drop = FALSE])
}

# field_pull() of the fit, from its cache (as the prior-data conflict
# check: print(), summary() and convergence_messages() all ask).
cached_field_pull <- function(x) {
  cache <- attr(x, "cache", exact = TRUE)
  if (!is.environment(cache)) return(field_pull(x))
  key <- conflict_key(x)
  if (!identical(cache$pullKey, key)) {
    cache$pull <- field_pull(x)
    cache$pullKey <- key
  }
  cache$pull
}

# The message when the median pull exceeds fbc_pull_max.
field_pull_messages <- function(x) field_pull_text(cached_field_pull(x))
field_pull_text <- function(fp) {
  if (is.null(fp) || !(stats::median(fp$pull) > fbc_pull_max)) return(character())
  hi <- fp$pull > fbc_pull_max
  at <- vapply(colnames(fp$kappa), function(v) {
    r <- range(fp$kappa[hi, v])
    sprintf("%s %s to %s", v, fmt_num(r[1]), fmt_num(r[2]))
  }, "")
  sprintf(
    "The field data bend the emulator: at kappa's draws they pull its mean at the field inputs %s runs-only predictive sds from what the runs alone say (median over %d draws; above %g at %s of them). The posterior rests on an emulator fitted towards the field data, not on the simulator. Add simulator runs where kappa's draws lie (%s) and refit.",
    format(round(stats::median(fp$pull), 1), nsmall = 1), length(fp$pull), fbc_pull_max,
    fmt_share(mean(hi)), paste(at, collapse = "; "))
}
