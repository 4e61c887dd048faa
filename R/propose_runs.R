# propose_runs(): where to run the simulator next, scored against the joint
# posterior draws by a look-ahead (importance reweighting of the draws over
# fantasised simulator values).

#' Where to run the simulator next
#'
#' Chooses `n` new simulator inputs (experimental and calibration columns)
#' expected to shrink the posterior of the calibration parameters
#' \eqn{\kappa} most (the default), or the uncertainty of calibrated
#' predictions at inputs the user names (`target`), and reports each one's
#' expected gain integrated over the joint posterior of \eqn{\kappa} and
#' every hyperparameter. The points are picked with the hyperparameters at
#' their MAP values (`method = "plugin"`, the default: measured as good as
#' or better than picking by the joint criterion, `method = "joint"`), for
#' kappa by the expected reduction of its entropy; the measurements behind
#' these choices are in `vignette("design", package = "FBC")`.
#'
#' @section Criterion:
#' For each retained draw \eqn{\phi_s} (kappa and the hyperparameters) the
#' simulator's value \eqn{y^*} at a candidate input \eqn{(x, t)} is Gaussian
#' given the data (the GP conditional on the runs and the field data,
#' \eqn{N(\mu_s, v_s)}). A run there observing \eqn{y^*} would turn the
#' posterior into \eqn{p(\phi \mid D, y^*) \propto p(\phi \mid D)
#' N(y^*; \mu_s, v_s)}: the draws reweighted, exactly (no refit). The
#' criterion is the expected reduction of kappa's posterior variance (in
#' the design's scaled units, \eqn{\kappa} on \eqn{[0, 1]}, summed over the
#' calibration inputs), the expectation over \eqn{y^*} from the posterior
#' predictive (a mixture over the draws), by `nfantasy` fantasised values
#' with common random numbers across candidates:
#' \deqn{G(x, t) = \mathrm{Var}(\kappa \mid D) - E_{y^*}[\mathrm{Var}_w(\kappa \mid D, y^*)].}
#' A run near the field inputs at a likely \eqn{\kappa} scores high when
#' the emulator is uncertain there and the draws disagree about its value;
#' a run where the emulator is known, or where every draw predicts the
#' same, scores near 0. A batch is chosen greedily: each next point with
#' the pending points' values fantasised jointly with it (per draw their
#' joint Gaussian), so a point close to a pending one gains little
#' (re-running a deterministic simulator at the same input tells nothing).
#' `gain` is each point's expected reduction given the points chosen
#' before it, as a fraction of the current variance.
#'
#' @section A prediction target:
#' With `target` a set of experimental inputs \eqn{x_1, \dots, x_T} (as
#' [predict()]'s `newdata`), the criterion is the expected reduction of the
#' calibrated prediction's posterior predictive variance averaged over
#' them (an integrated variance), the prediction being
#' \eqn{\zeta(x) = \eta(x, \kappa) + \delta(x)}, `predict(type = "mean")`.
#' Per draw, \eqn{\zeta(x_t)} and the simulator's value at a candidate are
#' jointly Gaussian given the data, so a fantasised run does two things:
#' it reweights the draws as above, and it moves each draw's predictive
#' mean and shrinks its variance (the GP update with the run's value). The
#' variance after is the mixture's (law of total variance over the
#' reweighted draws):
#' \deqn{G_T(x, t) = \frac1T \sum_{t'} \left(\mathrm{Var}(\zeta(x_{t'}) \mid D) -
#'   E_{y^*}[\mathrm{Var}_w(\zeta(x_{t'}) \mid D, y^*)]\right),}
#' with the same fantasies, batches and `gain` (a fraction of the current
#' integrated variance). Runs then go near the target inputs at likely
#' values of \eqn{\kappa}, and where they also narrow \eqn{\kappa}
#' (tested: a batch of 5 for a target at \eqn{x = 0.15} on the sinusoid
#' put 4 runs within 0.04 of it, one for \eqn{x = 0.85} 3 within 0.05 of
#' it, while for kappa they spread over \eqn{x} = 0.28-0.90). The part of
#' the variance runs cannot reduce (the bias's, and
#' \eqn{\kappa}'s where the field data leave it wide) stays. The cost grows
#' with the number of target points (at most 100; a few dozen are plenty
#' for an integrated variance).
#'
#' Which points are picked: by default (`method = "plugin"`) by the same
#' criterion with the hyperparameters fixed at the MAP draw's (kappa on a
#' grid for one calibration input, a uniform sample otherwise, weighted by
#' its likelihood and prior), what EIVAR does (KOH-IMSPE fixes kappa at
#' its estimate too, and needs more runs: `vignette("design", package = "FBC")`); with
#' `method = "joint"` by the joint criterion above. For kappa (no
#' `target`) the plug-in scores by kappa's entropy, not its variance: on
#' its kappa values \eqn{\kappa_k} (weights \eqn{p_k}) the expected
#' reduction of \eqn{-\sum_k p_k \log p_k}{-sum_k p_k log p_k} by a run there, which is the
#' mutual information of \eqn{\kappa} and the run's value,
#' \deqn{I(x, t) = H(y^*) - \frac12 \sum_k p_k \log(2 \pi e v_k),}{I(x, t) = H(y*) - (1/2) sum_k p_k log(2 pi e v_k),}
#' estimated with the same fantasies (the variance weighs most what tells
#' far-apart values of kappa apart; the entropy weighs telling any apart,
#' and that reached the posterior in fewer runs). The plug-in ignores the
#' hyperparameters' uncertainty, so its own gains overstate what its picks
#' are worth: the `gain` reported is always the joint look-ahead's (of
#' kappa's variance), at the plug-in's picks in its order (each given the
#' ones before), and the plug-in's own gains are kept in attribute
#' `pluginGain`, for kappa its entropy's expected reduction \eqn{\Delta H}
#' as the fraction of the variance it means for a normal posterior,
#' \eqn{1 - e^{-2 \Delta H}}{1 - exp(-2 Delta H)}. Where the two
#' disagree about the plug-in's first pick, the plug-in expecting it to be
#' worth 1% of the current variance or more and the joint look-ahead less,
#' the joint criterion picks instead if its best run is worth 1% or more
#' (attribute `method` says which criterion picked): the MAP
#' hyperparameters misled the plug-in (a loop on the sinusoid with runs in
#' \eqn{x \le 0.5}: the plug-in's kappa grid had 3 points of weight, its
#' pick was worth 0.3%, the joint criterion's halved kappa's 90%
#' interval). Where both find it worth under 1%, the "limited" message
#' below is said.
#'
#' @section When new runs cannot help:
#' New runs shrink only the part of kappa's uncertainty that comes from the
#' emulator's. When the field data cannot separate a change of kappa from
#' a bias (the Kennedy-O'Hagan confounding, [convergence_messages()]) or
#' the field data are few and noisy, kappa's posterior stays wide however
#' many runs are made (its shape still depends on where the runs are:
#' with the KOH bias on the sinusoid of Koermer et al., kappa's sd stopped
#' shrinking at about 25 runs). `propose_runs()` says so when the best point's
#' expected gain is below 1% of the current variance (of kappa, or of the
#' prediction at the targets), in a message (by default: when the plug-in
#' and the joint look-ahead both find the plug-in's first pick worth under
#' 1%, or the joint criterion's best is).
#'
#' @section Defaults and cost:
#' The look-ahead costs draws x candidates x fantasies per point of a
#' batch (one `exp()` each), plus a dense factor per draw, whatever the
#' fit's length. The fantasies' draws are chosen by systematic resampling
#' and their normal deviates are stratified, and all candidates share them,
#' so the picks are steadier than the gains themselves. Give fewer
#' `nfantasy` or `ndraws` for a cheaper, noisier step. How the defaults
#' (`ndraws = 100`, `nfantasy = 50`, `100 (p + q)` candidates, half at
#' kappa's draws and the field's inputs) were chosen, and how the default
#' criterion compares with the joint one, with kappa's variance, with
#' uniform candidates, with KOH-IMSPE and with nested Latin hypercubes:
#' `vignette("design", package = "FBC")`.
#'
#' @section Scope:
#' The conditional is computed per draw with a dense Cholesky factor of
#' the covariance of the \eqn{m} runs and the field's distinct inputs
#' (exact, whatever algebra the fit ran; refused beyond 3000 runs and
#' distinct field inputs). It handles every discrepancy model (any
#' `discrepancy` of [calibrate()]: its bias, if it has one, on the field's
#' distinct inputs as the fit has it); several field data sets (`source`), each with its own noise
#' variance, with one bias or a bias each (`sourceBias = "own"`; then for
#' kappa only: a prediction target is refused, as its bias would be that
#' of no data set); and categorical inputs (their level correlations as
#' the fit has them; a candidate or target gives its level).
#'
#' Several outputs (`output =`, one simulator GP over the inputs and the
#' output, `outputs = "shared"`, the default): a run of the simulator
#' gives every output, so a candidate is a run (its inputs without the
#' output column) and its \eqn{K} values are fantasised jointly: per draw
#' they are \eqn{K}-variate Gaussian given the data and the pending runs
#' (correlated through the outputs' level correlation), and the draws are
#' reweighted by that density. A prediction target names its output (the
#' output column in `target`), or without that column stands for every
#' output at its inputs. With independent outputs (`outputs =
#' "independent"`, each output its own simulator GP and hyperparameters,
#' only \eqn{\kappa} shared) a run's \eqn{K} values are independent given
#' a draw, each Gaussian given its own output's runs, field data and
#' pending runs; the draws are reweighted by the product of their
#' densities.
#'
#' A stochastic simulator (a fit with `simNoise = "constant"` or
#' `"input"`, see [simulator_noise]): a run's value is \eqn{\eta(u)} plus
#' the simulator's own noise, so per draw its variance is the emulator's
#' plus \eqn{r(u)} (the draw's `sigma2R`, or with an input-dependent noise
#' the mean of \eqn{e^{g(u)}} given its log-variances). Each run's input
#' is a candidate too: a replicate there averages down that input's noise,
#' and it is scored beside the new inputs by the same criterion, so either
#' may be proposed (column `replicate`).
#' The look-ahead holds draws x (m + the field's distinct inputs) x
#' candidates (x outputs) numbers (with independent outputs m and the
#' field's inputs of the output with the most); beyond 5e7 (400 MB) it is
#' refused, naming the sizes (give fewer `ndraws` or candidates).
#'
#' @param fit An `fbc` object.
#' @param n Number of points (a batch, chosen greedily with the pending
#'   ones conditioned on).
#' @param candidates Candidate inputs (data frame or matrix with the
#'   experimental and calibration columns of `sim`, named; a categorical
#'   input a column of its levels, in a data frame), in any ranges the user
#'   wants; `NULL` (default): `ncandidates` points in the ranges of the
#'   simulator design, the experimental inputs' widened to take in the
#'   field's inputs (so the runs can reach field inputs beyond them), each
#'   categorical input at a level drawn at random; half uniform, half with
#'   their calibration inputs at draws of kappa's posterior and their
#'   experimental inputs at the field's (see `vignette("design", package = "FBC")`).
#'   With several outputs, runs: no output column.
#' @param target `"kappa"` (the default: shrink kappa's posterior) or
#'   experimental inputs where calibrated predictions are wanted (a data
#'   frame or matrix with the field's input columns, as [predict()]'s
#'   `newdata`, 1 to 100 rows): shrink the prediction's integrated
#'   variance there (see "A prediction target"). With several outputs a
#'   target without the output column means every output at its inputs.
#' @param ndraws Posterior draws the criterion integrates over (evenly
#'   spaced over the distinct retained ones, each weighted by its repeats:
#'   the draws of a reweighted fit, [update_runs()], repeat).
#' @param nfantasy Fantasised simulator values per candidate.
#' @param method Which criterion picks the points: `"plugin"` (the
#'   default: the hyperparameters at their MAP values; for kappa by its
#'   entropy) or `"joint"`
#'   (integrated over the draws); the gains reported are the joint
#'   look-ahead's either way (see "Criterion").
#' @param ncandidates Number of default candidates (default
#'   `100 * (p + q)`, at most 1000; \eqn{p} counts a categorical input's
#'   indicator columns, not an output's).
#' @param tol Candidates closer than `tol` (scaled units) to an existing
#'   run are left out.
#' @return A data frame of `n` rows: the inputs (natural units, columns
#'   named as in `sim`; a categorical input a factor of its levels; with
#'   several outputs a run's inputs, each run to give every output), `gain`
#'   (the point's expected reduction of kappa's posterior variance, or of
#'   the prediction's integrated variance, as a fraction of the current,
#'   given the points above it; the look-ahead's Monte Carlo estimate,
#'   which can fall below 0 where the true gain is about 0, is clipped at
#'   0 and kept unclipped in attribute `gainEstimate`); for a stochastic
#'   simulator also `replicate`: whether the point repeats a run's inputs
#'   (exactly those of the run).
#'   Attributes `variance` (current, scaled), `time` (CPU seconds),
#'   `method` (the criterion that picked: `"joint"` also where the plug-in
#'   and the joint look-ahead disagreed about the plug-in's pick, see
#'   "Criterion") and, where the plug-in picked, `pluginGain` (its own
#'   gains; for kappa its entropy's reduction as a variance fraction,
#'   \eqn{1 - e^{-2 \Delta H}}{1 - exp(-2 Delta H)}).
#' @seealso [update_runs()], [design_loop()]
#' @export
#' @examples
#' set.seed(1)
#' fit <- calibrate(ballSim[1:30, ], ballField, nChains = 2, nMCMC = 1000, nBurn = 400)
#' propose_runs(fit, n = 2, ndraws = 50, ncandidates = 100)
#' # runs for calibrated predictions at x = 2.5
#' propose_runs(fit, n = 2, target = c(2.5), ndraws = 50, ncandidates = 100)
propose_runs <- function(fit, n = 1, candidates = NULL, target = "kappa", ndraws = 100,
                         nfantasy = 50, method = c("plugin", "joint"), ncandidates = NULL,
                         tol = 1e-3) {
  t0 <- proc.time()
  fit <- check_fbc(fit, "fit")
  method <- match_choice(method, c("plugin", "joint"), "method")
  n <- check_count(n, "n", min = 1)
  ndraws <- check_count(ndraws, "ndraws", min = 2)
  nfantasy <- check_count(nfantasy, "nfantasy", min = 1)
  model <- fit$model
  check_design_model(model)
  sc <- model$scale
  d <- sc$p + sc$q
  out1 <- design_output(sc)
  K <- if (is.null(out1)) 1L else length(out1$levels)
  XT <- design_target(target, sc)
  if (nrow(XT) && model$dims$sources > 0L) {
    cli::cli_abort(c(
      "{.arg target} needs the calibrated prediction of one bias: this fit has a bias per field data set ({.code sourceBias = \"own\"}).",
      i = "Choose runs for kappa ({.code target = \"kappa\"}, the default), or fit with one bias."
    ))
  }
  U <- fit_candidates(fit, candidates, ncandidates, tol)
  # a stochastic simulator: a replicate at each run's input is a candidate
  # too (it halves, thirds ... that input's noise), scored beside the new
  # inputs by the same criterion
  nNew <- nrow(U)
  noisy <- !is.null(model$spec$model$replicates)
  if (noisy) U <- rbind(U, model$data$Xs)
  if (nrow(U) < n * K) {
    cli::cli_abort("Only {nrow(U) / K} candidate{?s} are distinct from the existing runs; {.arg n} = {n} needs at least {n}.")
  }
  joint <- design_particles(fit, ndraws, "joint")
  # (before any work: the joint look-ahead over every candidate may be needed)
  check_look_ahead_size(nrow(joint$phi), model, U, XT)
  plug <- if (method == "plugin") design_particles(fit, ndraws, "plugin")
  crit <- pick_runs(plug, joint, U, model, n, nfantasy, XT, K)
  out <- as.data.frame(unscale_inputs(U[(crit$chosen - 1L) * K + 1L, , drop = FALSE],
                                      sc, seq_len(d)))
  names(out) <- c(sc$names$inputs, sc$names$calibration)
  if (K > 1L) {
    # a run gives every output: no output column
    out <- out[-out1$j]
    sc$factors[[out1$name]] <- NULL
  }
  out <- indicators_to_levels(out, sc)
  if (noisy) {
    # a replicate's inputs exactly those of its run (not unscaled: a
    # rounding would make it a new input)
    rep <- crit$chosen > nNew
    if (any(rep)) {
      raw <- model$raw$sim
      first <- sim_replicates(raw)$first[crit$chosen[rep] - nNew]
      cols <- intersect(names(out), colnames(raw))
      for (j in cols) out[rep, j] <- raw[first, j]
    }
    out$replicate <- rep
  }
  # an expected variance reduction cannot be negative: an estimate below
  # 0 is the look-ahead's Monte Carlo error about 0, reported as 0 (the
  # estimates themselves are kept in attribute gainEstimate)
  est <- crit$gain / crit$variance
  out$gain <- pmax(est, 0)
  tm <- proc.time() - t0
  attr(out, "gainEstimate") <- est
  attr(out, "variance") <- crit$variance
  attr(out, "method") <- crit$method
  attr(out, "pluginGain") <- crit$own
  attr(out, "time") <- sum(tm[c(1, 2)])
  if (est[1] < design_limited) message(design_limited_message(est[1], nrow(XT) > 0))
  out
}

