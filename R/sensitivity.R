#' Global sensitivity of the simulator and of the calibrated prediction
#'
#' Which inputs drive the output? `sensitivity()` gives first-order and total
#' Sobol indices of the simulator over its experimental and calibration
#' inputs, and of the calibrated prediction over the experimental inputs,
#' each as a posterior: one value per posterior draw, summarised by its
#' median and an interval, with the Monte Carlo error of the median.
#'
#' @section What is computed:
#' For each posterior draw of the parameters (the GP hyperparameters and
#' \eqn{\kappa}), the simulator's emulator has a conditional mean given the
#' simulator runs and the field data (the field data enter through
#' \eqn{\kappa} as they do in the model), a function of all \eqn{p + q}
#' inputs. Its Sobol variances under a product measure of the inputs
#' (uniform over the design's box by default) are computed in closed form
#' from one-dimensional integrals of the correlation against each input's
#' measure (Oakley and O'Hagan 2004): exact against a uniform measure for
#' the Gaussian correlation (error functions) and the Matern families
#' (exponentials times polynomials), and otherwise 64-node Gauss-Legendre
#' quadrature (the power exponential, or a density given in `inputs`), at a
#' cost of \eqn{O(N^2 (p + q))} per draw with \eqn{N} the runs plus the
#' distinct field inputs. The quadrature is accurate to a few \eqn{10^{-6}}
#' on the indices for the Gaussian and Matern families; the power exponential with
#' \eqn{\alpha < 2} has a cusp at each run, where it is accurate to about
#' \eqn{10^{-3}}.
#'
#' By default each draw's indices are those of a *conditional sample path*
#' of the emulator rather than of its mean, so that their spread carries the
#' emulator's own error given the parameters (Marrel et al. 2009) as well as
#' the uncertainty in the GP's hyperparameters and in \eqn{\kappa}: the
#' path's values at `paths` support points (a randomised Halton design over
#' the measure, fresh for every draw) are drawn jointly given the data, and
#' the path is the emulator's mean given the data and those values, one
#' more kernel expansion whose indices are again in closed form, with no
#' Monte Carlo error of their own. Between the support points the path is
#' its conditional mean, so the spread is slightly understated when `paths`
#' is small against the inputs' dimension (on Ishigami's function and Sobol's
#' g-function with 200 runs, 512 points widen the intervals by 7-9% over the
#' default 128, at five to eight times the cost). `paths = 0` gives the indices of
#' the emulator's posterior mean at each draw: they carry the parameters'
#' uncertainty only, and their intervals narrow faster than the emulator's
#' error shrinks (on Ishigami's function with 100 to 200 runs they cover the
#' true indices far less often than their level says).
#'
#' Where the expansion has more than 2,000 centres (runs, distinct field
#' inputs and support points; typical of the nearest-neighbour algebra) the
#' closed form's \eqn{N \times N} integrals give way to an estimator
#' (`estimator = "sampling"`, chosen by `"auto"`) at \eqn{O(N D (64 + (D + 2)
#' n))} per draw for `samples` = \eqn{n}: the mean \eqn{f_0} stays exact and
#' each first-order variance is the squared main effect integrated by the
#' input's 64 quadrature nodes (exact but for the quadrature), while the
#' variance and the total indices come from two independent samples of
#' \eqn{n} points of the measure (Jansen's estimator; Saltelli et al. 2010),
#' fresh for every draw (each draw's indices limited to \eqn{[0, 1]}). The
#' result's `sampling_sd` column gives each
#' index's sampling error for one draw (the median over the draws); it is
#' part of the intervals' spread. On the nearest-neighbour algebra the
#' emulator's mean is that of its approximation (\eqn{D_s^{-1} \approx U
#' U'} of the runs' conditionals), exact with every predecessor.
#'
#' An index that is exactly zero (an input without effect) lies on the
#' boundary: a path's first-order variance is positive, so no equal-tailed
#' interval holds zero; read a small upper limit as "no effect".
#'
#' The calibrated prediction's indices are those of the mean field response
#' \eqn{E[\eta(x, \kappa) + \delta(x)]} at each draw over the experimental
#' inputs alone (under the same measure as above), \eqn{\kappa} integrated
#' over its posterior by the draws. At a draw that mean is two kernel
#' expansions, the emulator's at the draw's \eqn{\kappa} and the bias's over
#' the distinct field inputs, so its indices are in closed form too (the
#' cross terms of the two families by the quadrature nodes), with no Monte
#' Carlo error of their own. The predictive
#' variance averaged over `points` randomised quasi-random points of the
#' experimental inputs' measure is split into shares (summing to
#' one): the measurement error (`noise`); the emulator and the bias, which
#' split the conditional variance of the mean response by their covariances
#' with it (\eqn{Var(\eta + \delta) = Cov(\eta, \eta + \delta) + Cov(\delta,
#' \eta + \delta)}); and the spread of the conditional mean over the draws
#' (`kappa`: the uncertainty in \eqn{\kappa}, with that of the GP parameters
#' it comes with). Their sum is the squared standard error [predict()]
#' gives, averaged over those points (`points` in the result).
#'
#' @param fit An `fbc` object from [calibrate()], with an emulated simulator,
#'   one output and numeric inputs (for the prediction's part, one field data
#'   set).
#' @param inputs Input distributions other than uniform over the design's
#'   box: a named list whose names are inputs of the simulator and whose
#'   elements are either a range `c(lower, upper)` (uniform, in the input's
#'   units) or a density function of the input in its units (say kappa's
#'   prior), integrated over the design's range of that input by quadrature.
#' @param ndraws The number of posterior draws used (evenly spaced over all
#'   retained draws, as in [predict()]); `NULL` uses them all. Each draw
#'   brings its own sample path, so that the draws are nearly independent:
#'   with 200 the Monte Carlo error of a median is about 3% of a 90%
#'   interval's width (independent draws of a normal posterior).
#' @param level Probability of the intervals.
#' @param paths Support points of each draw's conditional sample path of the
#'   emulator (the closed form's cost grows as the square of the runs plus
#'   `paths`); `0` gives the indices of the emulator's mean at each draw.
#' @param prediction If `TRUE`, also the calibrated prediction's indices and
#'   the variance shares (the slower part).
#' @param points Quasi-random points of the experimental inputs over which
#'   the predictive variance's shares are averaged (three conditional
#'   variances per point and draw).
#' @param estimator `"closed"` (the closed form), `"sampling"` (the total
#'   variance and the total indices by sampling, see Details) or `"auto"`:
#'   the closed form up to 2,000 centres.
#' @param samples Points of each of the sampling estimator's two samples per
#'   draw (it evaluates the mean at `(D + 2) * samples` points per draw).
#' @param ... Not used: an argument given here is an error.
#' @return An object of class `fbc_sensitivity`: `simulator` and
#'   `prediction` (data frames with one row per input and index: `median`,
#'   `lower`, `upper`, `mcse` the Monte Carlo standard error of the median,
#'   and with the sampling estimator `sampling_sd`),
#'   `shares` (the prediction's variance shares), `points` (the points the
#'   shares average over, in the inputs' units), `draws` (per-draw indices:
#'   arrays draws x inputs x index), `main` (main effects: for each input a
#'   data frame of the conditional mean over a grid, in the response's units,
#'   with its median and interval over the draws) and `settings`.
#'   `as.data.frame()` stacks the indices; `plot()` shows the main effects or
#'   the indices.
#' @references Oakley, J. E. and O'Hagan, A. (2004). Probabilistic
#'   sensitivity analysis of complex models: a Bayesian approach. JRSS B 66,
#'   751-769. Marrel, A., Iooss, B., Laurent, B. and Roustant, O. (2009).
#'   Calculations of Sobol indices for the Gaussian process metamodel.
#'   Reliability Engineering & System Safety 94, 742-751. Saltelli, A. et al.
#'   (2010). Variance based sensitivity analysis of model output. Computer
#'   Physics Communications 181, 259-270.
#' @export
#' @examples
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, nChains = 1)
#' s <- sensitivity(fit, ndraws = 100)
#' s
#' as.data.frame(s)
sensitivity <- function(fit, inputs = NULL, ndraws = 200, level = 0.9, paths = 128,
                        prediction = TRUE, points = 128,
                        estimator = c("auto", "closed", "sampling"), samples = 1024, ...) {
  check_dots_empty(..., fn = sensitivity, name = "sensitivity")
  fit <- check_fbc(fit, "fit")
  check_sensitivity_fit(fit)
  if (!is.null(ndraws)) ndraws <- check_count(ndraws, "ndraws", min = 2)
  check_level(level)
  paths <- check_count(paths, "paths", min = 0)
  if (paths == 1L) cli::cli_abort("{.arg paths} must be 0 (no sample paths) or at least 2, not 1.")
  check_flag(prediction, "prediction")
  points <- check_count(points, "points", min = 2)
  alg <- fit$model$algebra
  if (paths > 0L && identical(alg$name, "kronecker") && isTRUE(alg$missing > 0L)) {
    cli::cli_abort(c(
      "Sample paths ({.arg paths} > 0) need a complete product design on the Kronecker algebra.",
      x = "{.arg fit}'s runs leave {alg$missing} cell{?s} of the product design out.",
      i = "Use {.code paths = 0} (the indices of the emulator's mean at each draw), or refit with {.code algebra = \"dense\"}."
    ))
  }
  estimator <- match_choice(estimator, c("auto", "closed", "sampling"), "estimator")
  samples <- check_count(samples, "samples", min = 2)
  if (prediction && !is.null(fit$model$spec$model$source)) {
    cli::cli_abort(c(
      "The calibrated prediction's part needs a fit with one field data set.",
      x = "{.arg fit} has a bias per field data set; use {.code prediction = FALSE}."
    ))
  }
  sc <- fit$model$scale
  p <- sc$p
  q <- sc$q
  D <- p + q
  nm <- sim_input_names(sc, D)
  measure <- sensitivity_measure(inputs, sc, nm)
  rows <- draw_rows(nrow(fit$Phi), ndraws)
  phis <- sampler_draws(fit, rows)
  M <- length(rows)

  estimator <- sensitivity_estimator(fit, paths, estimator)
  sampled <- estimator == "sampling"
  G <- 25L
  grid <- matrix(seq(0, 1, length.out = G), G, D)
  for (k in seq_len(D)) grid[, k] <- seq(measure$lower[k], measure$upper[k], length.out = G)
  res <- at_draws(fit, .fbc_sobol_c, phis, exact = measure$exact, lower = measure$lower,
                  upper = measure$upper, nodes = measure$nodes, weights = measure$weights,
                  grid = grid, support = support_points(paths, M, measure),
                  samples = sobol_samples(if (sampled) samples else 0L, M, measure))
  sim_draws <- index_draws(res, M, nm, sampled)
  role <- rep(c("experimental", "calibration"), c(p, q))
  out <- list(
    simulator = index_table(sim_draws, role, level, if (sampled) sampling_sd(res, M, nm)),
    prediction = NULL, shares = NULL,
    draws = list(simulator = sim_draws),
    main = list(simulator = main_effects(res$main, grid, sc, nm, G, level))
  )
  if (prediction) {
    pr <- prediction_sensitivity(fit, phis, points, level, measure, if (sampled) samples else 0L)
    out$prediction <- pr$table
    out$shares <- pr$shares
    out$draws$prediction <- pr$draws
    out$main$prediction <- pr$main
    out$points <- pr$points
  }
  out$settings <- list(ndraws = M, draw_rows = rows, level = level, inputs = nm, role = role,
                       measure = measure$label, paths = paths, points = points,
                       estimator = estimator, samples = if (sampled) samples else NA_integer_,
                       kernel = kernels$label[match(fit$model$spec$model$kernS, kernels$code)])
  class(out) <- "fbc_sensitivity"
  out
}

