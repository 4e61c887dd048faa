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
#' @section Categorical inputs and several outputs:
#' A categorical input has a discrete measure: uniform over its levels, or
#' the level probabilities given in `inputs`. Its one-dimensional integrals
#' are the probability-weighted sums over its levels of the level
#' correlation \eqn{C[l, a_j]} between each level and each centre's, and
#' its double integrals the double sums; the sampling estimator and the
#' sample paths' support points draw its levels. Its indices are ordinary
#' Sobol indices, and its main effect is the conditional mean at each level.
#'
#' With several outputs the output is not an input of the measure: the
#' indices, the shares and the main effects are given at each output (a
#' column `output`). With `outputs = "shared"` the output's level is held
#' at that output (the expansion's weights times the output's level
#' correlation \eqn{C[j, a_i]}, the bias's likewise); with
#' `"independent"` each output's own GPs are used. Each output's draws have
#' their own sample paths (through support points at that output), and the
#' noise share is that output's measurement error (its first group with
#' several field data sets); the prediction's part needs field data at
#' every output.
#'
#' @param fit An `fbc` object from [calibrate()], with an emulated simulator
#'   (for the prediction's part, one bias for all field data and field data
#'   at every output).
#' @param inputs Input distributions other than uniform over the design's
#'   box: a named list whose names are inputs of the simulator and whose
#'   elements are either a range `c(lower, upper)` (uniform, in the input's
#'   units) or a density function of the input in its units (say kappa's
#'   prior), integrated over the design's range of that input by quadrature;
#'   for a categorical input, its levels' probabilities (named by the
#'   levels, those left out 0, or one per level in order, summing to one).
#'   The output of a fit with several outputs is not among them.
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
#'   shares average over, in the inputs' units; a data frame with
#'   categorical inputs), `draws` (per-draw indices: arrays draws x inputs x
#'   index, x output with several outputs), `main` (main effects: for each
#'   input a data frame of the conditional mean over a grid, or at each level
#'   (`level`, numbered by `x`), in the response's units, with its median and
#'   interval over the draws) and `settings`. With several outputs the data
#'   frames have a column `output`. `as.data.frame()` stacks the indices;
#'   `plot()` shows the main effects or the indices (one row of panels per
#'   output; `output =` names those shown).
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
  rows <- draw_rows(nrow(fit$Phi), ndraws)
  targets <- sensitivity_targets(fit, sampler_draws(fit, rows))
  if (prediction) check_prediction_targets(targets)
  M <- length(rows)
  estimator <- sensitivity_estimator(fit, paths, estimator)
  sampled <- estimator == "sampling"
  ns <- if (sampled) samples else 0L
  measure0 <- sensitivity_measure(inputs, sc, targets[[1]]$model, targets[[1]]$output)
  # the shares' quasi-random points: drawn at the first output, the same at
  # every output
  share_u <- NULL
  parts <- vector("list", length(targets))
  for (i in seq_along(targets)) {
    tg <- targets[[i]]
    measure <- if (is.null(tg$output)) measure0 else sensitivity_measure(inputs, sc, tg$model, tg$output)
    parts[[i]] <- sensitivity_target(tg, sc, measure, paths, ns, level, prediction, points, share_u)
    share_u <- parts[[i]]$share_u
  }
  out <- combine_targets(parts, targets)
  out$settings <- list(ndraws = M, draw_rows = rows, level = level, inputs = measure0$names,
                       role = measure0$role, measure = measure0$label, paths = paths,
                       points = points, estimator = estimator,
                       samples = if (sampled) samples else NA_integer_,
                       kernel = kernels$label[match(fit$model$spec$model$kernS, kernels$code)],
                       outputs = if (!is.null(sc$output)) sc$output$levels,
                       outputs_model = if (!is.null(sc$output)) fit$model$options$outputs)
  class(out) <- "fbc_sensitivity"
  out
}

