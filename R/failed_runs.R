# Failed simulator runs: rows of `sim` whose response is NA, NaN or
# infinite. A run that fails says where the code fails, not what kappa is
# (the physical system does not fail with the code), so the calibration
# posterior is that of the successful runs; the failed inputs stay in the
# model (model$design$failed) and feed a model of where the simulator fails
# (failure_classifier(), predict(fit, type = "failure")).

# The response column of the user's `sim` as given (before any column is
# read): by name when both data sets carry usable names (response_column()),
# else the first.
raw_response_column <- function(sim, field, call = parent.frame()) {
  sn <- usable_names(sim)
  fn <- usable_names(field)
  if (is.null(sn) || is.null(fn) || anyDuplicated(sn) || anyDuplicated(fn)) return(1L)
  if (length(setdiff(fn, sn))) return(1L) # align_columns() will refuse it, naming the columns
  match(response_column(sn, fn, call = call), sn)
}

# Splits `sim` into its successful and failed runs. `failedRuns` is
# "setAside" (one message, the failed inputs kept) or "error" (the refusal
# of check_data_matrix()). Returns list(sim, failed): `failed` is NULL
# without failed runs, else list(runs = the failed rows' inputs as given,
# rows = their row numbers in `sim`, m = the number of runs given,
# classifier = failure_classifier()'s fit).
split_failed_runs <- function(sim, field, failedRuns, call = parent.frame()) {
  if (!(is.matrix(sim) || is.data.frame(sim)) || nrow(sim) < 1L || ncol(sim) < 2L) {
    return(list(sim = sim, failed = NULL))
  }
  j <- raw_response_column(sim, field, call = call)
  y <- if (is.data.frame(sim)) sim[[j]] else sim[, j]
  if (!is.numeric(y)) return(list(sim = sim, failed = NULL)) # check_data_matrix() refuses it
  bad <- !is.finite(y)
  if (!any(bad) || failedRuns == "error") return(list(sim = sim, failed = NULL))
  inputs <- sim[bad, -j, drop = FALSE]
  num <- if (is.data.frame(inputs)) vapply(inputs, is.numeric, logical(1)) else rep(TRUE, ncol(inputs))
  inNum <- as.matrix(inputs[, num, drop = FALSE])
  if (any(!is.finite(inNum))) {
    where <- which(!is.finite(inNum), arr.ind = TRUE)[1, ]
    cli::cli_abort(c(
      "{.arg sim} must not contain NA, NaN or infinite inputs.",
      x = "Row {which(bad)[where[1]]} is a failed run (its response is not finite) and its input {.val {colnames(inNum)[where[2]] %||% where[2]}} is not finite either.",
      i = "A failed run's inputs say where the simulator fails; give them, or drop the row."
    ), call = call)
  }
  ok <- sim[!bad, , drop = FALSE]
  if (sum(!bad) < 3L) {
    cli::cli_abort(c(
      "{.arg sim} needs at least 3 successful runs, and it has {sum(!bad)} (of {length(y)}).",
      i = "The other runs failed (NA, NaN or infinite response)."
    ), call = call)
  }
  classifier <- failure_classifier(sim[, -j, drop = FALSE], bad)
  inform_failed_runs(inputs, bad, classifier, call = call)
  list(sim = ok, failed = list(runs = inputs, rows = which(bad), m = length(y),
                               classifier = classifier))
}