# The fits whose simulator's mean is one kernel expansion.
check_sensitivity_fit <- function(fit, call = parent.frame()) {
  mdl <- fit$model$spec$model
  why <- c(
    if (!is.null(mdl$simulator)) "its simulator is an R function (there is no emulator)",
    if (!is.null(mdl$outputs)) "it has several independent outputs",
    if (!is.null(mdl$levels)) "it has categorical inputs"
  )
  if (length(why)) {
    cli::cli_abort(c(
      "{.fn sensitivity} needs a fit with one emulated output and numeric inputs.",
      x = "{.arg fit} cannot be used: {why[1]}."
    ), call = call)
  }
  invisible(fit)
}

check_level <- function(level, arg = "level", call = parent.frame()) {
  if (!is.numeric(level) || length(level) != 1L || is.na(level) || level <= 0 || level >= 1) {
    cli::cli_abort("{.arg {arg}} must be a single number strictly between 0 and 1.", call = call)
  }
  invisible(level)
}

# The closed form's integrals are N x N per input, N the centres of the
# expansion (runs, distinct field rows, support points): above this many the
# indices are estimated by sampling (`estimator = "auto"`).
fbc_sensitivity_closed_max <- 2000L

# The estimator `"auto"` stands for: the closed form unless the expansion's
# centres (the runs, or unique inputs with the simulator's noise, the
# distinct field rows and the support points) are more than the maximum.
sensitivity_estimator <- function(fit, paths, estimator) {
  if (estimator != "auto") return(estimator)
  d <- fit$model$data
  N <- nrow(d$Xs) + nrow(unique(d$Xf)) + paths
  if (N > fbc_sensitivity_closed_max) "sampling" else "closed"
}