# propose_runs()'s "limited" message, a condition of class
# fbc_design_limited (design_loop() says it once a loop). Its text is
# wrapped here, not by cli: R formats a message when it is signalled, even
# a muffled one, and cli's formatting cost 14 ms, more than the design step
# it followed (5-10 ms), in loops and scripts that muffle it.
design_limited_message <- function(gain, target) {
  what <- if (target) "the calibrated prediction's variance at the target points" else "kappa's posterior variance"
  why <- if (target) {
    "Such as kappa's uncertainty that the field data leave, or the bias's: runs of the simulator do not reduce them."
  } else {
    "Such as the bias's confounding with kappa or few, noisy field data: see `convergence_messages()`."
  }
  # (a gain at or below 0 is the look-ahead's Monte Carlo error about 0)
  size <- format(100 * gain, digits = 2)
  text <- c(paste0(if (gain > 0) {
    paste0("The best new run is expected to shrink ", what, " by ", size, "% only")
  } else {
    paste0("No new run is expected to shrink ", what, " measurably (the best's estimate, ", size,
           "%, is Monte Carlo error about 0)")
  }, ": it is limited by something new runs cannot change."),
            why)
  width <- max(20L, getOption("width", 80L) - 2L)
  lines <- mapply(function(x, bullet) paste(strwrap(x, width, prefix = "  ", initial = paste0(bullet, " ")), collapse = "\n"),
                  text, c("!", cli::symbol$info))
  structure(class = c("fbc_design_limited", "message", "condition"),
            list(message = paste0(paste(lines, collapse = "\n"), "\n"), call = NULL))
}