# The one message of failed runs: how many, and where (the inputs' ranges
# among the failed runs beside those of all runs).
inform_failed_runs <- function(inputs, bad, classifier, call = parent.frame()) {
  nm <- colnames(inputs) %||% paste0("input ", seq_len(ncol(inputs)))
  where <- if (!is.null(classifier)) {
    X <- classifier$X
    lo <- apply(X[bad, , drop = FALSE], 2, min)
    hi <- apply(X[bad, , drop = FALSE], 2, max)
    # the inputs whose failed range is narrower than the design's, narrowest first
    share <- (hi - lo) / pmax(apply(X, 2, max) - apply(X, 2, min), .Machine$double.eps)
    o <- order(share)[share[order(share)] < 0.999]
    if (length(o)) {
      o <- utils::head(o, 3L)
      paste0("They lie at ", paste0(colnames(X)[o], " in [", signif(lo[o], 3), ", ",
                                    signif(hi[o], 3), "]", collapse = ", "),
             " (the runs span ", paste0("[", signif(apply(X[, o, drop = FALSE], 2, min), 3), ", ",
                                         signif(apply(X[, o, drop = FALSE], 2, max), 3), "]",
                                         collapse = ", "), ").")
    } else "They are spread over the whole design."
  }
  cli::cli_inform(class = "fbc_failed_runs", c(
    "{sum(bad)} of the {length(bad)} simulator runs failed (NA, NaN or infinite response) and {?is/are} set aside: the calibration uses the other {sum(!bad)}.",
    i = if (!is.null(where)) where,
    i = "{.code predict(fit, newdata, type = \"failure\")} gives the probability that a run fails; {.code failedRuns = \"error\"} refuses failed runs."
  ), call = call)
}

# ------------------------------------------------------------- classifier ----

# The failure classifier's prior median of the latent's variance s2 (see
# failure_classifier()).
fbc_failure_s2 <- 1000

# A Gaussian-process classifier of failure over the runs' numeric inputs
# (categorical ones are left out), fitted by the Laplace approximation with
# the logistic link (Rasmussen and Williams 2006, algorithms 3.1 and 3.2).
# The latent f ~ GP(0, s2 R + 10) with R the Gaussian correlation
# exp(-sum((x - x')^2 / l^2)) on inputs scaled to [0, 1]; the constant 10
# is a N(0, 10) prior on the latent mean, broad enough for any base rate of
# failure (with N(0, 1), regions far from failed runs kept p near 0.15-0.2
# on a design whose base rate was 0.15 outside a disc of failures). l and s2 are plug-in values: the maximum of
# the Laplace marginal likelihood times weak log-normal priors
# (log l ~ N(log 0.3, 1), log s2 ~ N(log fbc_failure_s2, 1), which keep a
# class that separates cleanly from sending s2 to infinity). A run of a
# deterministic code that failed fails again: the labels are not noisy, so
# the latent's scale is large (the logistic of a latent with sd about 30 is
# nearly the step of its sign) and the probability is that of the latent's
# mode, which interpolates the labels. Averaging the logistic over the
# Laplace variance instead (the probit approximation) pulls every
# probability of a cleanly separated class toward 1/2, and the design
# step kept proposing inputs beside failed ones (bench/failed-runs.R: 49-53%
# of the picks failed, against 23% so, 88% without the failure model and 0
# with the true failure region). Plug-in values serve here
# because the classifier does not enter kappa's posterior: it only says
# where runs fail. Above 1,000 runs the classifier is fitted to every
# failed run and a random 1,000 minus those of the successful ones,
# reweighting nothing (said in ?calibrate). Returns NULL when no input is
# numeric.
# The fit (its optimisation costs seconds on a few hundred runs, most of a
# short calibration's CPU) is made when a probability is first asked for
# (failure_probability(): predict(type = "failure"), its plot,
# propose_runs()), not by calibrate(): the classifier is an environment
# that holds the runs (X, y_all, named: what its users read) and the
# subsample, drawn here so that calibrate()'s random numbers are the same
# whether or not the classifier is ever fitted, and receives the fitted
# values (fit_failure_classifier()) the first time they are needed; every
# copy of the fit shares them.
failure_classifier <- function(inputs, failed, max_runs = 1000L) {
  num <- if (is.data.frame(inputs)) vapply(inputs, is.numeric, logical(1)) else rep(TRUE, ncol(inputs))
  if (!any(num)) return(NULL)
  X <- as.matrix(inputs[, num, drop = FALSE])
  storage.mode(X) <- "double"
  # (unnamed runs: inputs by position, labelled by their column of sim)
  named <- !is.null(usable_names(X))
  if (!named) colnames(X) <- paste0("input ", which(num) + 1L)
  keep <- seq_len(nrow(X))
  if (nrow(X) > max_runs) {
    ok <- which(!failed)
    keep <- sort(c(which(failed), ok[sample.int(length(ok), max(max_runs - sum(failed), 0L))]))
  }
  cl <- new.env(parent = emptyenv())
  cl$X <- X
  cl$y_all <- as.numeric(failed)
  cl$named <- named
  cl$keep <- keep
  cl$subsample <- length(keep) < nrow(X)
  cl$fitted <- FALSE
  class(cl) <- "fbc_failure_classifier"
  cl
}