# Per draw, two independent samples A and B of n points from the measure
# (2 n rows per draw, stacked: A then B); n = 0: none (the closed form).
sobol_samples <- function(n, M, measure) {
  D <- length(measure$lower)
  if (n == 0L) return(matrix(0, 0, D))
  to_measure(matrix(stats::runif(2L * n * M * D), 2L * n * M, D), measure)
}

# The draws' indices (draws x inputs x index) from the compiled variances;
# sampled ones limited to [0, 1], where every index lies.
index_draws <- function(res, M, nm, sampled = FALSE) {
  V <- pmax(as.vector(res$V), .Machine$double.xmin)
  D <- length(nm)
  S <- array(c(t(res$V1) / V, t(res$VT) / V), c(M, D, 2), list(NULL, nm, c("first", "total")))
  if (sampled) S[] <- pmin(pmax(S, 0), 1)
  S
}

# Each draw's sampling error of its indices (draws x inputs x index).
sampling_sd <- function(res, M, nm) {
  array(c(t(res$sd1), t(res$sdT)), c(M, length(nm), 2), list(NULL, nm, c("first", "total")))
}

# The first n points of the Halton sequence in d dimensions (radical inverses
# in the first d primes), skipping the point at the origin.
halton <- function(n, d) {
  primes <- c(2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53, 59, 61, 67, 71, 73,
              79, 83, 89, 97, 101, 103, 107, 109, 113)
  if (d > length(primes)) {
    primes <- c(primes, Filter(function(k) all(k %% 2:floor(sqrt(k)) != 0), 114:(20 * d)))
  }
  i <- seq_len(n)
  vapply(primes[seq_len(d)], function(b) {
    x <- numeric(n)
    f <- 1 / b
    k <- i
    while (any(k > 0)) {
      x <- x + f * (k %% b)
      k <- k %/% b
      f <- f / b
    }
    x
  }, numeric(n))
}