# Below this expected gain (a fraction of the current variance) a run is
# worth nothing: propose_runs() says the posterior is limited by something
# runs cannot change, and where the plug-in values its pick above it and
# the joint look-ahead below, the joint criterion picks (pick_runs()).
design_limited <- 0.01

# n points of the candidates U picked by the plug-in's particles `plug`
# (NULL: by the joint particles `joint`), with the joint look-ahead's gains
# (at the plug-in's picks in its order, the points before conditioned on:
# the plug-in's own, `own`, ignore the hyperparameters' spread). Where the
# plug-in expects its first pick to be worth design_limited or more and the
# joint look-ahead less, its picks give way to the joint criterion's if
# that finds one worth more: the plug-in's hyperparameters, not the
# posterior, misled it (`limit`: design_limited, or another share for the
# tests). `method` says which picked.
pick_runs <- function(plug, joint, U, model, n, nfantasy, XT, K = 1L, limit = design_limited) {
  if (is.null(plug)) {
    return(c(look_ahead(joint, U, model, n, nfantasy, XT, K = K), method = "joint"))
  }
  # for kappa the plug-in picks by kappa's entropy: its own gains, each
  # point's expected reduction of the entropy, as the variance fraction a
  # normal posterior's reduction means, 1 - exp(-2 gain)
  entropy <- nrow(XT) == 0L
  own_share <- function(la) if (entropy) -expm1(-2 * la$gain) else la$gain / la$variance
  # the two look-aheads' random numbers, drawn first (in this order), so
  # their first steps can be run alone: whether the joint criterion takes
  # over depends on the first pick only, and where it does the plug-in's
  # other picks would be thrown away (on two calibration inputs in batches
  # of 5, three quarters of its look-ahead's CPU time)
  rmine <- look_ahead_random(n * K, nfantasy)
  rcrit <- look_ahead_random(n * K, nfantasy)
  takeover <- function(crit1, own1) crit1$gain[1] / crit1$variance < limit && own1 >= limit
  joint_alt <- function() {
    alt <- look_ahead(joint, U, model, n, nfantasy, XT, K = K)
    if (alt$gain[1] / alt$variance >= limit) alt
  }
  # the plug-in's first step (the rest resumed below unless the joint
  # criterion takes over) and the joint look-ahead's value of its pick:
  # with n = 1 the whole of both
  mine <- look_ahead(plug, U, model, n, nfantasy, XT, K = K, entropy = entropy, random = rmine,
                     steps = 1L)
  crit <- look_ahead(joint, U[run_rows(mine$chosen, K), , drop = FALSE], model, 1L, nfantasy, XT,
                     order = 1L, K = K, random = first_random(rcrit, K))
  if (takeover(crit, own_share(mine)[1])) {
    # (the plug-in's systems freed first: the peak memory one look-ahead's)
    if (!is.null(mine$state)) .design_look_ahead_release(mine$state)
    alt <- joint_alt()
    if (!is.null(alt)) return(c(alt, method = "joint"))
    # rarely (the joint criterion's best under the limit too): the
    # plug-in's batch from the start, the same numbers
    if (n > 1L) mine <- look_ahead(plug, U, model, n, nfantasy, XT, K = K, entropy = entropy, random = rmine)
  } else if (n > 1L) {
    mine <- look_ahead_resume(mine)
  }
  if (n > 1L) {
    crit <- look_ahead(joint, U[run_rows(mine$chosen, K), , drop = FALSE], model, n, nfantasy, XT,
                       order = seq_len(n), K = K, random = rcrit)
  }
  crit$chosen <- mine$chosen
  own <- own_share(mine)
  c(crit, method = "plugin", list(own = own))
}

