#' Full Bayesian calibration of a computer model
#'
#' Fits the Kennedy-O'Hagan model to simulator runs and field data and draws
#' from the joint posterior of every unknown, the calibration parameters
#' \eqn{\kappa} and all GP hyperparameters, by adaptive Metropolis-within-Gibbs
#' in compiled code.
#'
#' @section Model:
#' With field response \eqn{y_f} at inputs \eqn{x_f} and simulator response
#' \eqn{y_s} at inputs \eqn{(x_s, t_s)},
#' \deqn{y_f = \eta(x_f, \kappa) + \delta(x_f) + \epsilon, \quad y_s = \eta(x_s, t_s),}
#' \eqn{\eta \sim GP(0, \sigma^2_S R_s)}, \eqn{\delta \sim GP(\mu_B, \sigma^2_B R_b)},
#' \eqn{\epsilon \sim N(0, \sigma^2_E)}, with separable correlations of the
#' family chosen for each GP ([correlation()]). This is
#' `discrepancy = "gp"`, the default; the other models of `discrepancy`
#' (below) change \eqn{\delta} or drop it. Inputs are scaled to
#' \eqn{[0, 1]} over the simulator design and the response standardised by
#' the simulator runs; the hyperparameters and their priors live on that
#' scale, \eqn{\kappa} in its own units.
#'
#' The details are in the articles: `vignette("model", package = "FBC")`
#' (discrepancy models, correlation families, scaling, categorical inputs,
#' outputs and data sets, the simulator as a function, the data checks) and
#' `vignette("sampler", package = "FBC")` (the algebras, the moves, warm-up
#' and stopping, chains, interrupting and checkpoints).
#'
#' @section Defaults:
#' Four chains, each warming up until its proposals have settled, then
#' running until every R-hat < 1.01 and every bulk ESS >= 400
#' ([until_converged()]); Matérn 5/2 correlations; a Beta(1.1, 1.1) prior
#' on each \eqn{\kappa} over the design's range; the algebra chosen by
#' projected cost (`algebra = "auto"`). Chains run through \pkg{future}:
#' sequentially unless a plan is set (`future::plan(future::multisession)`
#' runs them in parallel); [set.seed()] reproduces a run on any plan.
#' Ctrl-C returns the draws so far; `checkpoint` lets a run resume.
#'
#' @section Failed runs and missing cells:
#' A row of `sim` whose response is `NA`, `NaN` or infinite is a failed run.
#' By default it is set aside with one message (how many, and where), its
#' inputs are kept in the model, and the calibration uses the successful
#' runs: a failed run is not evidence about kappa (the physical system does
#' not fail with the code), so the posterior is that of the successful runs.
#' The failed inputs feed a model of where the simulator fails, a Gaussian
#' process classifier over the numeric inputs (logistic link, Laplace
#' approximation, its length-scales and variance at their posterior mode:
#' plug-in values serve because it does not enter kappa's posterior; a
#' large latent scale and the latent's mode, so that it interpolates the
#' runs, since a deterministic code fails again where it failed; above
#' 1,000 runs it sees every failed run and a sample of the successful ones;
#' fitted when first asked for, not by `calibrate()`):
#' `predict(fit, newdata, type = "failure")`, `plot(fit, type = "failure")`,
#' and [propose_runs()] weighs its candidates by it. Field data in long
#' format may miss an output at some field inputs.
#'
#' On a product design, a failed run (or a combination with no row) is a
#' missing cell: the Kronecker algebra leaves it out exactly, while that is
#' projected cheaper than the dense algebra; `print()` says how many cells.
#'
#' @param sim Simulator runs: a numeric matrix or data frame with the
#'   response, the `p` experimental inputs and the `q` calibration inputs
#'   (matched by name, or by position without names); or the simulator
#'   itself as an R function `f(x, kappa)`, called inside the sampler; or an `fbc_model` from
#'   `calibrate(..., fit = FALSE)` to fit.
#' @param field Field data: the response and the same `p` experimental
#'   inputs.
#' @param nMCMC Total number of MCMC iterations (sweeps) per chain, burn-in
#'   included. `NULL` (the default): until converged (see `converge`), or
#'   8000 sweeps with `converge = FALSE`.
#' @param nBurn Number of initial iterations discarded; the proposals adapt
#'   during these. `NULL` (the default): each chain warms up until its
#'   proposals have settled, between 200 and 5000 sweeps.
#' @param thinning Keep every `thinning`-th iteration after burn-in.
#' @param nChains Number of independent chains.
#' @param kappaDist,kappaInit,kappaP1,kappaP2 Prior family, initial value and
#'   prior parameters of the calibration parameters, in the calibration
#'   inputs' own units (see [prior_builder()] for the families). The default
#'   Beta(1.1, 1.1) is stretched over the range the simulator design covers
#'   for each calibration input. `kappaInit = NA` starts at the middle of
#'   that range (or at the centre of the prior when that lies outside it).
#'   Scalars apply to every calibration parameter; vectors must have length
#'   `q`. The defaults of `kappaP1` and `kappaP2` are the Beta's: another
#'   family must be given its own parameters (e.g. `kappaDist = "gaussian",
#'   kappaP1 = 9.8, kappaP2 = 1` for a mean and standard deviation in `g`'s
#'   units), else `calibrate()` refuses it and names the arguments to give.
#'   A prior reaching beyond the range the simulator design covers warns,
#'   and one with no support on it is refused.
#' @param hypers Hyperparameter priors from [set_hyperPriors()].
#' @eval discrepancy_docs()
#' @param kernelS,kernelB Correlation family of the simulator GP and of the
#'   bias GP: `"matern52"` (the default), `"powexp"` (the vignette's),
#'   `"gaussian"` or `"matern32"`.
#' @param showProgress Show a progress bar over all chains (on any plan: the
#'   workers report through \pkg{progressr}) with the time left and each
#'   chain's acceptance rate after burn-in (mean over its parameters).
#'   `NULL` (the default) shows it where a person waits for the run, in an
#'   interactive session, and prints nothing in scripts (`Rscript`) or
#'   while \pkg{knitr} renders a document; `TRUE` or `FALSE` decide.
#' @param sampler `"blocks"` (the default: joint and exact moves) or `"single"` (the vignette's one-at-a-time sampler).
#' @param algebra `"auto"` (the default: the Kronecker algebra when the runs
#'   are every combination of two groups of input columns, such as an output
#'   index x run settings; else the exact dense one while a sweep of it is projected to
#'   cost under 0.1 s, else the nearest-neighbour approximation), `"dense"`
#'   (always the exact dense one) or `"vecchia"` (the nearest-neighbour
#'   approximation). `print()` says which ran and why.
#' @param neighbours For the nearest-neighbour algebra: how many neighbours
#'   each simulator run and each field point conditions on (a whole number,
#'   at least 1; more is closer to exact and slower). `NULL` (the default):
#'   20 below 4000 runs, 10 from 4000 on (how these were chosen:
#'   `vignette("sampler")`). Given with an algebra that has no neighbours, it is not used and
#'   a message says so.
#' @param blockSim Deprecated: `TRUE` is `sampler = "blocks"` and `FALSE`
#'   `sampler = "single"`, with a warning.
#' @param checkpoint `NULL` (no checkpoints) or a directory where the chains
#'   save checkpoints (created if needed). When it holds
#'   a checkpoint of the same run, the run is resumed from it.
#' @param checkpointEvery Seconds between a chain's checkpoints (it also
#'   saves when it stops); `0` saves after every piece of 50 iterations.
#' @param output For several outputs in long format: the name of a factor
#'   (or character) column of both `sim` and `field` saying which output
#'   each row holds (with a simulator function, a column of `field`).
#' @param outputs With `output`: how the outputs are modelled. `"shared"`
#'   (default): one simulator GP over the inputs and the output, the outputs
#'   correlated by a learned level correlation (`rhoS`; the bias likewise,
#'   `rhoB`). `"independent"`: each output its own simulator and bias GP
#'   (its own length-scales, smoothness and variances), only `kappa` shared.
#' @param source For several field data sets stacked in `field`: the name
#'   of a factor column of `field` only saying which data set each row
#'   belongs to; each has its own measurement-error variance.
#' @param sourceBias With `source`: `"shared"` (default), one bias for all
#'   field data sets; `"own"`, a bias per data set: the bias GP correlates
#'   the data sets' biases by a correlation learned like every
#'   hyperparameter (`rhoD1`, ...: at 1 the biases coincide, at 0 they are
#'   independent, as in Gu, Anderson and McPhillips' multi-source
#'   calibration; `set_hyperPriors(rhoDDist = "fixed", rhoDInit = 0)` holds
#'   them independent).
#' @param converge `NULL` (the default): stop when converged when `nMCMC`
#'   is not given, run `nMCMC` sweeps when it is. `FALSE` runs `nMCMC`
#'   sweeps per chain. `TRUE`, or a rule from [until_converged()], runs
#'   until every R-hat is below 1.01 and every bulk ESS at least 400 (the
#'   rule's thresholds), or a ceiling, checked first 500 sweeps after each
#'   chain's warm-up (or after `nMCMC` sweeps when given).
#' @param fit `TRUE` (the default) fits the model; `FALSE` returns it
#'   unfitted, an `fbc_model` (see [fbc_model]) that `calibrate(model, ...)`
#'   fits later. With a model as `sim`, only the run's settings (`nMCMC`,
#'   `nBurn`, `thinning`, `nChains`, `showProgress`, `checkpoint`,
#'   `checkpointEvery`, `converge`) may be given.
#' @param nonFinite With a simulator function: `"error"` (the default)
#'   stops at a non-finite value of `f`, naming the kappa; `"reject"`
#'   treats it as a rejected proposal, so the chains avoid the kappa where
#'   `f` is undefined (the posterior is then restricted to where `f` is
#'   finite).
#' @param failedRuns What to do with failed runs (see "Failed runs and
#'   missing cells"): `"setAside"` (the default) or `"error"`, which refuses
#'   them.
#' @param simNoise The simulator's own noise, for a stochastic simulator
#'   with replicate runs (identical input rows of `sim`; see
#'   [simulator_noise]): `"auto"` (the default: `"constant"` when replicates
#'   differ beyond rounding, else `"none"`), `"none"` (a deterministic
#'   simulator), `"constant"` (one noise variance `sigma2R`, sampled with
#'   the rest, the replicates entering by their sufficient statistics) or
#'   `"input"` (its log a GP over the inputs; see [simulator_noise]).
#' @param fieldLink What the field is, with the simulator's noise modelled:
#'   `"mean"` (the default) the system's mean behaviour, its noise
#'   measurement error only; `"realization"` one realization of the
#'   stochastic process, its noise variance also carrying the simulator's
#'   (`"constant"` noise only). The default holds when the simulator's
#'   randomness stands for what is unknown, not for the system's own
#'   variability (see [simulator_noise]).
#' @param threads Threads inside each chain (OpenMP) for the
#'   nearest-neighbour algebra, with the same draws for any number; `1` (the
#'   default) is one core per chain (`vignette("clusters")`).
#' @return An object of class `fbc`: a list with `Phi` (one row per retained
#'   draw, chains stacked; one column per parameter, in the order `kappa`,
#'   `thetaS`, `alphaS`, `thetaB`, `alphaB`, `sigma2S`, `sigma2B`, `sigma2E`,
#'   `muB`, without `alphaS`/`alphaB` for a family that has no smoothness
#'   and without those of the bias GP the discrepancy model lacks, all
#'   of them under `discrepancy = "none"`),
#'   `chain` (the chain of each row), `estimates` (posterior summaries with
#'   `rhat` and `ess`), `logPost`, `priors`, `acceptance`, `vars` (the names
#'   of `Phi`'s columns), `indices` (for each parameter
#'   class, the columns of `Phi` holding it: `integer(0)` for a smoothness
#'   that is not sampled), `priorFns`, `proposalSD`, `call`, `settings`
#'   (the run's: MCMC sizes, nugget, run time, checkpoint directory, the
#'   convergence rule), `model` (the [fbc_model] fitted: the scaled
#'   `data`, their `scale`, `spec` (the model description the copies
#'   `priors`, `vars`, `indices` and `priorFns` come from), `kernelS`,
#'   `kernelB`, `discrepancy`, `sampler` and its `moves`, the `algebra`
#'   that ran (`name`, `dims` of a product design, `neighbours`, `reason`),
#'   ...), `state` (`chains`: where
#'   each chain stopped, its adapted proposal scales and acceptance, over
#'   the sampler's full parameter vector; `interrupted`) and `version`
#'   (`fbc`: the version of FBC that made it; `format`:
#'   the object's format). A fit saved by an earlier FBC is brought to the
#'   current format by every function that takes one, and an
#'   earlier version's checkpoint directory resumes.
#' @export
#' @examples
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 600, nBurn = 200, nChains = 2,
#'                  converge = FALSE)
#' fit
#' # no discrepancy: y_f = eta(x, kappa) + eps, no bias parameters
#' set.seed(1)
#' none <- calibrate(ballSim, ballField, nMCMC = 400, nBurn = 200, nChains = 2,
#'                   discrepancy = "none")
#' colnames(none$Phi)
#' # the simulator as an R function (no runs, no emulator)
#' f <- function(x, kappa) 5 * exp(-kappa[["u"]] * x$t)
#' set.seed(1)
#' fk <- calibrate(f, as.data.frame(kineticField), kappaDist = "uniform",
#'                 kappaP1 = c(u = 0.5), kappaP2 = c(u = 3), nMCMC = 600,
#'                 nBurn = 200, nChains = 2)
#' summary(fk)
#' # the defaults (until converged; a few seconds on the ball data):
#' # fit <- calibrate(ballSim, ballField)
calibrate <- function(sim, field, nMCMC = NULL, nBurn = NULL, thinning = 2,
                      nChains = 4, kappaDist = "beta", kappaInit = NA, kappaP1 = 1.1,
                      kappaP2 = 1.1, hypers = set_hyperPriors(), discrepancy = "gp",
                      kernelS = "matern52",
                      kernelB = "matern52", showProgress = NULL, sampler = c("blocks", "single"),
                      blockSim = NULL, algebra = c("auto", "dense", "vecchia"),
                      neighbours = NULL, checkpoint = NULL,
                      checkpointEvery = 60, converge = NULL, output = NULL, source = NULL,
                      sourceBias = c("shared", "own"), outputs = c("shared", "independent"),
                      fit = TRUE, nonFinite = c("error", "reject"),
                      failedRuns = c("setAside", "error"),
                      simNoise = c("auto", "none", "constant", "input"), threads = 1L,
                      fieldLink = c("mean", "realization")) {
  call <- match.call()
  run <- check_run(nMCMC, nBurn, thinning, nChains, converge, showProgress, checkpoint,
                   checkpointEvery, threads)
  if (inherits(sim, "fbc_model")) return(fit_model(model_to_fit(sim, call), run))
  check_flag(fit, "fit")
  failedRuns <- match_choice(failedRuns, c("setAside", "error"), "failedRuns")
  if (is.function(sim)) {
    check_sim_noise_function(simNoise)
    check_field_link_function(fieldLink)
    # the simulator as an R function (R/simulator_function.R)
    model <- build_function_model(sim, field,
      kappa = list(dist = kappaDist, init = kappaInit, p1 = kappaP1, p2 = kappaP2),
      hypers = hypers, discrepancy = discrepancy, kernelB = kernelB, sampler = sampler,
      blockSim = blockSim, output = output, source = source, sourceBias = sourceBias,
      nonFinite = nonFinite, modelCall = call)
    return(if (fit) fit_model(model, run) else model)
  }
  model <- build_model(sim, field,
                       kappa = list(dist = kappaDist, init = kappaInit, p1 = kappaP1, p2 = kappaP2),
                       kappaDefault = c(missing(kappaP1), missing(kappaP2)), hypers = hypers,
                       discrepancy = discrepancy, kernelS = kernelS, kernelB = kernelB,
                       sampler = sampler, blockSim = blockSim, algebra = algebra,
                       neighbours = neighbours, output = output, source = source,
                       sourceBias = sourceBias, outputs = outputs, failedRuns = failedRuns,
                       simNoise = simNoise, fieldLink = fieldLink, modelCall = call)
  if (!fit) return(model)
  fit_model(model, run)
}