# Per draw, N support points of the sample path (stacked, N rows per draw):
# the Halton points shifted by a uniform draw modulo one (a randomised
# quasi-Monte Carlo design, fresh for every draw), mapped to each input's
# measure (uniform on its range, or the inverse of the quadrature's
# distribution function for a density). N = 0: none (the mean's indices).
support_points <- function(N, M, measure) {
  D <- length(measure$lower)
  if (N == 0L) return(matrix(0, 0, D))
  H <- halton(N, D)
  out <- matrix(0, N * M, D)
  for (d in seq_len(M)) {
    rows <- (d - 1L) * N + seq_len(N)
    out[rows, ] <- (H + rep(stats::runif(D), each = N)) %% 1
  }
  to_measure(out, measure)
}

# Points u of the unit cube mapped to each input's measure: uniform on its
# range, or the inverse of the quadrature's distribution function for a
# density.
to_measure <- function(u, measure) {
  for (k in seq_len(ncol(u))) {
    u[, k] <- if (measure$exact[k]) {
      measure$lower[k] + (measure$upper[k] - measure$lower[k]) * u[, k]
    } else {
      cw <- cumsum(measure$weights[, k])
      stats::approx(c(0, cw), c(measure$lower[k], measure$nodes[, k]), u[, k], rule = 2,
                    ties = "ordered")$y
    }
  }
  u
}

# Gauss-Legendre nodes and weights on [0, 1] (Golub-Welsch), weights summing to one.
gauss_legendre01 <- function(n) {
  if (n == 1L) return(list(x = 0.5, w = 1))
  i <- seq_len(n - 1L)
  b <- i / sqrt(4 * i^2 - 1)
  J <- matrix(0, n, n)
  J[cbind(i, i + 1L)] <- b
  J[cbind(i + 1L, i)] <- b
  e <- eigen(J, symmetric = TRUE)
  o <- order(e$values)
  list(x = (e$values[o] + 1) / 2, w = e$vectors[1, o]^2)
}