# The rows of runs `runs` (in order) among candidates of K rows a run.
run_rows <- function(runs, K) as.vector(t(outer((runs - 1L) * K, seq_len(K), "+")))

# Several outputs (shared: the output a categorical input of the one
# simulator GP): a run gives every output, so the look-ahead's candidates
# are runs of K rows. The output's factor (name, levels, columns) and `j`,
# its columns' places among the inputs; NULL with one output.
design_output <- function(sc) {
  out <- sc$output
  if (is.null(out)) return(NULL)
  c(out, list(j = match(out$columns, c(sc$names$inputs, sc$names$calibration))))
}

# The criterion's target on the scaled experimental inputs: no rows for
# kappa's variance, else the rows of `target` (experimental inputs where
# calibrated predictions are wanted, as predict()'s newdata).
design_target <- function(target, sc, call = parent.frame()) {
  if (is.character(target) && identical(target, "kappa")) return(matrix(0, 0, sc$p))
  if (!is.data.frame(target) && !is.numeric(target)) {
    cli::cli_abort(c(
      "{.arg target} must be {.val kappa} or experimental inputs where calibrated predictions are wanted (as {.fn predict}'s {.arg newdata}), not {.obj_type_friendly {target}}.",
      i = "Such as {.code target = data.frame({sc$names$inputs[1]} = 0.5)}."
    ), call = call)
  }
  out <- design_output(sc)
  if (!is.null(out) && !(is.data.frame(target) && out$name %in% names(target))) {
    target <- every_output(target, sc, out)
  }
  if (length(sc$factors) && is.data.frame(target)) target <- levels_to_indicators(target, sc, "target", call)
  X <- tryCatch(check_newdata(target, sc), error = function(e) {
    cli::cli_abort("{.arg target} must be {.val kappa} or experimental inputs as {.fn predict}'s {.arg newdata}.",
                   parent = e, call = call)
  })
  if (nrow(X) < 1L || nrow(X) > 100L) {
    cli::cli_abort("{.arg target} must have 1 to 100 points (the look-ahead's cost grows with their number), not {nrow(X)}.", call = call)
  }
  scale_inputs(X, sc, seq_len(sc$p))
}