# The classifier's plug-in fit (see failure_classifier()), into `cl` once
# (a list: a classifier of a fit saved before the fit was made on first
# use, fitted already).
fit_failure_classifier <- function(cl) {
  if (!is.environment(cl) || isTRUE(cl$fitted)) return(invisible(cl))
  X <- cl$X
  lower <- apply(X, 2, min)
  range <- pmax(apply(X, 2, max) - lower, .Machine$double.eps)
  Z <- sweep(sweep(X, 2, lower), 2, range, "/")[cl$keep, , drop = FALSE]
  y <- cl$y_all[cl$keep]
  d <- ncol(Z)
  # -(log Laplace evidence + log prior) and its gradient in par = (log l,
  # log s2), both from one mode at each par (optim asks for them apart)
  last <- NULL
  at <- function(par) {
    if (!identical(last$par, par)) {
      ev <- laplace_evidence(Z, y, exp(par[seq_len(d)]), exp(par[d + 1L]))
      mu <- c(rep(log(0.3), d), log(fbc_failure_s2))
      last <<- list(par = par, value = -(ev$logZ + sum(stats::dnorm(par, mu, 1, log = TRUE))),
                    grad = -(ev$grad - (par - mu)))
    }
    last
  }
  start <- c(rep(log(0.3), d), log(fbc_failure_s2))
  opt <- stats::optim(start, function(par) at(par)$value, function(par) at(par)$grad,
                      method = "L-BFGS-B", lower = c(rep(log(0.02), d), log(0.01)),
                      upper = c(rep(log(10), d), log(1e6)))
  ell <- exp(opt$par[seq_len(d)])
  s2 <- exp(opt$par[d + 1L])
  mode <- laplace_mode(Z, y, ell, s2)
  cl$lower <- lower; cl$range <- range; cl$Z <- Z; cl$y <- y; cl$ell <- ell; cl$s2 <- s2
  cl$f <- mode$f; cl$grad <- y - stats::plogis(mode$f)
  cl$fitted <- TRUE
  invisible(cl)
}

# The latent covariance of the classifier between rows of A and B.
failure_kernel <- function(A, B, ell, s2) {
  D <- 0
  for (k in seq_len(ncol(A))) D <- D + outer(A[, k], B[, k], "-")^2 / ell[k]^2
  s2 * exp(-D) + 10
}

# The mode of p(f | y) by Newton's method (algorithm 3.1) and the Laplace
# approximation of log p(y).
laplace_mode <- function(Z, y, ell, s2, tol = 1e-8, maxit = 100L) {
  K <- failure_kernel(Z, Z, ell, s2)
  n <- length(y)
  f <- numeric(n)
  old <- -Inf
  for (it in seq_len(maxit)) {
    pr <- stats::plogis(f)
    W <- pr * (1 - pr)
    sW <- sqrt(W)
    L <- chol(diag(n) + outer(sW, sW) * K)
    b <- W * f + (y - pr)
    a <- b - sW * backsolve(L, forwardsolve(t(L), sW * (K %*% b)))
    f <- drop(K %*% a)
    val <- -0.5 * sum(a * f) + sum(y * f - log1p(exp(f)))
    if (abs(val - old) < tol) break
    old <- val
  }
  pr <- stats::plogis(f)
  sW <- sqrt(pr * (1 - pr))
  L <- chol(diag(n) + outer(sW, sW) * K)
  list(f = f, L = L, sW = sW,
       logZ = -0.5 * sum(a * f) + sum(y * f - log1p(exp(f))) - sum(log(diag(L))))
}