# Nodes per input of the simulator's measure.
fbc_sensitivity_quadrature <- 64L

# Each input's measure in scaled units: uniform on [lower, upper] (exact:
# closed form where the family allows) or quadrature nodes and weights.
sensitivity_measure <- function(inputs, sc, nm, call = parent.frame()) {
  D <- length(nm)
  Q <- fbc_sensitivity_quadrature
  gl <- gauss_legendre01(Q)
  lower <- rep(0, D)
  upper <- rep(1, D)
  exact <- rep(TRUE, D)
  dens <- vector("list", D)
  label <- rep("uniform over the design's range", D)
  if (!is.null(inputs)) {
    if (!is.list(inputs) || is.null(names(inputs)) || any(!nzchar(names(inputs)))) {
      cli::cli_abort("{.arg inputs} must be a named list (names: inputs of the simulator).",
                     call = call)
    }
    bad <- setdiff(names(inputs), nm)
    if (length(bad)) {
      cli::cli_abort(c("{.arg inputs} names {?an input/inputs} the simulator does not have: {.val {bad}}.",
                       i = "Its inputs are {.val {nm}}."), call = call)
    }
    for (v in names(inputs)) {
      k <- match(v, nm)
      el <- inputs[[v]]
      lo <- sc$xmin[k]
      wd <- sc$xmax[k] - sc$xmin[k]
      if (is.function(el)) {
        dens[[k]] <- el
        exact[k] <- FALSE
        label[k] <- "the density given, over the design's range"
      } else if (is.numeric(el) && length(el) == 2L && all(is.finite(el)) && el[1] < el[2]) {
        lower[k] <- (el[1] - lo) / wd
        upper[k] <- (el[2] - lo) / wd
        label[k] <- sprintf("uniform on [%s, %s]", format(el[1], digits = 4), format(el[2], digits = 4))
      } else {
        cli::cli_abort(c(
          "{.arg inputs${v}} must be a range {.code c(lower, upper)} with lower < upper, or a density function.",
          x = "It is {.obj_type_friendly {el}}."
        ), call = call)
      }
    }
  }
  nodes <- weights <- matrix(0, Q, D)
  for (k in seq_len(D)) {
    nodes[, k] <- lower[k] + (upper[k] - lower[k]) * gl$x
    w <- gl$w
    if (!is.null(dens[[k]])) {
      f <- dens[[k]](sc$xmin[k] + (sc$xmax[k] - sc$xmin[k]) * nodes[, k])
      if (!is.numeric(f) || length(f) != Q || any(!is.finite(f)) || any(f < 0) || sum(f) <= 0) {
        cli::cli_abort("{.arg inputs${nm[k]}} must return finite, non-negative densities, not all zero, on the design's range.",
                       call = call)
      }
      w <- w * f
    }
    weights[, k] <- w / sum(w)
  }
  list(lower = lower, upper = upper, exact = exact, nodes = nodes, weights = weights,
       label = stats::setNames(label, nm))
}

# Median, interval and the Monte Carlo error of the median of each input's
# indices (draws x inputs x index).
index_table <- function(draws, role, level, sampling = NULL) {
  nm <- dimnames(draws)[[2]]
  a <- (1 - level) / 2
  rows <- lapply(dimnames(draws)[[3]], function(ix) {
    x <- draws[, , ix, drop = FALSE]
    dim(x) <- dim(x)[1:2]
    data.frame(
      input = nm, role = role, index = ix,
      median = apply(x, 2, stats::median),
      lower = apply(x, 2, stats::quantile, probs = a, names = FALSE),
      upper = apply(x, 2, stats::quantile, probs = 1 - a, names = FALSE),
      # draws all equal (parameters fixed): no Monte Carlo error
      mcse = apply(x, 2, function(v) if (all(v == v[1])) 0 else mcse_median_quiet(v)),
      stringsAsFactors = FALSE
    )
  })
  if (!is.null(sampling)) {
    # the sampling estimator's own error of one draw's index (its median
    # over the draws), already inside the interval's spread
    sd <- lapply(dimnames(draws)[[3]], function(ix) apply(sampling[, , ix, drop = FALSE], 2, stats::median))
    for (i in seq_along(rows)) rows[[i]]$sampling_sd <- sd[[i]]
  }
  out <- do.call(rbind, rows)
  rownames(out) <- NULL
  out
}