# A target without the output's column (several outputs): every output at
# each of its points (a data frame, or numeric experimental inputs in the
# order of the field's numeric ones), the outputs innermost.
every_output <- function(target, sc, out) {
  if (!is.data.frame(target)) {
    xn <- setdiff(sc$names$inputs, unlist(lapply(sc$factors, `[[`, "columns")))
    target <- as.data.frame(matrix(target, ncol = length(xn), dimnames = list(NULL, xn)))
  }
  at_every_output(target, out)
}

# The rows of a draw's system in the look-ahead (src/design.cpp): the runs
# and the field's groups of rows at one input in one noise group and data
# set (replicates enter through their mean; field_groups()), as c(runs,
# field). With independent outputs each output's system is its own (a
# block; design_systems_outputs()): the largest output's.
design_rows <- function(model) {
  mm <- model$spec$model
  key <- cbind(model$data$Xf, mm$noise, mm$source)
  count <- function(sim, field) c(length(sim), sum(!duplicated(key[field, , drop = FALSE])))
  if (output_count(mm) == 1L) return(count(seq_len(model$dims$m), seq_len(nrow(key))))
  rows <- mapply(count, output_rows(model, "sim"), output_rows(model, "field"))
  rows[, which.max(colSums(rows))]
}

# The models the look-ahead handles (a simulator with runs; the dense
# conditional, refused beyond 3000 rows).
check_design_model <- function(model, call = parent.frame()) {
  if (!is.null(model$simulator)) {
    cli::cli_abort(c(
      "This fit calibrates a simulator function, which has no runs to add to: {.fn propose_runs} chooses simulator runs.",
      i = "{.fn design_loop} builds a fit of runs of a function and chooses its runs."
    ), call = call)
  }
  N <- design_rows(model)
  if (sum(N) > 3000) {
    each <- if (model$dims$outputs > 1L) " (of one output: each has its own)" else ""
    cli::cli_abort(c(
      "{.fn propose_runs} handles up to 3000 runs and distinct field inputs{each}; this fit has {N[1]} and {N[2]}.",
      i = "It conditions every candidate on all of them for every draw it scores, which is too slow beyond that."
    ), call = call)
  }
}