# The simulator's indices (and the prediction's) of one output, or of the
# only one: its data, compiled model and draws (`tg`), the measure of its
# inputs.
sensitivity_target <- function(tg, sc, measure, paths, ns, level, prediction, points, share_u) {
  D <- ncol(tg$data$Xs)
  M <- nrow(tg$phis)
  G <- 25L
  grid <- matrix(0, G, D)
  for (k in measure$cols + 1L) grid[, k] <- seq(measure$lower[k], measure$upper[k], length.out = G)
  res <- target_draws(tg, .fbc_sobol_c, exact = measure$exact, lower = measure$lower,
                      upper = measure$upper, nodes = measure$nodes, weights = measure$weights,
                      grid = grid, support = support_points(paths, M, measure),
                      samples = sobol_samples(ns, M, measure), cols = measure$cols,
                      probs = measure$probs)
  sim_draws <- index_draws(res, M, measure, ns > 0L)
  out <- list(
    simulator = index_table(sim_draws, measure$role, level,
                            if (ns > 0L) sampling_sd(res, M, measure)),
    draws = list(simulator = sim_draws),
    main = list(simulator = main_effects(res$main, grid, sc, measure, G, level, tg$out))
  )
  if (prediction) {
    pr <- prediction_sensitivity(tg, sc, level, measure, ns, points, share_u)
    out$share_u <- pr$share_u
    out$prediction <- pr$table
    out$shares <- pr$shares
    out$draws$prediction <- pr$draws
    out$main$prediction <- pr$main
    out$points <- pr$points
  }
  out
}

# `entry` at the draws of a target (at_draws() on its data and model).
target_draws <- function(tg, entry, ...) {
  d <- tg$data
  entry(Xf = d$Xf, yf = d$yf, Xs = d$Xs, ys = d$ys, phis = tg$phis, nugget = tg$nugget,
        model = tg$model, ...)
}

# The parts the indices are computed for: one without several outputs;
# with shared outputs the whole fit at each output (its level held there:
# `output`); with independent outputs each output's own GPs (its rows, its
# parameters' columns of the draws and its compiled model). Each with the
# column of its measurement-error variance (`s2E`, one-based in phis; NA
# for an output without field data) and its output's number (`out`).
sensitivity_targets <- function(fit, phis) {
  mc <- fit$model$spec$model
  d <- fit$model$data
  sc <- fit$model$scale
  base <- list(data = d[c("Xf", "yf", "Xs", "ys")], model = mc, phis = phis,
               nugget = fit$settings$nugget, out = NULL, output = NULL)
  noise <- if (is.null(mc$noise)) rep(1L, nrow(d$Xf)) else mc$noise
  if (is.null(sc$output)) {
    base$s2E <- mc$offset[["sigma2E"]] + 1L
    return(list(base))
  }
  K <- length(sc$output$levels)
  lapply(seq_len(K), function(o) {
    rf <- which(d$outF == o)
    g <- sort(unique(noise[rf]))
    tg <- base
    tg$out <- o
    tg$output <- sc$output$levels[o]
    if (!identical(fit$model$options$outputs, "independent")) {
      tg$s2E <- if (length(g)) mc$offset[["sigma2E"]] + g[1] else NA_integer_
      return(tg)
    }
    rs <- which(d$outS == o)
    sub <- output_model(mc, o, K, g, rf)
    tg$data <- list(Xf = d$Xf[rf, , drop = FALSE], yf = d$yf[rf],
                    Xs = d$Xs[rs, , drop = FALSE], ys = d$ys[rs])
    tg$model <- sub$model
    tg$phis <- phis[, sub$map, drop = FALSE]
    tg$s2E <- sub$model$offset[["sigma2E"]] + 1L
    tg
  })
}