# posterior::mcse_median() without its note that independent draws' ESS is
# capped (each draw's sample path makes the draws nearly independent).
mcse_median_quiet <- function(v) {
  withCallingHandlers(posterior::mcse_median(v), warning = function(w) {
    if (grepl("ESS has been capped", conditionMessage(w), fixed = TRUE)) invokeRestart("muffleWarning")
  })
}

# Main effects (G grid values x inputs, stacked, per draw) as one data frame
# per input in the response's and the inputs' units.
main_effects <- function(main, grid, sc, nm, G, level) {
  a <- (1 - level) / 2
  lapply(stats::setNames(seq_along(nm), nm), function(k) {
    v <- y_mean(sc) + y_sd(sc) * main[(k - 1L) * G + seq_len(G), , drop = FALSE]
    data.frame(
      x = sc$xmin[k] + (sc$xmax[k] - sc$xmin[k]) * grid[, k],
      median = apply(v, 1, stats::median),
      lower = apply(v, 1, stats::quantile, probs = a, names = FALSE),
      upper = apply(v, 1, stats::quantile, probs = 1 - a, names = FALSE)
    )
  })
}

# The calibrated prediction over the experimental inputs: per draw the
# Sobol variances of the mean response zeta(x) = E[eta(x, kappa) + delta(x)
# | y] in closed form (two kernel expansions, the simulator's at the draw's
# kappa and the bias's: .fbc_sobol_pred_c), under the measure's first p
# inputs, and its main effects on a grid of G values per input; the shares
# of the predictive variance averaged over `points` randomised Halton
# points of the same measure (predict()'s conditional variances there).
prediction_sensitivity <- function(fit, phis, points, level, measure, samples = 0L) {
  sc <- fit$model$scale
  p <- sc$p
  M <- nrow(phis)
  ex <- seq_len(p)
  mp <- list(lower = measure$lower[ex], upper = measure$upper[ex], exact = measure$exact[ex],
             nodes = measure$nodes[, ex, drop = FALSE],
             weights = measure$weights[, ex, drop = FALSE])
  G <- 25L
  grid <- matrix(0, G, p)
  for (k in ex) grid[, k] <- seq(mp$lower[k], mp$upper[k], length.out = G)
  X <- support_points(points, 1L, mp)
  res <- at_draws(fit, .fbc_sobol_pred_c, phis, exact = mp$exact, lower = mp$lower,
                  upper = mp$upper, nodes = mp$nodes, weights = mp$weights, grid = grid,
                  share = X, samples = sobol_samples(samples, M, mp))
  nm <- sim_input_names(sc, p + sc$q)[ex]
  S <- index_draws(res, M, nm, samples > 0L)
  sd <- if (samples > 0L) sampling_sd(res, M, nm)
  # one input: both indices are one by definition
  if (p == 1L) {
    S[] <- 1
    if (!is.null(sd)) sd[] <- 0
  }
  # variance shares over the points: each draw's conditional variances and
  # the spread of the conditional means over the draws (predict()'s se^2)
  s2E <- phis[, fit$model$spec$model$offset[["sigma2E"]] + 1L]
  f <- res$mean
  spread <- if (M > 1L) rowSums((f - rowMeans(f))^2) / (M - 1L) else 0 * f[, 1]
  comp <- c(
    kappa = mean(spread),
    bias = mean(rowMeans((res$var + res$var_bias - res$var_sim) / 2)),
    emulator = mean(rowMeans((res$var + res$var_sim - res$var_bias) / 2)),
    noise = mean(s2E)
  )
  shares <- data.frame(source = names(comp), variance = y_sd(sc)^2 * comp,
                       share = comp / sum(comp), stringsAsFactors = FALSE)
  rownames(shares) <- NULL
  pts <- sweep(sweep(X, 2, sc$xmax[ex] - sc$xmin[ex], "*"), 2, sc$xmin[ex], "+")
  colnames(pts) <- nm
  list(table = index_table(S, rep("experimental", p), level, sd), shares = shares, draws = S,
       main = main_effects(res$main, grid, sc, nm, G, level), points = pts)
}