# propose_runs()'s candidates for `fit` (scaled rows; `candidates` NULL: the
# default ones, `ncandidates` NULL: 100 per input up to 1000). The default
# candidates reach the field's inputs beyond the runs' (so the runs can
# cover them), and half sit at kappa's posterior draws: a run tells about
# kappa where its calibration inputs are near kappa's posterior, and
# uniform candidates put ever fewer there as it narrows (measured,
# "Candidates").
fit_candidates <- function(fit, candidates = NULL, ncandidates = NULL, tol = 1e-3,
                           call = parent.frame()) {
  model <- fit$model
  sc <- model$scale
  nin <- sc$p + sc$q - length(design_output(sc)$j)
  design_candidates(candidates, sc, ncandidates %||% min(1000, 100 * nin), model$data$Xs, tol,
                    kappa = sampler_scale(fit$Phi[, seq_len(sc$q), drop = FALSE], sc),
                    Xf = model$data$Xf, call = call)
}

# The candidates on the scaled inputs (rows), those within `tol` of an
# existing run left out. A categorical input is given by its levels (a
# column of `candidates` named as in `sim`) and held as its indicator
# columns. The default candidates (`candidates` NULL) are uniform in the
# runs' ranges, the experimental inputs' widened to the field's inputs
# (`Xf`, scaled); given `kappa` (draws, scaled), the first half take their
# calibration inputs from draws picked at random (held to the runs' range)
# and, given `Xf` too, their experimental inputs from the field's distinct
# inputs picked at random.
design_candidates <- function(candidates, sc, ncand, Xs, tol, kappa = NULL, Xf = NULL,
                              call = parent.frame()) {
  d <- sc$p + sc$q
  nm <- c(sc$names$inputs, sc$names$calibration)
  out <- design_output(sc)
  if (is.null(candidates)) {
    U <- matrix(stats::runif(ncand * d), ncand, d)
    if (!is.null(Xf) && sc$p > 0L) {
      lo <- pmin(0, apply(Xf, 2, min))
      hi <- pmax(1, apply(Xf, 2, max))
      U[, seq_len(sc$p)] <- sweep(sweep(U[, seq_len(sc$p), drop = FALSE], 2, hi - lo, "*"), 2, lo, "+")
    }
    # a categorical input: a level drawn for each candidate, as its
    # indicator columns (the output's set by runs_by_output())
    for (f in sc$factors) {
      if (identical(f$name, out$name)) next
      j <- match(f$columns, nm)
      a <- sample.int(length(f$levels), ncand, replace = TRUE)
      U[, j] <- scale_inputs(indicator_matrix(f$levels[a], f$columns), sc, j)
    }
    if (!is.null(kappa)) {
      U <- half_at(U, sc$p + seq_len(sc$q), kappa, 0, 1)
      # and at the field's inputs, where the emulator is used (with kappa)
      if (!is.null(Xf) && sc$p > 0L) U <- half_at(U, seq_len(sc$p), unique(Xf))
    }
  } else {
    if (!is.null(out)) {
      if (is.data.frame(candidates) && out$name %in% names(candidates)) {
        cli::cli_abort(c(
          "{.arg candidates} are runs, and a run gives every output: drop its column {.val {out$name}}.",
          i = "Each candidate is scored with its values for all outputs ({.val {out$levels}})."
        ), call = call)
      }
      candidates <- as.data.frame(candidates)
      candidates[[out$name]] <- out$levels[1]  # (a placeholder: runs_by_output())
    }
    if (length(sc$factors)) candidates <- levels_to_indicators(candidates, sc, "candidates", call)
    X <- as.matrix(if (is.data.frame(candidates)) candidates[intersect(nm, names(candidates))] else candidates)
    if (!is.null(colnames(X)) && all(nm %in% colnames(X))) X <- X[, nm, drop = FALSE]
    if (!is.numeric(X) || ncol(X) != d || anyNA(X)) {
      cli::cli_abort("{.arg candidates} must have the {d} numeric input column{?s} {.val {nm}} without NA.", call = call)
    }
    U <- scale_inputs(X, sc, seq_len(d))
  }
  # distances to every run, a column of runs at a time (the per-candidate
  # apply() was an eighth of a design step); with several outputs over
  # the inputs but the output's
  D2 <- matrix(0, nrow(U), nrow(Xs))
  for (k in setdiff(seq_len(d), out$j)) D2 <- D2 + outer(U[, k], Xs[, k], "-")^2
  near <- rowSums(sqrt(D2) < tol) > 0
  U <- U[!near, , drop = FALSE]
  if (is.null(out)) U else runs_by_output(U, sc, out)
}