# Output o's compiled model under independent outputs (as the compiled core
# builds each output's block, src/outputs.cpp): kappa shared, its own copy
# of every other class, its measurement-error groups `g` (of its field rows
# rf) among its own; `map` the columns of phi it takes.
output_model <- function(mc, o, K, g, rf) {
  sub <- mc
  sub$outputs <- NULL
  off <- mc$offset
  len <- mc$length
  map <- integer()
  at <- 0L
  for (cl in names(off)) {
    l <- if (cl == "sigma2E") length(g) else if (cl == "kappa") len[[cl]] else len[[cl]] %/% K
    idx <- if (cl == "sigma2E") off[[cl]] + g else if (cl == "kappa") off[[cl]] + seq_len(l) else
      off[[cl]] + (o - 1L) * l + seq_len(l)
    map <- c(map, idx)
    sub$offset[[cl]] <- at
    sub$length[[cl]] <- l
    at <- at + l
  }
  if (!is.null(mc$noise)) sub$noise <- match(mc$noise[rf], g)
  if (!is.null(mc$fieldRows)) {
    fr <- mc$fieldRows[rf]
    sub$fieldRows <- match(fr, unique(fr))
  }
  if (!is.null(mc$source)) sub$source <- mc$source[rf]
  list(model = sub[!vapply(sub, is.null, logical(1))], map = as.integer(map))
}

# The prediction's part at an output needs its field data (its noise).
check_prediction_targets <- function(targets, call = parent.frame()) {
  lacking <- vapply(targets, function(tg) is.na(tg$s2E), logical(1))
  if (any(lacking)) {
    none <- vapply(targets[lacking], `[[`, "", "output")
    cli::cli_abort(c(
      "The calibrated prediction's part needs field data at every output.",
      x = "{cli::qty(length(none))}Output{?s} {.val {none}} of {.arg fit} {?has/have} no field data.",
      i = "Use {.code prediction = FALSE} for the simulator's indices alone."
    ), call = call)
  }
  invisible(targets)
}

# The parts of every output stacked, with an `output` column (and the
# draws' arrays a fourth dimension, the output) when there are several.
combine_targets <- function(parts, targets) {
  if (length(parts) == 1L && is.null(targets[[1]]$output)) {
    p <- parts[[1]]
    return(list(simulator = p$simulator, prediction = p$prediction, shares = p$shares,
                draws = p$draws, main = p$main, points = p$points))
  }
  labs <- vapply(targets, `[[`, "", "output")
  stack <- function(what) {
    if (is.null(parts[[1]][[what]])) return(NULL)
    out <- do.call(rbind, Map(function(p, o) cbind(output = o, p[[what]], stringsAsFactors = FALSE),
                              parts, labs))
    rownames(out) <- NULL
    out
  }
  arr <- function(what) {
    if (is.null(parts[[1]]$draws[[what]])) return(NULL)
    a <- lapply(parts, function(p) p$draws[[what]])
    dn <- c(dimnames(a[[1]]), list(labs))
    array(unlist(a), c(dim(a[[1]]), length(a)), dn)
  }
  mains <- function(what) {
    if (is.null(parts[[1]]$main[[what]])) return(NULL)
    nm <- names(parts[[1]]$main[[what]])
    stats::setNames(lapply(nm, function(v) {
      out <- do.call(rbind, Map(function(p, o) cbind(output = o, p$main[[what]][[v]],
                                                     stringsAsFactors = FALSE), parts, labs))
      rownames(out) <- NULL
      out
    }), nm)
  }
  list(simulator = stack("simulator"), prediction = stack("prediction"), shares = stack("shares"),
       draws = Filter(Negate(is.null), list(simulator = arr("simulator"), prediction = arr("prediction"))),
       main = Filter(Negate(is.null), list(simulator = mains("simulator"), prediction = mains("prediction"))),
       points = parts[[1]]$points)
}