#' @export
print.fbc_sensitivity <- function(x, digits = 3, ...) {
  check_dots_empty(..., fn = print.fbc_sensitivity, name = "print", cls = "fbc_sensitivity",
                   action = "warn")
  s <- x$settings
  cat(sprintf("<fbc_sensitivity> Sobol indices from %d posterior draws (%s correlation), %g%% intervals\n",
              s$ndraws, s$kernel, 100 * s$level))
  cat("Simulator, over its inputs (", paste(sprintf("%s: %s", names(s$measure), s$measure),
                                           collapse = "; "), "):\n", sep = "")
  show <- function(tab) {
    tab$interval <- sprintf("[%s, %s]", formatC(tab$lower, digits, format = "f"),
                            formatC(tab$upper, digits, format = "f"))
    tab$median <- formatC(tab$median, digits, format = "f")
    tab$mcse <- formatC(tab$mcse, digits, format = "f")
    cols <- c("input", "index", "median", "interval", "mcse")
    if (!is.null(tab$sampling_sd)) {
      tab$sampling <- formatC(tab$sampling_sd, digits, format = "f")
      cols <- c(cols, "sampling")
    }
    print(tab[cols], row.names = FALSE)
  }
  show(x$simulator)
  if (!is.null(x$prediction)) {
    cat("Calibrated prediction, over the experimental inputs (kappa over its posterior):\n")
    show(x$prediction)
    cat(sprintf("Shares of the predictive variance over the experimental inputs (%d quasi-random points):\n",
                s$points))
    sh <- x$shares
    cat(paste(sprintf("  %s %s", format(sh$source), formatC(sh$share, digits, format = "f")),
              collapse = "\n"), "\n", sep = "")
  }
  cat("mcse: Monte Carlo standard error of the median over the draws.\n")
  if (identical(s$estimator, "sampling")) {
    cat(sprintf("sampling: one draw's sampling error (two samples of %d points per draw; inside the intervals).\n",
                s$samples))
  }
  invisible(x)
}

#' @export
as.data.frame.fbc_sensitivity <- function(x, row.names = NULL, optional = FALSE, ...) {
  out <- cbind(of = "simulator", x$simulator, stringsAsFactors = FALSE)
  if (!is.null(x$prediction)) {
    out <- rbind(out, cbind(of = "prediction", x$prediction, stringsAsFactors = FALSE))
  }
  rownames(out) <- row.names
  out
}

#' @export
plot.fbc_sensitivity <- function(x, what = c("main", "indices"), of = c("simulator", "prediction"),
                                 ...) {
  check_dots_empty(..., fn = plot.fbc_sensitivity, name = "plot", cls = "fbc_sensitivity")
  what <- match_choice(what, c("main", "indices"), "what")
  of <- match_choice(of, c("simulator", "prediction"), "of")
  if (of == "prediction" && is.null(x$prediction)) {
    cli::cli_abort("{.arg x} has no prediction part: call {.fn sensitivity} with {.code prediction = TRUE}.")
  }
  if (what == "main") {
    me <- x$main[[of]]
    df <- do.call(rbind, lapply(names(me), function(v) cbind(input = v, me[[v]])))
    df$input <- factor(df$input, names(me))
    ggplot2::ggplot(df, ggplot2::aes(x = .data$x, y = .data$median)) +
      ggplot2::geom_ribbon(ggplot2::aes(ymin = .data$lower, ymax = .data$upper), alpha = 0.3) +
      ggplot2::geom_line() +
      ggplot2::facet_wrap(~input, scales = "free_x") +
      ggplot2::labs(x = NULL, y = "conditional mean",
                    title = sprintf("Main effects of the %s", of))
  } else {
    tab <- x[[of]]
    tab$input <- factor(tab$input, unique(tab$input))
    ggplot2::ggplot(tab, ggplot2::aes(x = .data$input, y = .data$median, colour = .data$index)) +
      ggplot2::geom_pointrange(ggplot2::aes(ymin = .data$lower, ymax = .data$upper),
                               position = ggplot2::position_dodge(width = 0.4)) +
      ggplot2::coord_cartesian(ylim = c(0, 1)) +
      ggplot2::labs(x = NULL, y = "Sobol index", colour = NULL,
                    title = sprintf("Sobol indices of the %s", of))
  }
}