# Candidates X with the first half's columns `cols` at rows of `F` (kappa's
# draws, or the field's distinct inputs; the columns' units) picked at
# random, held to [lo, hi].
half_at <- function(X, cols, F, lo = -Inf, hi = Inf) {
  h <- seq_len(nrow(X) %/% 2)
  pick <- F[sample.int(nrow(F), length(h), replace = TRUE), , drop = FALSE]
  X[h, cols] <- pmin(pmax(pick, rep(lo, each = length(h))), rep(hi, each = length(h)))
  X
}

# Each candidate run (a row of U) as its K rows, one per output (the
# output's indicator columns at each level in turn): the look-ahead's
# candidates with several outputs.
runs_by_output <- function(U, sc, out) {
  K <- length(out$levels)
  V <- U[rep(seq_len(nrow(U)), each = K), , drop = FALSE]
  V[, out$j] <- scale_inputs(indicator_matrix(rep(out$levels, nrow(U)), out$columns), sc, out$j)
  V
}

# The draws scored over: `phi` (rows, sampler's scale), base log-weights
# `lw0` (0 for posterior draws, the log of its repeats for a repeated one)
# and kappa (scaled). "plugin": the MAP draw's hyperparameters with kappa
# on a grid (q = 1) or uniform, weighted by likelihood times prior; those
# of no weight (under 1e-10 of the largest) are left out by the look-ahead
# (`prune`, a log ratio; 0 with !prune).
design_particles <- function(fit, ndraws, method, prune = TRUE) {
  N <- nrow(fit$Phi)
  q <- fit$model$scale$q
  if (method == "joint") {
    # evenly over the distinct draws, each weighted by its repeats: a
    # reweighted fit's draws repeat (update_runs()), and picking among all
    # draws would spend particles on copies. Without repeats, every draw
    # is its own run (the particles are the evenly spaced draws).
    same <- c(FALSE, rowSums(abs(diff(fit$Phi))) == 0 & diff(fit$chain) == 0)
    run <- cumsum(!same)
    G <- run[N]
    starts <- which(!same)
    pick <- unique(round(seq(1, G, length.out = min(ndraws, G))))
    phi <- sampler_draws(fit, starts[pick])
    return(list(phi = phi, lw0 = log(tabulate(run, G)[pick]), kappa = phi[, seq_len(q), drop = FALSE]))
  }
  phi0 <- sampler_draws(fit, which.max(fit$logPost))
  K <- if (q == 1L) matrix((seq_len(ndraws) - 0.5) / ndraws) else matrix(stats::runif(ndraws * q), ndraws, q)
  phi <- phi0[rep(1, ndraws), , drop = FALSE]
  phi[, seq_len(q)] <- K
  tab <- fit$model$spec$table
  lp <- 0
  for (j in seq_len(q)) lp <- lp + log_prior_row(tab, j, K[, j])
  # a kappa whose weight is under 1e-10 of the largest adds nothing to the
  # criterion but its cost (at 20 runs of the sinusoid 62 of 100)
  list(phi = phi, lw0 = rep_len(lp, ndraws), kappa = K, plugin = TRUE,
       prune = if (prune) log(1e10) else 0)
}