# The fits whose simulator's mean is one kernel expansion (per output).
check_sensitivity_fit <- function(fit, call = parent.frame()) {
  mdl <- fit$model$spec$model
  why <- c(
    if (!is.null(mdl$simulator)) "its simulator is an R function (there is no emulator)",
    if (!is.null(mdl$outputs) && !is.null(mdl$replicates))
      "its independent outputs have the simulator's own noise (replicate runs)"
  )
  if (length(why)) {
    cli::cli_abort(c(
      "{.fn sensitivity} needs a fit with an emulated simulator.",
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
  if (n == 0L) return(matrix(0, 0, measure$ncol))
  to_measure(matrix(stats::runif(2L * n * M * measure$nd), 2L * n * M, measure$nd), measure)
}

# The draws' indices (draws x inputs x index) from the compiled variances
# (one row per input of the measure, numeric ones first), in the inputs'
# order, an output held at its level left out; sampled ones limited to
# [0, 1], where every index lies.
index_draws <- function(res, M, measure, sampled = FALSE) {
  V <- pmax(as.vector(res$V), .Machine$double.xmin)
  nd <- length(measure$dims)
  S <- array(c(t(res$V1) / V, t(res$VT) / V), c(M, nd, 2),
             list(NULL, measure$dims, c("first", "total")))
  if (sampled) S[] <- pmin(pmax(S, 0), 1)
  S[, measure$names, , drop = FALSE]
}

# Each draw's sampling error of its indices (draws x inputs x index).
sampling_sd <- function(res, M, measure) {
  S <- array(c(t(res$sd1), t(res$sdT)), c(M, length(measure$dims), 2),
             list(NULL, measure$dims, c("first", "total")))
  S[, measure$names, , drop = FALSE]
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
# distribution function for a density; a categorical input's level by its
# probabilities). N = 0: none (the mean's indices).
support_points <- function(N, M, measure) {
  nd <- measure$nd
  if (N == 0L) return(matrix(0, 0, measure$ncol))
  H <- halton(N, nd)
  u <- matrix(0, N * M, nd)
  for (d in seq_len(M)) {
    rows <- (d - 1L) * N + seq_len(N)
    u[rows, ] <- (H + rep(stats::runif(nd), each = N)) %% 1
  }
  to_measure(u, measure)
}

# Points u of the unit cube (one column per input of the measure, numeric
# ones first) mapped to the measure's columns of the design: a numeric
# input uniform on its range, or the inverse of the quadrature's
# distribution function for a density; a categorical input's level the
# first whose cumulative probability exceeds u, written into its indicator
# columns. The other columns (an output's indicators under independent
# outputs: no correlation) are 0.
to_measure <- function(u, measure) {
  X <- matrix(0, nrow(u), measure$ncol)
  for (i in seq_along(measure$cols)) {
    k <- measure$cols[i] + 1L
    X[, k] <- if (measure$exact[k]) {
      measure$lower[k] + (measure$upper[k] - measure$lower[k]) * u[, i]
    } else {
      cw <- cumsum(measure$weights[, k])
      stats::approx(c(0, cw), c(measure$lower[k], measure$nodes[, k]), u[, i], rule = 2,
                    ties = "ordered")$y
    }
  }
  lev <- measure$levels
  for (f in seq_along(measure$probs)) {
    pr <- measure$probs[[f]]
    cut <- cumsum(pr)[-length(pr)]
    code <- 1L + rowSums(outer(u[, length(measure$cols) + f], cut, ">="))
    if (lev$ncol[f] == 1L) {
      X[, lev$col[f]] <- as.numeric(code == 2L)
    } else {
      for (a in seq_len(lev$ncol[f])) X[, lev$col[f] + a - 1L] <- as.numeric(code == a)
    }
  }
  X
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

# The inputs' measure in scaled units (`model`: the compiled model whose
# categorical inputs, `levels`, it weights; `output`: the output held at its
# level, shared outputs). Per column of the design: uniform on [lower,
# upper] (exact: closed form where the family allows) or quadrature nodes
# and weights; `cols` the numeric columns (0-based) and `probs` each
# categorical input's levels' probabilities (uniform by default; the
# output's a point mass at its level), `dims` the inputs in that order (the
# compiled core's), `names` and `role` those reported, in the design's
# order (the output left out), `label` how each is weighted.
sensitivity_measure <- function(inputs, sc, model, output = NULL, call = parent.frame()) {
  p <- sc$p
  D <- p + sc$q
  cn <- sim_input_names(sc, D)
  Q <- fbc_sensitivity_quadrature
  gl <- gauss_legendre01(Q)
  lev <- model$levels
  # each categorical input of the model, by its first indicator column
  facs <- sc$factors
  first <- vapply(facs, function(f) match(f$columns[1], cn), integer(1))
  ind <- unlist(lapply(facs, function(f) match(f$columns, cn)))
  fname <- names(facs)[match(lev$col, first)]
  outname <- sc$output$name
  numeric_cols <- setdiff(seq_len(D), ind)
  # the inputs reported, in the design's order
  keep <- character()
  for (k in seq_len(D)) {
    if (k %in% numeric_cols) keep <- c(keep, cn[k])
    f <- match(k, lev$col)
    if (!is.na(f) && !identical(fname[f], outname)) keep <- c(keep, fname[f])
  }
  catnames <- setdiff(fname, outname)
  lower <- rep(0, D)
  upper <- rep(1, D)
  exact <- rep(TRUE, D)
  dens <- vector("list", D)
  label <- stats::setNames(rep("uniform over the design's range", length(keep)), keep)
  label[catnames] <- "uniform over its levels"
  probs <- lapply(seq_along(fname), function(f) {
    L <- lev$L[f]
    if (identical(fname[f], outname)) as.numeric(seq_len(L) == match(output, sc$output$levels))
    else rep(1 / L, L)
  })
  if (!is.null(inputs)) {
    if (!is.list(inputs) || is.null(names(inputs)) || any(!nzchar(names(inputs)))) {
      cli::cli_abort("{.arg inputs} must be a named list (names: inputs of the simulator).",
                     call = call)
    }
    if (!is.null(outname) && outname %in% names(inputs)) {
      cli::cli_abort(c(
        "{.arg inputs${outname}}: the output {.val {outname}} is not an input of the measure.",
        i = "The indices are given at each output."
      ), call = call)
    }
    bad <- setdiff(names(inputs), keep)
    if (length(bad)) {
      cli::cli_abort(c("{.arg inputs} names {?an input/inputs} the simulator does not have: {.val {bad}}.",
                       i = "Its inputs are {.val {keep}}."), call = call)
    }
    for (v in names(inputs)) {
      el <- inputs[[v]]
      if (v %in% catnames) {
        f <- match(v, fname)
        probs[[f]] <- check_level_probs(el, facs[[v]]$levels, v, call = call)
        label[v] <- "the level probabilities given"
        next
      }
      k <- match(v, cn)
      lo <- sc$xmin[k]
      wd <- sc$xmax[k] - sc$xmin[k]
      if (is.function(el)) {
        dens[[k]] <- el
        exact[k] <- FALSE
        label[v] <- "the density given, over the design's range"
      } else if (is.numeric(el) && length(el) == 2L && all(is.finite(el)) && el[1] < el[2]) {
        lower[k] <- (el[1] - lo) / wd
        upper[k] <- (el[2] - lo) / wd
        label[v] <- sprintf("uniform on [%s, %s]", format(el[1], digits = 4), format(el[2], digits = 4))
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
        cli::cli_abort("{.arg inputs${cn[k]}} must return finite, non-negative densities, not all zero, on the design's range.",
                       call = call)
      }
      w <- w * f
    }
    weights[, k] <- w / sum(w)
  }
  role <- ifelse(keep %in% cn[numeric_cols[numeric_cols > p]], "calibration", "experimental")
  list(lower = lower, upper = upper, exact = exact, nodes = nodes, weights = weights,
       cols = as.integer(numeric_cols - 1L), probs = probs, levels = lev, ncol = D,
       nd = length(numeric_cols) + length(probs), dims = c(cn[numeric_cols], fname),
       names = keep, role = role, label = label[keep],
       level_names = lapply(stats::setNames(fname, fname), function(v) facs[[v]]$levels),
       nd_pred = sum(numeric_cols <= p) + length(probs))
}

# The measure of the experimental inputs alone (the prediction's: the
# first p columns).
prediction_measure <- function(measure, p) {
  ex <- seq_len(p)
  keepc <- measure$cols[measure$cols < p]
  nf <- length(measure$probs)
  list(lower = measure$lower[ex], upper = measure$upper[ex], exact = measure$exact[ex],
       nodes = measure$nodes[, ex, drop = FALSE], weights = measure$weights[, ex, drop = FALSE],
       cols = keepc, probs = measure$probs, levels = measure$levels, ncol = p,
       nd = length(keepc) + nf,
       dims = c(measure$dims[match(keepc, measure$cols)], utils::tail(measure$dims, nf)),
       names = measure$names[measure$role == "experimental"],
       role = rep("experimental", sum(measure$role == "experimental")),
       level_names = measure$level_names)
}

# A categorical input's level probabilities given in `inputs`: a numeric
# vector named by its levels (levels left out have probability 0) or one
# per level in order, non-negative, summing to one.
check_level_probs <- function(x, levels, v, call = parent.frame()) {
  L <- length(levels)
  ok <- is.numeric(x) && length(x) >= 1L && all(is.finite(x)) && all(x >= 0)
  nm <- names(x)
  if (ok && !is.null(nm)) ok <- all(nm %in% levels) && !anyDuplicated(nm)
  if (ok && is.null(nm)) ok <- length(x) == L
  if (!ok || abs(sum(x) - 1) > 1e-8) {
    cli::cli_abort(c(
      "{.arg inputs${v}} must be the probabilities of the levels of the categorical input {.val {v}}: non-negative, summing to one, named by its levels ({.val {levels}}) or one per level in that order.",
      x = if (is.numeric(x)) "They are {format(x, digits = 3)}{if (!is.null(nm)) paste0(' (named ', paste(nm, collapse = ', '), ')')}." else "It is {.obj_type_friendly {x}}."
    ), call = call)
  }
  if (is.null(nm)) return(as.numeric(x))
  out <- numeric(L)
  out[match(nm, levels)] <- x
  out
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

# Main effects (per draw, G grid values per numeric input and one value per
# level of a categorical input, stacked in the measure's order) as one data
# frame per input in the response's (output `out`'s) and the inputs' units:
# a categorical input's `x` the level's number, `level` its name.
main_effects <- function(main, grid, sc, measure, G, level, out = NULL) {
  a <- (1 - level) / 2
  nc <- length(measure$cols)
  size <- c(rep(G, nc), lengths(measure$probs))
  start <- cumsum(c(0L, size))
  summ <- function(v) {
    data.frame(median = apply(v, 1, stats::median),
               lower = apply(v, 1, stats::quantile, probs = a, names = FALSE),
               upper = apply(v, 1, stats::quantile, probs = 1 - a, names = FALSE))
  }
  lapply(stats::setNames(measure$names, measure$names), function(v) {
    i <- match(v, measure$dims)
    v_ <- y_mean(sc, out) + y_sd(sc, out) * main[start[i] + seq_len(size[i]), , drop = FALSE]
    if (i <= nc) {
      k <- measure$cols[i] + 1L
      cbind(x = sc$xmin[k] + (sc$xmax[k] - sc$xmin[k]) * grid[, k], summ(v_))
    } else {
      levs <- measure$level_names[[v]]
      cbind(x = seq_along(levs), level = levs, summ(v_), stringsAsFactors = FALSE)
    }
  })
}

# The calibrated prediction over the experimental inputs: per draw the
# Sobol variances of the mean response zeta(x) = E[eta(x, kappa) + delta(x)
# | y] in closed form (two kernel expansions, the simulator's at the draw's
# kappa and the bias's: .fbc_sobol_pred_c), under the measure's
# experimental inputs, and its main effects on a grid of G values per
# input; the shares of the predictive variance averaged over the points
# `share_u` (randomised Halton points mapped to the same measure;
# predict()'s conditional variances there).
prediction_sensitivity <- function(tg, sc, level, measure, samples, points, share_u = NULL) {
  p <- sc$p
  M <- nrow(tg$phis)
  mp <- prediction_measure(measure, p)
  G <- 25L
  grid <- matrix(0, G, p)
  for (k in mp$cols + 1L) grid[, k] <- seq(mp$lower[k], mp$upper[k], length.out = G)
  if (is.null(share_u)) share_u <- (halton(points, mp$nd) + rep(stats::runif(mp$nd), each = points)) %% 1
  X <- to_measure(share_u, mp)
  res <- target_draws(tg, .fbc_sobol_pred_c, exact = mp$exact, lower = mp$lower,
                      upper = mp$upper, nodes = mp$nodes, weights = mp$weights, grid = grid,
                      share = X, samples = sobol_samples(samples, M, mp), cols = mp$cols,
                      probs = mp$probs)
  S <- index_draws(res, M, mp, samples > 0L)
  sd <- if (samples > 0L) sampling_sd(res, M, mp)
  # one input: both indices are one by definition
  if (length(mp$names) == 1L) {
    S[] <- 1
    if (!is.null(sd)) sd[] <- 0
  }
  # variance shares over the points: each draw's conditional variances and
  # the spread of the conditional means over the draws (predict()'s se^2)
  s2E <- tg$phis[, tg$s2E]
  f <- res$mean
  spread <- if (M > 1L) rowSums((f - rowMeans(f))^2) / (M - 1L) else 0 * f[, 1]
  comp <- c(
    kappa = mean(spread),
    bias = mean(rowMeans((res$var + res$var_bias - res$var_sim) / 2)),
    emulator = mean(rowMeans((res$var + res$var_sim - res$var_bias) / 2)),
    noise = mean(s2E)
  )
  shares <- data.frame(source = names(comp), variance = y_sd(sc, tg$out)^2 * comp,
                       share = comp / sum(comp), stringsAsFactors = FALSE)
  rownames(shares) <- NULL
  list(table = index_table(S, mp$role, level, sd), shares = shares, draws = S,
       main = main_effects(res$main, grid, sc, mp, G, level, tg$out),
       points = share_points(X, sc, mp), share_u = share_u)
}

# The shares' points in the inputs' units: a matrix of the numeric inputs,
# or with categorical inputs a data frame (their levels as factors).
share_points <- function(X, sc, mp) {
  nc <- length(mp$cols)
  cols <- lapply(mp$names, function(v) {
    i <- match(v, mp$dims)
    if (i <= nc) {
      k <- mp$cols[i] + 1L
      return(sc$xmin[k] + (sc$xmax[k] - sc$xmin[k]) * X[, k])
    }
    f <- i - nc
    lev <- mp$levels
    code <- if (lev$ncol[f] == 1L) 1L + (X[, lev$col[f]] > 0.5) else
      max.col(X[, lev$col[f] + seq_len(lev$ncol[f]) - 1L, drop = FALSE], "first")
    factor(mp$level_names[[v]][code], levels = mp$level_names[[v]])
  })
  names(cols) <- mp$names
  if (nc == length(mp$names)) return(do.call(cbind, cols))
  as.data.frame(cols, optional = TRUE, stringsAsFactors = FALSE)
}

#' @export
print.fbc_sensitivity <- function(x, digits = 3, ...) {
  check_dots_empty(..., fn = print.fbc_sensitivity, name = "print", cls = "fbc_sensitivity",
                   action = "warn")
  s <- x$settings
  cat(sprintf("<fbc_sensitivity> Sobol indices from %d posterior draws (%s correlation), %g%% intervals\n",
              s$ndraws, s$kernel, 100 * s$level))
  if (!is.null(s$outputs)) {
    cat(sprintf("At each of %d outputs (%s; %s), the output held at its level:\n",
                length(s$outputs), paste(s$outputs, collapse = ", "), s$outputs_model))
  }
  cat("Simulator, over its inputs (", paste(sprintf("%s: %s", names(s$measure), s$measure),
                                           collapse = "; "), "):\n", sep = "")
  show <- function(tab) {
    tab$interval <- sprintf("[%s, %s]", formatC(tab$lower, digits, format = "f"),
                            formatC(tab$upper, digits, format = "f"))
    tab$median <- formatC(tab$median, digits, format = "f")
    tab$mcse <- formatC(tab$mcse, digits, format = "f")
    cols <- c(if (!is.null(tab$output)) "output", "input", "index", "median", "interval", "mcse")
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
    if (is.null(sh$output)) {
      cat(paste(sprintf("  %s %s", format(sh$source), formatC(sh$share, digits, format = "f")),
                collapse = "\n"), "\n", sep = "")
    } else {
      wide <- do.call(rbind, lapply(split(sh, factor(sh$output, unique(sh$output))), function(d) {
        stats::setNames(formatC(d$share, digits, format = "f"), d$source)
      }))
      wide <- data.frame(output = rownames(wide), wide, check.names = FALSE)
      print(wide, row.names = FALSE)
    }
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
                                 output = NULL, ...) {
  check_dots_empty(..., fn = plot.fbc_sensitivity, name = "plot", cls = "fbc_sensitivity")
  what <- match_choice(what, c("main", "indices"), "what")
  of <- match_choice(of, c("simulator", "prediction"), "of")
  if (of == "prediction" && is.null(x$prediction)) {
    cli::cli_abort("{.arg x} has no prediction part: call {.fn sensitivity} with {.code prediction = TRUE}.")
  }
  outs <- x$settings$outputs
  if (!is.null(output)) {
    if (is.null(outs)) {
      cli::cli_abort("{.arg output} is for a fit with several outputs; {.arg x} has one.")
    }
    if (!is.character(output) || !length(output) || anyNA(output) || !all(output %in% outs)) {
      cli::cli_abort(c("{.arg output} must name outputs of {.arg x}.",
                       i = "Its outputs are {.val {outs}}."))
    }
  }
  pick <- function(df) if (is.null(output)) df else df[df$output %in% output, , drop = FALSE]
  several <- !is.null(outs)
  if (what == "main") {
    me <- x$main[[of]]
    df <- do.call(rbind, lapply(names(me), function(v) {
      d <- me[[v]]
      lab <- if (is.null(d$level)) v else {
        u <- unique(d[c("x", "level")])
        sprintf("%s (%s)", v, paste(sprintf("%d = %s", u$x, u$level), collapse = ", "))
      }
      cbind(input = lab, categorical = !is.null(d$level),
            d[setdiff(names(d), "level")], stringsAsFactors = FALSE)
    }))
    df <- pick(df)
    df$input <- factor(df$input, unique(df$input))
    if (several) df$output <- factor(df$output, outs)
    num <- df[!df$categorical, , drop = FALSE]
    lv <- df[df$categorical, , drop = FALSE]
    g <- ggplot2::ggplot(df, ggplot2::aes(x = .data$x, y = .data$median))
    if (nrow(num)) {
      g <- g + ggplot2::geom_ribbon(data = num, ggplot2::aes(ymin = .data$lower, ymax = .data$upper),
                                    alpha = 0.3) +
        ggplot2::geom_line(data = num)
    }
    if (nrow(lv)) {
      g <- g + ggplot2::geom_pointrange(data = lv, ggplot2::aes(ymin = .data$lower, ymax = .data$upper))
    }
    g <- g + if (several) ggplot2::facet_grid(output ~ input, scales = "free") else
      ggplot2::facet_wrap(~input, scales = "free_x")
    g + ggplot2::labs(x = NULL, y = "conditional mean",
                      title = sprintf("Main effects of the %s", of))
  } else {
    tab <- pick(x[[of]])
    tab$input <- factor(tab$input, unique(tab$input))
    g <- ggplot2::ggplot(tab, ggplot2::aes(x = .data$input, y = .data$median, colour = .data$index)) +
      ggplot2::geom_pointrange(ggplot2::aes(ymin = .data$lower, ymax = .data$upper),
                               position = ggplot2::position_dodge(width = 0.4)) +
      ggplot2::coord_cartesian(ylim = c(0, 1)) +
      ggplot2::labs(x = NULL, y = "Sobol index", colour = NULL,
                    title = sprintf("Sobol indices of the %s", of))
    if (several) g <- g + ggplot2::facet_wrap(~output)
    g
  }
}