# The Laplace evidence log q(y | l, s2) (laplace_mode()) and its gradient
# in (log l, log s2) (Rasmussen and Williams 2006, algorithm 5.1; through
# W = -d^2 log p, d log q / d f_i = +1/2 [(K^-1 + W)^-1]_ii d^3 log p(y_i | f_i)
# / d f_i^3, the sign checked against a difference quotient in the tests):
# with R = (W^-1 + K)^-1 and dK_j = dK / d par_j,
#   explicit_j = a' dK_j a / 2 - tr(R dK_j) / 2,  a = K^-1 f,
#   implicit_j = s2' (I - K R) dK_j (y - logistic(f)),
#   s2_i = [K - K W^1/2 B^-1 W^1/2 K]_ii d3_i / 2.
# O(n^3) once and O(n^2) per parameter, instead of a mode per parameter
# for a difference quotient.
laplace_evidence <- function(Z, y, ell, s2) {
  md <- laplace_mode(Z, y, ell, s2)
  d <- ncol(Z)
  Dk <- lapply(seq_len(d), function(k) outer(Z[, k], Z[, k], "-")^2 / ell[k]^2)
  E <- s2 * exp(-Reduce(`+`, Dk))
  K <- E + 10
  pr <- stats::plogis(md$f)
  a <- y - pr # = K^-1 f at the mode
  sW <- md$sW
  R <- sW * t(sW * chol2inv(md$L))
  C <- forwardsolve(t(md$L), sW * K)
  s2v <- 0.5 * (diag(K) - colSums(C^2)) * (-pr * (1 - pr) * (1 - 2 * pr))
  grad <- vapply(seq_len(d + 1L), function(j) {
    dK <- if (j <= d) 2 * E * Dk[[j]] else E
    b <- drop(dK %*% a)
    0.5 * sum(a * b) - 0.5 * sum(R * dK) + sum(s2v * (b - drop(K %*% (R %*% b))))
  }, numeric(1))
  list(logZ = md$logZ, grad = grad)
}

# The probability of failure at the rows of X (inputs on their own scale,
# the classifier's columns): the logistic of the latent's mode there,
# E(f* | f-hat) = k*' (y - logistic(f-hat)) (algorithm 3.2's mean; see
# failure_classifier() for why not its average over the variance).
failure_probability <- function(cl, X) {
  fit_failure_classifier(cl)
  Z <- sweep(sweep(X, 2, cl$lower), 2, cl$range, "/")
  Ks <- failure_kernel(cl$Z, Z, cl$ell, cl$s2)
  stats::plogis(drop(crossprod(Ks, cl$grad)))
}

# predict(fit, newdata, type = "failure"): newdata holds the runs' inputs
# (experimental and calibration; the response may be there too), matched
# by name when both carry names, else by position in sim's order without
# the response.
predict_failure <- function(object, newdata, call = parent.frame()) {
  failed <- object$model$design$failed
  if (is.null(failed)) {
    cli::cli_abort(c(
      "{.code type = \"failure\"} needs failed runs, and none of this fit's simulator runs failed.",
      i = "A failed run is a row of {.arg sim} whose response is NA, NaN or infinite."
    ), call = call)
  }
  cl <- failed$classifier
  if (is.null(cl)) {
    cli::cli_abort("{.code type = \"failure\"} needs a numeric input, and every input of {.arg sim} is categorical.", call = call)
  }
  if (missing(newdata) || is.null(newdata)) newdata <- cl$X
  X <- newdata
  if (is.data.frame(X) || is.matrix(X)) {
    nm <- usable_names(X)
    need <- colnames(cl$X)
    if (isTRUE(cl$named) && !is.null(nm) && all(need %in% nm)) {
      X <- X[, need, drop = FALSE]
    } else if (ncol(X) != length(need)) {
      cli::cli_abort(c(
        "{.arg newdata} must have the simulator's numeric inputs {.val {need}}.",
        x = "It has {ncol(X)} column{?s}{if (!is.null(nm)) paste0(': ', paste(nm, collapse = ', ')) else ''}."
      ), call = call)
    }
  } else {
    cli::cli_abort("{.arg newdata} must be a data frame or matrix, not {.obj_type_friendly {newdata}}.", call = call)
  }
  X <- as.matrix(X)
  storage.mode(X) <- "double"
  if (any(!is.finite(X))) {
    cli::cli_abort("{.arg newdata} must not contain NA, NaN or infinite values.", call = call)
  }
  failure_probability(cl, X)
}