# The look-ahead's memory, draws x (m + G + T) x candidates numbers (G
# the field's distinct inputs: replicates enter through their means; with
# independent outputs m + G of the largest output, design_rows()): refused
# beyond 5e7 (400 MB).
check_look_ahead_size <- function(ndraws, model, U, XT, call = parent.frame()) {
  rows <- sum(design_rows(model)) + nrow(XT)
  size <- ndraws * rows * nrow(U)
  if (size > 5e7) {
    what <- if (nrow(XT)) "runs, field inputs and targets" else "runs and field inputs"
    if (model$dims$outputs > 1L) what <- paste(what, "(the largest output's)")
    K <- length(model$scale$output$levels)
    cand <- if (K > 1L) paste(nrow(U) / K, "candidates x", K, "outputs") else paste(nrow(U), "candidates")
    cli::cli_abort(c(
      "The look-ahead would hold {format(8 * size / 2^20, digits = 3)} MB ({ndraws} draws x {rows} {what} x {cand}).",
      i = "Give fewer {.arg ndraws} or candidates."
    ), call = call)
  }
}

# The greedy look-ahead (src/design.cpp, design_look_ahead()) over the
# particles at the candidates U: n points chosen one at a time, each
# maximising the expected reduction of kappa's (weighted) posterior
# variance (`entropy`: its entropy, for the plug-in's particles; or of the
# prediction's variance at the targets XT) with the pending
# points' fantasised values conditioned on per draw (with `order`, the
# candidates U[order, ] in that order: their gains). Its random numbers,
# `random`, from look_ahead_random() (drawn after the size check unless
# given); `steps` < n runs the first steps only (look_ahead_resume() the
# rest). Returns .design_look_ahead()'s list: `chosen`, `gain`, `variance` (the
# criterion's current value: kappa's entropy with `entropy`), `scores`,
# `kept`.
look_ahead <- function(parts, U, model, n, nfantasy, XT = matrix(0, 0, ncol(model$data$Xf)),
                       order = integer(), K = 1L, entropy = FALSE,
                       random = look_ahead_random(n * K, nfantasy), steps = n,
                       call = parent.frame()) {
  dat <- model$data
  check_look_ahead_size(nrow(parts$phi), model, U, XT, call)
  .design_look_ahead(dat$Xf, dat$yf, dat$Xs, dat$ys, parts$phi, U, parts$kappa, parts$lw0,
                     isTRUE(parts$plugin), random$usrc, random$Z, XT, fbc_nugget, model$spec$model,
                     as.integer(order), parts$prune %||% 0, as.integer(K), entropy,
                     as.integer(steps), run_success(model, U, K), run_noise(model, parts$phi, U))
}

# A stochastic simulator's noise variance of a run at each candidate (rows
# of U, scaled) under each draw (rows of phis, the sampler's scale), as a
# matrix candidates x draws; 0 x 0 for a deterministic simulator. A
# constant noise is the draw's sigma2R; an input-dependent one the mean of
# exp(g(u)) given the draw's log-variances (latent_noise_mean()), which at
# a run's own input is exp(gR_i) up to the GP's jitter.
run_noise <- function(model, phis, U) {
  reps <- model$spec$model$replicates
  if (is.null(reps) || !nrow(U)) return(matrix(0, 0, 0))
  if (!isTRUE(reps$latent)) {
    return(matrix(phis[, model$spec$classes == "sigma2R"], nrow(U), nrow(phis), byrow = TRUE))
  }
  r <- vapply(seq_len(nrow(phis)), function(i) latent_noise_mean(model, phis[i, ], U),
              numeric(nrow(U)))
  matrix(r, nrow(U))
}

# Each candidate run's probability of succeeding, by the model of where the
# simulator fails (failure_classifier()), which multiplies its expected gain
# in the look-ahead; numeric(0) (no weighting) when no run failed.
run_success <- function(model, U, K = 1L) {
  cl <- model$design$failed$classifier
  if (is.null(cl) || !nrow(U)) return(numeric())
  sc <- model$scale
  X <- as.data.frame(unscale_inputs(U[seq(1L, nrow(U), by = K), , drop = FALSE], sc,
                                    seq_len(sc$p + sc$q)))
  names(X) <- c(sc$names$inputs, sc$names$calibration)
  X <- indicators_to_levels(X, sc)
  X <- if (isTRUE(cl$named)) X[colnames(cl$X)] else X[vapply(X, is.numeric, logical(1))]
  1 - failure_probability(cl, as.matrix(X))
}

# The rest of a look-ahead begun with fewer `steps` than points (its
# `state`): the same list as running them all at once.
look_ahead_resume <- function(la) .design_look_ahead_resume(la$state)

# look_ahead()'s random numbers for `cols` fantasised values a fantasy
# (n points of K values): the fantasies' draws by systematic resampling
# (uniforms (j - U) / nfantasy, one U), then per value a random order of
# the nfantasy normal quantiles (common to every candidate).
look_ahead_random <- function(cols, nfantasy) {
  usrc <- (seq_len(nfantasy) - stats::runif(1)) / nfantasy  # systematic: the draws evenly
  Z <- matrix(0, nfantasy, cols)
  for (k in seq_len(cols)) Z[, k] <- stats::qnorm((sample.int(nfantasy) - 0.5) / nfantasy)
  list(usrc = usrc, Z = Z)
}

# The random numbers of a look-ahead's first point alone (its first K
# columns): its first step is the same as the whole batch's.
first_random <- function(random, K) list(usrc = random$usrc, Z = random$Z[, seq_len(K), drop = FALSE])
