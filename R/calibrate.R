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
#' \eqn{\epsilon \sim N(0, \sigma^2_E)}, with separable correlations
#' \eqn{R(x, x') = \prod_k r(|x_k - x'_k|)} of the family chosen for each GP
#' (see [correlation()] and "Correlation families"). The log posterior is
#' evaluated through Cholesky factors of the blocks of the joint covariance
#' (never an explicit inverse).
#'
#' @section Discrepancy models:
#' `discrepancy` chooses the model of the simulator's discrepancy
#' \eqn{\delta}:
#' * `"gp"` (the default, the vignette's): the Kennedy-O'Hagan bias GP
#'   above, with parameters `thetaB`, `alphaB`, `sigma2B` and `muB`;
#' * `"sgasp"`: the scaled Gaussian stochastic process (S-GaSP) of Gu and
#'   Wang (2018), a bias GP conditioned to have a small L2 norm over the
#'   experimental inputs, so that \eqn{\kappa} is pulled towards the value
#'   whose simulator is closest to reality in L2 rather than traded off
#'   against the bias. Discretized at the \eqn{n_u} distinct field inputs
#'   \eqn{U} (replicates share one point, as they share the bias), its
#'   correlation is
#'   \deqn{R_z(x, x') = R(x, x') - R(x, U) (R(U, U) + (n_u / \lambda_z) I)^{-1} R(U, x')}
#'   with \eqn{R} the bias GP's correlation (`kernelB`, `thetaB`, `alphaB`)
#'   and scale \eqn{\lambda_z} (`lambdaZ`, sampled under a lognormal prior
#'   with median 20, see [set_hyperPriors()], or fixed): small
#'   \eqn{\lambda_z} gives the bias GP back, large \eqn{\lambda_z} no
#'   discrepancy. Its mean is 0 (no `muB`): a constant offset between the
#'   simulator and the field counts in the L2 norm it shrinks. `Phi` has
#'   `thetaB`, `alphaB`, `lambdaZ` and `sigma2B`, moved jointly.
#'   [predict.fbc()]'s `"bias"` and `"mean"` use the same kernel at new
#'   inputs. Every algebra applies (the S-GaSP lives on the field side).
#' * `"none"`: no discrepancy, \eqn{y_f = \eta(x_f, \kappa) + \epsilon}. The
#'   bias GP has no parameters: none in `Phi` (nor in `vars`, `estimates`,
#'   `indices`, whose bias entries are `integer(0)`), no bias moves. A
#'   prior given for a bias parameter in `hypers`, or a `kernelB`, is
#'   ignored with a warning. [predict.fbc()]'s types keep their meaning:
#'   the bias is exactly 0, so `"mean"` is `"simulator"` and `"field"` adds
#'   \eqn{\sigma^2_E}.
#'
#' Without a discrepancy the field data inform \eqn{\kappa} only through
#' the simulator: the interval is narrower, and right only when the
#' simulator can match the field. With the bias GP, \eqn{\kappa} and the
#' bias are confounded (Kennedy and O'Hagan 2001; on the ball data the
#' interval for `g` is most of the design's range; [convergence_messages()]
#' says when this happens). The S-GaSP sits between the two. On the ball
#' data (defaults, `set.seed(1)`) the 95% intervals of `g` are 6.27 to 13.49
#' (`"gp"`), 6.73 to 11.30 (`"sgasp"`) and 7.68 to 8.70 (`"none"`);
#' RobustCalibration's plug-in fits give 7.0 to 9.9 (S-GaSP) and
#' 7.8 to 8.6 (none). [loo.fbc()] compares the models by exact
#' leave-one-out predictive densities of the field data.
#'
#' @section The simulator as a function:
#' When the simulator is an R function that runs in micro- to
#' milliseconds, give it as `sim`: `calibrate(f, field, ...)` calibrates
#' \eqn{y_f = f(x, \kappa) + \delta(x) + \epsilon} with no emulator
#' (and no runs), every unknown sampled jointly as for runs.
#' * `f(x, kappa)` takes `x`, the field inputs (a data frame when `field`
#'   is one, else a matrix, with `field`'s input names, one row per field
#'   point) and `kappa`, a named numeric vector, and returns one number per
#'   row of `x`. It is called once per proposal of kappa with all the field
#'   rows (never once per point), and at the new inputs by [predict.fbc()]
#'   (once per draw); the rest of a sweep is compiled code.
#' * Besides its adapted random walk, each \eqn{\kappa_l} makes a jump
#'   move once a sweep: an independence proposal drawn from its uniform
#'   prior, accepted with the likelihood ratio (exact Metropolis-Hastings,
#'   not adapted; one more call of `f` a sweep, reported by `print()` as
#'   `"kappa1 jump"`). A walk adapted within one mode rarely leaves it; the
#'   jump visits every mode of a multimodal posterior. On
#'   RobustCalibration's documented example (`sin(theta x) + x`, no
#'   discrepancy; a second mode near 0.27 holding 18% of the mass) it
#'   finds both modes on every seed tried (`bench/RESULTS-function.md`).
#' * The calibration inputs come from the kappa prior:
#'   `kappaDist = "uniform", kappaP1 = lower, kappaP2 = upper`, one entry
#'   per input; a named `kappaP1` (or `kappaP2`) names them (else `kappa1`,
#'   `kappa2`, ...). Other prior families are refused: there is no design
#'   whose range a `"beta"` prior could be stretched over.
#' * Scaling: the experimental inputs over the field's range, kappa over its
#'   prior's range, the response by the mean of `f` over the field inputs
#'   at the prior's centre (or `kappaInit`) and by the field response's sd
#'   (the priors of `sigma2E` and `sigma2B` are on that scale).
#' * `discrepancy` is `"gp"`, `"sgasp"` or `"none"` as for runs; there is
#'   no simulator GP, so `thetaS`, `alphaS`, `sigma2S` are not parameters
#'   (priors given for them are ignored with a warning).
#' * An error inside `f`, a wrong length or a non-finite value stops the
#'   run with a message naming the kappa (native units) that caused it;
#'   `nonFinite = "reject"` rejects proposals where `f` is not finite
#'   instead. `f` must be self-contained (it travels to parallel workers).
#' * `predict()` gives `f` at the new inputs plus the bias (`"simulator"`:
#'   `f` itself, with no emulator variance); `print()`, `plot()`,
#'   `update()`, `loo()`, `ppc_field()`, checkpoints (the function's code
#'   is part of the run's identity) and `converge` work as for runs;
#'   `emulator_cv()` has no emulator to check; [emulator_vs_direct()]
#'   compares an emulator-based fit with the function's. `source` works
#'   (a noise variance per field data set, one shared bias; `f` does not
#'   see the data set's column).
#' * `output` works with `discrepancy = "none"`: the field in long format,
#'   `f` sees the output column (a factor) in `x` and returns each row's
#'   output; kappa is shared, each output is standardised on its own (the
#'   mean of `f` at the prior's centre and the sd of its field response)
#'   and has its own noise variance. With a bias it is refused (the bias
#'   over the outputs, their level correlation, is built for runs only), as
#'   are `sourceBias = "own"` and other categorical inputs.
#'
#' @section Correlation families:
#' `kernelS` and `kernelB` choose the family of the simulator GP
#' \eqn{\eta} and of the bias GP \eqn{\delta}, separately, with
#' \eqn{d = |x_k - x'_k|} and \eqn{h = \sqrt{\theta_k} d} per input:
#' * `"matern52"` (the default): \eqn{(1 + \sqrt{5} h + 5 h^2 / 3) \exp(-\sqrt{5} h)};
#' * `"powexp"` (the vignette's): \eqn{\exp(-\theta d^\alpha)},
#'   with a smoothness \eqn{\alpha \in [1, 2]} per input that is sampled
#'   (`alphaS`, `alphaB`);
#' * `"gaussian"`: \eqn{\exp(-\theta d^2)};
#' * `"matern32"`: \eqn{(1 + \sqrt{3} h) \exp(-\sqrt{3} h)}.
#'
#' The Matérn 5/2 is the default (as in RobustGaSP, RobustCalibration and
#' DiceKriging) because it mixes on the smooth simulators calibration
#' meets: there the power exponential's smoothness piles up at its bound 2
#' (the README's example warned of it), and at m = 1000 scattered runs its
#' block did not mix in 30,000 sweeps a chain (`alphaS` R-hat 2.6, bulk ESS
#' 5), while the Matérn 5/2 converged in 5500 (issue 27). The vignette's
#' power exponential stays available as `kernelS = "powexp"` (and
#' `kernelB`); it was the default of FBC 0.1.0.
#'
#' Every family is \eqn{1 - c\,\theta d^2 + \dots} near 0 (\eqn{c = 1, 3/2,
#' 5/6}; the power exponential at \eqn{\alpha = 2}), so \eqn{\theta} keeps its
#' meaning and its default prior. The last three have no smoothness
#' parameter: with them `alphaS` (or `alphaB`) is not sampled and is not a
#' column of `Phi` (nor of `vars`, `estimates`, `acceptance`, `proposalSD`,
#' [as_draws_df()][fbc-draws] or `coef()`), and its entry of `indices` is
#' `integer(0)`; `plot(fit, "alphaS")` is then an error. A prior given for it
#' in `hypers` is ignored with a warning. When the power exponential's
#' smoothness piles up at 2 (a smooth simulator, [convergence_messages()]
#' says so), a smooth family is the clean choice: the Gaussian is that
#' limit, and the Matérn 5/2 (the robust default of RobustCalibration) is as
#' smooth for practical purposes with far better conditioned correlation
#' matrices; on smooth functional outputs it removes the stuck chains the
#' power exponential near \eqn{\alpha = 2} can give. Every family has the
#' same caching and speed (`bench/RESULTS-scale.md`).
#'
#' @section Scaling:
#' Each simulator input column is mapped to `[0, 1]` by its minimum and
#' maximum over the simulator design; the field inputs use the same minimum
#' and maximum. Both responses are standardised by the mean and standard
#' deviation of the simulator response. The hyperparameters (and their priors)
#' live on this scale; the calibration parameters are reported, and their
#' priors specified, in the calibration inputs' own units. The scaling is kept
#' in `$scale`. For numerical safety a relative nugget of `1e-6` is added to
#' the diagonal of the simulator correlation matrix (a simulator noise
#' variance of `1e-6 * sigma2S`, far below any simulator's rounding).
#'
#' @section Simulator algebra:
#' When the simulator runs are every combination of \eqn{I} settings of the
#' experimental inputs and \eqn{J} settings of the calibration inputs, in
#' any row order (a functional output: each of \eqn{J} runs returns the
#' response at the same \eqn{I} times, positions or grid points), the
#' simulator correlation is a Kronecker product \eqn{R_x \otimes R_t} up to
#' a permutation of the rows. The likelihood is then evaluated exactly
#' through the eigendecompositions of the two small factors (the nugget
#' keeps its meaning): a move of an experimental-input correlation parameter
#' costs one \eqn{I \times I} eigendecomposition, a calibration-input one a
#' \eqn{J \times J} one, a \eqn{\kappa} move \eqn{O(IJ + In^2)}, and no
#' \eqn{m \times m} matrix is ever formed (\eqn{m = IJ}). The field inputs
#' need not lie on the grid. `calibrate()` detects such a design itself
#' (rows compared exactly; used from about 4 settings of each on, where it
#' pays) and otherwise uses the dense algebra, Cholesky factors of the
#' \eqn{m \times m} simulator block: a design with one run missing is not a
#' product design. `algebra = "dense"` forces the dense algebra (the same
#' posterior, slower). `print()` and `fit$model$algebra` say which one
#' ran; [predict.fbc()] uses the same.
#'
#' Beyond a few thousand scattered runs no exact algebra is practical (a
#' factorization of the \eqn{m \times m} block per sweep). The
#' nearest-neighbour (Vecchia) approximation (`algebra = "vecchia"`, or
#' `"auto"` when the runs are not a product design and a dense sweep is
#' projected to cost more than 0.1 s, see below) replaces the
#' joint Gaussian of the runs and the field points by a directed graph
#' (Vecchia 1988; Datta et al. 2016; Katzfuss and Guinness 2021): the runs
#' in a maximin order of their scaled inputs (Guinness 2018), each
#' conditioned on its `neighbours` nearest earlier runs, then the field
#' points \eqn{\eta(x, \kappa)}, each conditioned on its `neighbours`
#' nearest runs at the current \eqn{\kappa} and on its nearest earlier
#' field points. A sweep then costs \eqn{O(m k^3)} instead of
#' \eqn{O(m^3)} and memory \eqn{O(m k)}; no \eqn{m \times m} matrix is
#' formed. The distances scale each input by \eqn{\theta_k^{1/\alpha}}
#' from a pilot maximum-likelihood fit of the simulator GP on at most 400
#' runs (Katzfuss, Guinness and Lawrence 2022), made once before sampling:
#' every chain, `update()`, [predict.fbc()] and [emulator_cv()] use
#' the same approximation (`fit$spec$model$vecchia`). The posterior is that
#' of the approximate model, exact when every node conditions on all its
#' predecessors (`neighbours` at least \eqn{m}, tested); `print()` says
#' when it ran, with \eqn{k}. `bench/vecchia.R` measures it against
#' the exact algebra.
#'
#' Under `algebra = "auto"` the choice is by projected cost: a dense sweep
#' is projected move by move (each move of the simulator block factors the
#' \eqn{m \times m} block and builds it over the \eqn{p + q} inputs, each
#' kappa move solves the \eqn{m \times n} cross block) from constants
#' measured on the reference BLAS (`bench/dense-cost.R`, within 1.5 times of
#' measured sweeps). While that is under 0.1 s the
#' dense algebra runs, exact; above, the nearest-neighbour one, whose sweep
#' costs milliseconds (8 ms at m = 1000). The rule is the same on every BLAS,
#' so the same data get the same algebra on every machine: an optimized BLAS
#' does not favour the dense algebra enough to move it (OpenBLAS, m = 1000:
#' a dense sweep 17.6 ms, a Vecchia one 7.0 ms).
#' `print()` gives the projected dense cost and the
#' ways towards exact (`algebra = "dense"`, a larger `neighbours`).
#'
#' @section Categorical inputs, outputs and data sets:
#' A factor or character column of both `sim` and `field` (data frames) is a
#' categorical experimental input. Its levels are those of `sim`'s column
#' (a level of `field` or of [predict.fbc()]'s `newdata` that `sim` does not
#' have is refused). Its levels are read into indicator columns, one for
#' two levels (`name[level2]`) and one per level from three
#' (`name[level]`), which appear among the inputs but enter neither GP's
#' kernel (their \eqn{\theta} is held at 0, and they are not in `Phi`).
#' Each GP multiplies its correlation by the levels' correlation instead:
#' \eqn{R((x, a), (x', b)) = R(x, x') C_{ab}}, with \eqn{C} an
#' unstructured \eqn{L \times L} correlation matrix, learned and sampled
#' like every hyperparameter through its \eqn{L(L-1)/2} canonical partial
#' correlations (`rhoS1`, ... for the simulator GP, `rhoB1`, ... for the
#' bias; see [set_hyperPriors()]): for two levels the correlation itself;
#' for three, the correlations of levels 2 and 3 with level 1, then the
#' partial correlation of levels 2 and 3 given level 1. \eqn{C} is positive
#' definite by construction, and its correlations may be negative (two
#' outputs that move in opposite directions). [level_correlation()] gives
#' its posterior mean. An unstructured correlation has \eqn{L(L-1)/2}
#' parameters: for a categorical input with many levels, expect slower
#' mixing. (Version 0.1.x used a product of one positive factor per level
#' instead; see `bench/RESULTS-outputs.md` for why it was replaced.)
#'
#' `output = "name"` names such a column that says which output each row of
#' `sim` and `field` holds (long format: one response column, one row per
#' run or observation and output). Outputs given in wide format (a response
#' column per output) are not read as outputs: the first is the response
#' and a second, when `field` has it too, an experimental input. Stack them
#' instead (e.g. with `reshape()` or `tidyr::pivot_longer()`);
#' `calibrate()` warns when a column shared with `field` varies with the
#' calibration inputs in `sim`, as an output does and a design input does
#' not. Each output is standardised by
#' its own simulator runs' mean and sd, and has its own measurement-error
#' variance (`sigma2E1`, `sigma2E2`, ...); the simulator GP and the bias
#' correlate the outputs through the output's level correlation, so all
#' outputs inform the shared \eqn{\kappa}. The bias is one GP with the
#' output as an input rather than a separate bias per output: its learned
#' correlation between outputs (`rhoB`) holds separate biases (at 0) and one
#' common bias (at 1) as special cases, so the data choose, with one set of
#' bias hyperparameters. When every run gives every
#' output at the same experimental settings the design is still a product
#' design and the Kronecker algebra applies.
#'
#' That is `outputs = "shared"`, the default: one simulator GP for every
#' output, so one set of length-scales, smoothness and variance.
#' `outputs = "independent"` gives each output its own simulator GP and its
#' own bias GP instead (`thetaS1[amount]`, `sigma2S[amount]`,
#' `sigma2B[amount]`, ...: every hyperparameter class but `sigma2E` has a
#' copy per output, named with the output in brackets), the GPs of
#' different outputs independent: only \eqn{\kappa} is shared. The
#' log-likelihood is then the sum of each output's, each output's block has
#' its own algebra (Kronecker on a product design, dense otherwise; the
#' nearest-neighbour algebra is not available with it yet), and the sampler
#' moves each output's simulator and bias hyperparameters in blocks of
#' their own. Every output needs field data (an unobserved output modelled
#' on its own says nothing about \eqn{\kappa}). Why shared stays the
#' default (`bench/RESULTS-outputs.md`): on two-output known-truth
#' problems (20 replicates each, outputs of different and of alike shapes)
#' both structures pooled to intervals about half the better output's
#' alone, shared at about 0.7 times the CPU; on the 3-output benchmark
#' shared gave intervals about half as wide as independent (both covering
#' the truth) in about the same CPU time. Try `"independent"` when the
#' outputs differ in smoothness or scale in ways one set of length-scales
#' cannot follow (compare with [loo.fbc()]).
#' `print()` says how the outputs are modelled; `loo()`, the confounding
#' check (per noise group) and the plots work per output under both.
#'
#' `source = "name"` names a factor column of `field` only: several field
#' data sets sharing \eqn{\kappa}, each with its own measurement-error
#' variance (the groups are the output x data set combinations present).
#' The bias is shared by the data sets, or with `sourceBias = "own"` each
#' data set has its own: the bias GP multiplies its correlation by a
#' correlation between the data sets (`rhoD1`, ..., an unstructured one as
#' for a categorical input), so the data show how alike the biases are;
#' [predict.fbc()] then needs the data set of each new point for every type
#' but `"simulator"`, and [level_correlation()] gives the biases'
#' correlation (`input` = the data set column). `print()` lists the groups.
#'
#' @section Sampler:
#' Both samplers are exact adaptive Metropolis-within-Gibbs: every move
#' leaves the posterior invariant, the acceptance ratios include the Jacobian
#' of each transformation, and every adapted proposal is frozen after
#' burn-in, so the retained draws come from one fixed, valid Markov kernel.
#' Positive parameters move on the log scale, smoothness parameters on the
#' logit scale of `[1, 2]`, \eqn{\kappa} and \eqn{\mu_B} on their own
#' scale. A proposal whose covariance is not positive definite is rejected.
#'
#' `sampler = "single"` is the vignette's sampler: parameters are updated one
#' at a time in the order of `Phi`'s columns, and during burn-in each
#' proposal's log standard deviation moves every 50 iterations by
#' \eqn{\pm \min(0.5, 1/\sqrt{b})} (batch `b`) towards an acceptance rate
#' of 0.44: the one adaptation rule of every adapted move (FBC 0.1.0 moved
#' single sites by \eqn{\pm 1/\sqrt{b}}, so the first three batches differ
#' and so do the draws for a given seed; the moves are 0.1.0's).
#'
#' `sampler = "blocks"` (the default) makes, in each sweep:
#' * three moves of each \eqn{\kappa_l} (a \eqn{\kappa} move needs no
#'   factorisation of the simulator block, and \eqn{\kappa} is what the user
#'   came for);
#' * two joint moves of the simulator GP's parameters (`thetaS`, `alphaS`,
#'   `sigma2S`, whose range and scale trade off), each costing one
#'   factorisation of the simulator block; on the Vecchia algebra the move
#'   walks the correlation parameters alone and draws `sigma2S` from the
#'   runs' own conditional (inverse gamma, given the proposed correlation),
#'   corrected for the field data by Metropolis-Hastings, so that it need
#'   not follow the ridge between `sigma2S` and the length-scales (at
#'   m = 1000 1.1-2.3 times the slowest parameter's ESS per CPU second in
#'   two paired runs, `bench/RESULTS-defaults.md`); after a warm-up of
#'   data-dependent length (`nBurn = NULL`, the default) a block that walks
#'   4 parameters instead proposes from a multivariate t (7 degrees
#'   of freedom) fitted to its warm-up draws (an independence
#'   Metropolis-Hastings move, exact like the others; reported as kind
#'   `"independent"`, with no adapted scale): the runs make these
#'   parameters' posterior nearly Gaussian on the walk's scale, which a walk
#'   crosses slowly (at m = 1000 the slowest length-scale's bulk ESS rose
#'   4.5-fold at the same cost, and the default run took 80-109 CPU s
#'   against 121-163). Not after a warm-up cut at its maximum, nor after an
#'   explicit `nBurn`, whose estimate's effective draws are not known, nor
#'   for 5 walked parameters or more (at m = 20,000, 5 of them, the warm-up's
#'   estimate was up to 4 times wider than the posterior and the proposal
#'   accepted 4.5%): there the block walks on;
#' * two joint moves of the bias GP's parameters (`thetaB`, `alphaB`,
#'   `sigma2B`), which touch only the field block (none under
#'   `discrepancy = "none"`);
#' * a single-site move of `sigma2E`;
#' * a jump of each \eqn{\kappa_l} with a proper prior (the default beta
#'   included; with either `sampler`), after the walks: an independence
#'   proposal drawn uniformly over the prior's range (a uniform's or beta's
#'   support; an unbounded prior's central 99.9%, e.g. a gaussian's mean
#'   \eqn{\pm} 3.29 sd, from outside which the jump is rejected, leaving the
#'   tails to the walk), accepted with the posterior ratio (exact
#'   Metropolis-Hastings, not adapted; reported as `"kappa1 jump"`). A walk adapted within one mode of a
#'   multimodal \eqn{\kappa} posterior rarely leaves it: on Tuo and Wu's
#'   problem with 12-24 runs, 4 of 6 default fits without it ran to the
#'   50,000-sweep ceiling with chains in different modes (10-14 CPU s, one
#'   with three of four chains in the mode holding about a quarter of the
#'   mass); with it all 6 converged in 0.3-0.8 CPU s. It costs about one
#'   \eqn{\kappa} move a sweep, not measurable beside the simulator block's
#'   moves at m = 40, 300 and 1000 (fixed-length one-chain runs). Default
#'   runs to convergence on a unimodal sinusoid, paired by seed
#'   (`bench/jump.R --part=default`): m = 40, 20 seeds, 12.9 CPU s in
#'   all without it, 15.9 with (the runs with it a median 14% longer, 11
#'   of 20 longer, 6 shorter); m = 300, 10 seeds, 627 against 589 s; m =
#'   1000, 10 seeds, 942 against 370 s, where without it one run reached
#'   the 50,000-sweep ceiling (535 s, kappa's R-hat 1.011) and one took
#'   166 s (kappa the last to pass), both 29-34 s with it. To
#'   run without it, build the model with `fit = FALSE`, set
#'   `model$moves$jump <- NULL` and fit it with `calibrate(model)`;
#' * an exact draw of `muB` from its Gaussian full conditional (Gibbs; when
#'   its prior is gaussian, else a random walk; none without a bias);
#' * a move multiplying `sigma2S`, `sigma2B` and `sigma2E` (without a bias:
#'   `sigma2S` and `sigma2E`) by one factor:
#'   the whole covariance scales, so its log-determinant and quadratic form
#'   follow in closed form with no factorisation.
#'
#' With 500 simulator runs or more on the dense algebra (see "Simulator
#' algebra"), each \eqn{\kappa_l} and the simulator block move once a
#' sweep instead of three and two times: there a simulator-block move costs
#' a Cholesky factorisation of the \eqn{m \times m} simulator block and a
#' \eqn{\kappa} move an \eqn{m \times m \times n} triangular solve, while
#' every other move costs \eqn{O(n^3)}; a sweep then costs about one
#' factorisation of the \eqn{(n + m) \times (n + m)} covariance
#' (`bench/scale.R`). Product designs on the Kronecker algebra keep the
#' default schedule: all their moves are cheap.
#'
#' A joint move proposes \eqn{w^* = w + e^{s} L \epsilon} on the walk scales.
#' \eqn{L} starts diagonal; after 100 burn-in sweeps it takes the shape of the
#' running covariance of the burn-in draws (Haario et al. 2001), estimated
#' afresh from the middle of burn-in so that the drift from the starting
#' point does not inflate it, and \eqn{s} adapts towards acceptance 0.234
#' (0.44 for one parameter) by the same rule. The `acceptance` of a block's
#' parameters is that of its joint move (1 for `muB`'s exact draw), and
#' `proposalSD` the proposal's marginal step on the walk's scale (for a joint
#' move \eqn{e^s} times the spread \eqn{L} gives the parameter; `NA` for an
#' exact draw or a fixed parameter). The sampler counts acceptance once, per
#' move: `print()` reports each move by name (`kappa1`, `sim`, `bias`,
#' `sigma2E`, `muB`, `kappa1 jump`, `scale`) with its acceptance over the
#' retained sweeps of all chains, and `acceptance` gives each parameter its move's rate;
#' `state$chains[[k]]$sampler$moves` holds each chain's counts and adapted
#' scales, `state$chains[[k]]$acceptance` the chain's rates by parameter and
#' `state$chains[[k]]$scaleAcceptance` its scale move's rate.
#' `bench/mixing.R` measures both samplers and Stan's NUTS on the same
#' model (see "Defaults").
#'
#' Each chain uses R's random number generator, so [set.seed()] reproduces a
#' run, and it can be interrupted with Ctrl-C: the draws retained so far are
#' returned with a warning. The sampler's whole state (parameters, adapted
#' proposals, adaptation sums) is kept in `state$chains[[k]]$sampler`, so
#' [update.fbc()] continues a chain exactly where it stopped (even within
#' burn-in).
#'
#' @section Several chains:
#' `nChains` independent chains are run through the \pkg{future} framework
#' (one future per chain): sequentially
#' when no plan is set, on the cores of one machine after
#' `future::plan(future::multisession)`, on a cluster with `plan(cluster)` or
#' a \pkg{future.batchtools} backend, with no change to the call. Each chain
#' gets its own L'Ecuyer-CMRG random stream derived from the session's RNG
#' state, so [set.seed()] reproduces a run whatever the plan. Chain 1 starts
#' at the initial values (`kappaInit`, the `*Init` of [set_hyperPriors()]);
#' the others start at draws from the priors (within their 10%-90%
#' quantiles; initial values jittered where a prior is improper), so that
#' the chains' agreement means something. `Phi` stacks the chains' retained
#' draws and `chain` gives each row's chain; the `estimates` table carries the
#' rank-normalised split R-hat (`rhat`) and bulk effective sample size
#' (`ess`) of each parameter (Vehtari et al. 2021, \pkg{posterior} package),
#' and [convergence_messages()] (shown by `print()`) flags R-hat above 1.01,
#' ESS below 400 and draws piling up at a bound. [update.fbc()] continues
#' the chains; [as_draws_df()][fbc-draws] and `coda::as.mcmc.list()` hand the
#' draws to \pkg{posterior}, \pkg{bayesplot} and \pkg{coda}.
#'
#' @section Interrupting:
#' Ctrl-C stops the chains and returns the draws kept so far as a valid
#' `fbc` object, with a warning saying how far each chain got
#' (`state$interrupted` is `TRUE`); `update(fit, nMCMC = ...)` continues it.
#' With the sequential plan the running chain stops within 100 iterations
#' and the chains not yet started are skipped. With a parallel plan the
#' workers are asked to stop at the end of their current piece of 50
#' iterations and their draws are collected, so the session and its workers
#' are ready for the next run at once; a second Ctrl-C kills this run's
#' worker processes on this machine and restarts the plan's workers, and the
#' chains then come back as far as their last checkpoint. A worker that dies
#' (killed, out of memory) costs only its chain's draws since its last
#' checkpoint: the others go on, the plan's workers are restarted, and the
#' warning names the chain.
#'
#' @section Checkpoints:
#' With `checkpoint = "<directory>"` every chain saves its whole state (the
#' sampler's parameters and adapted proposals, its random number stream's
#' position, the draws kept so far) in that directory at most every
#' `checkpointEvery` seconds and when it stops. Each chain runs in pieces of
#' 50 iterations and saves at the end of a piece; a file is written under a
#' temporary name and renamed, so a kill at any instant leaves a readable
#' checkpoint. The directory also holds the run's data, priors, settings and
#' each chain's start, so that calling `calibrate()` again with the same
#' data and settings and the same `checkpoint` resumes the run after a
#' Ctrl-C, a killed worker, a crashed session or a cluster job's time limit:
#' every chain continues from its last checkpoint (chains that had not
#' started start), on whatever plan is set then, and the draws are exactly
#' those of an uninterrupted run with the same seed (the session's seed
#' does not matter when resuming: the streams are in the checkpoint). A
#' finished run's directory gives the fit back without sampling. A
#' directory holding another run (other data, priors or settings), a
#' corrupt checkpoint, or a non-empty directory that is not a checkpoint is
#' refused with a message saying what differs, and nothing is written. The
#' directory must be on storage the workers share (on a cluster, not a
#' node's local disk); see `vignette("clusters", package = "FBC")`.
#'
#' @section Warm-up and stopping when converged:
#' By default (`nBurn = NULL`) each chain warms up for as long as its
#' proposals need, as Stan's warm-up does: the proposals adapt as under a
#' fixed burn-in (see "Sampler"), and at the end of every window of 100
#' sweeps the chain checks whether they have settled: every adapted move's
#' acceptance over the window within 0.15 of its target, its proposal's log
#' size moved by at most 2.5 adaptation steps over the last two windows
#' (the steps cancel around the right scale and add up while it is still
#' walking), and every joint proposal's shape (its SD per parameter,
#' relative to its size) within 35% of the last window's, and, for a joint
#' proposal of 4 or more parameters, learnt from at least 10 effective draws
#' per parameter (batch means over the windows since its estimate started:
#' at m = 1000 scattered runs a shape learnt from fewer left the simulator's
#' block mixing at half the rate, see `bench/RESULTS-defaults.md`).
#' Warm-up ends at
#' the second settled window in a row, after at least 200 sweeps and at
#' most 5000 (or half of an explicit `nMCMC`); the joint proposals' running
#' covariance starts afresh at sweeps 200, 400, 800, ..., so it leaves out
#' the drift from the start as a fixed burn-in's second half does. Each
#' chain decides for itself: `fit$settings$warmup` has each chain's
#' warm-up length (`settings$warmupCapped` the chains that reached the
#' maximum), and `print()` says it. Draws are kept, every `thinning`-th, from
#' the end of each chain's warm-up.
#'
#' By default (`nMCMC = NULL`, `converge = NULL`) the run stops when it has
#' converged: each chain runs 500 sweeps after its warm-up, then the draws
#' of all chains are checked, and while some sampled parameter has R-hat of
#' 1.01 or more or bulk ESS below 400 every chain runs further, half as many
#' sweeps again as it has retained (500, 750, 1150, ... after warm-up), up to
#' `maxMCMC` (50000) sweeps per chain. [until_converged()] sets other
#' thresholds, a fixed step (`every`) or another ceiling; `converge = TRUE`
#' is its defaults. With an explicit `nMCMC` the run has that many sweeps
#' (`converge = NULL` or `FALSE`), or the rule's first check falls after
#' `nMCMC` sweeps (`converge = TRUE` or a rule); with an explicit `nBurn` the
#' burn-in is fixed. An explicit `nMCMC` and `nBurn` give the draws of
#' earlier versions. The chains continue their own random streams, and
#' each check reads the draws up to its sweep count only: a run of
#' data-dependent length (warm-up or stopping) is one run, reproduced by
#' [set.seed()] on any plan and resumed from a checkpoint to the same end
#' with the same draws. Warm-up is not extended by the rule. `print()` says
#' how many checks it took and whether the rule was met, and
#' `fit$settings$converge` keeps it. [update.fbc()] takes the same rule.
#'
#' @section Defaults:
#' `nChains = 4`, `thinning = 2`, a warm-up of data-dependent length and a
#' run until every R-hat < 1.01 and bulk ESS >= 400 (see "Warm-up and
#' stopping when converged"). Four chains are the usual minimum for R-hat to
#' detect chains stuck in different places. On the ball data the default
#' run's chains warm up for about 500-1100 sweeps and stop after one to
#' six checks (`bench/RESULTS-warmup.md`); the earlier defaults,
#' `nMCMC = 8000, nBurn = 2000`, ran 4 x 8000 sweeps whatever the data (on
#' the ball data R-hat <= 1.0021 and bulk ESS >= 1999 for seeds 1, 77 and
#' 2024, in 26-27 CPU seconds) and still give the same draws when given. In
#' `bench/mixing.R` the default sampler's slowest parameter gains
#' about 100 effective draws per CPU second on the ball data, 17 times
#' Stan's NUTS on the same model and priors, and `kappa` about 300, 42 times
#' Stan's. Thinning by 2 halves the memory at little cost in ESS. Harder
#' problems (more parameters, larger data) need longer runs, which the rule
#' makes up to its ceiling: check `convergence_messages(fit)` (or
#' `print(fit)`) and continue with [update.fbc()].
#'
#' @section Columns:
#' When both `sim` and `field` carry column names (matrices with
#' `colnames()`, data frames), the columns are matched by name, as
#' [model.frame()] does: the columns of `field` are the response and the
#' experimental inputs, in any order, under the names they have in `sim`;
#' the columns of `sim` that `field` does not have are the calibration
#' inputs (`kappa1`, ..., `kappaq`, in `sim`'s order). The names alone do not
#' say which shared column is the response: it is `sim`'s first column when
#' that is a column of `field` and `sim`'s last column is not (the
#' documented order: response first, calibration inputs last; `field` in any
#' order). Otherwise, for a `sim` stored as inputs then output, it is
#' `field`'s first column when that is `sim`'s first or last column and
#' `field`'s last column is not the other one (so `sim = ballSim[, c("g",
#' "h", "t")]` with `ballField` calibrates as `ballSim` does). Any other
#' case, such as `ballSim[, c("h", "g", "t")]` with `ballField` (either `h`
#' or `t` could be the response), is refused naming both candidates. A
#' column of `field` that `sim` lacks, or a name used twice, is refused with
#' the names of both sides. When either has no usable names (a matrix
#' without column names, or a name missing), the columns are taken by
#' position: the response first, then the `p` experimental inputs in the
#' same order in both, then `sim`'s `q` calibration inputs. The names label
#' the results (`fit$scale$names`, `print()`, `plot()`), and [predict.fbc()]
#' matches the columns of `newdata` by name in the same way.
#'
#' @section Checks:
#' Besides refusing malformed data and settings with a message naming the
#' argument, `calibrate()` warns when field inputs lie outside the simulator
#' design's range by more than 5% of its width (the emulator extrapolates
#' there), says when `sim` holds
#' duplicated runs (identical input rows: legal thanks to the nugget, but
#' they add nothing), refuses run lengths whose retained draws could not be
#' stored (saying how much memory they would need), and refuses a prior
#' family given without its own parameters (see `kappaDist`).
#'
#' The emulator knows the simulator only over the range of each calibration
#' input its runs cover (the "design range"); a value of \eqn{\kappa} beyond
#' it rests on the emulator's extrapolation. The default beta prior is
#' stretched over that range and never reaches beyond it; a prior given in
#' the calibration inputs' own units can. `calibrate()` refuses a prior that
#' puts less than `1e-9` of its mass on the design range (naming the prior
#' and the range), and warns (class `fbc_extrapolation`) when a prior puts
#' more than 1% of its mass beyond the design range widened by 5% of its
#' width on each side (an improper prior: when its support does), saying
#' where the prior reaches (its support, or its central 99% when the support
#' is unbounded), or when a fixed \eqn{\kappa} lies beyond it. After the
#' run, [convergence_messages()] (shown by `print()`) says when more than 1%
#' of the draws of a calibration parameter lie there, and [predict.fbc()]
#' warns when the draws it uses do.
#'
#' @param sim Simulator runs: a numeric matrix or data frame with the
#'   response, the `p` experimental inputs and the `q` calibration inputs
#'   (matched by name or by position: see "Columns"); or the simulator
#'   itself as an R function `f(x, kappa)`, called inside the sampler (see
#'   "The simulator as a function"); or an `fbc_model` from
#'   `calibrate(..., fit = FALSE)` to fit.
#' @param field Field data: the response and the same `p` experimental
#'   inputs (see "Columns").
#' @param nMCMC Total number of MCMC iterations (sweeps) per chain, burn-in
#'   included. `NULL` (the default): until converged (see `converge`), or
#'   8000 sweeps with `converge = FALSE`.
#' @param nBurn Number of initial iterations discarded; the proposals adapt
#'   during these. `NULL` (the default): each chain warms up until its
#'   proposals have settled, between 200 and 5000 sweeps (see "Warm-up and
#'   stopping when converged").
#' @param thinning Keep every `thinning`-th iteration after burn-in.
#' @param nChains Number of independent chains (see "Several chains").
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
#'   and one with no support on it is refused (see "Checks").
#' @param hypers Hyperparameter priors from [set_hyperPriors()].
#' @param discrepancy The discrepancy model: `"gp"` (the default, the bias
#'   GP), `"sgasp"` (the scaled GP of Gu and Wang 2018) or `"none"` (no
#'   discrepancy); see "Discrepancy models".
#' @param kernelS,kernelB Correlation family of the simulator GP and of the
#'   bias GP: `"matern52"` (the default), `"powexp"` (the vignette's),
#'   `"gaussian"` or `"matern32"` (see "Correlation families").
#' @param showProgress Show a progress bar over all chains (on any plan: the
#'   workers report through \pkg{progressr}) with the time left and each
#'   chain's acceptance rate after burn-in (mean over its parameters).
#'   `NULL` (the default) shows it where a person waits for the run, in an
#'   interactive session, and prints nothing in scripts (`Rscript`) or
#'   while \pkg{knitr} renders a document; `TRUE` or `FALSE` decide.
#' @param sampler `"blocks"` (the default: joint and exact moves, see
#'   "Sampler") or `"single"` (the vignette's one-at-a-time sampler).
#' @param algebra `"auto"` (the default: the Kronecker algebra on a product
#'   design, else the exact dense one while a sweep of it is projected to
#'   cost under 0.1 s, else the nearest-neighbour approximation), `"dense"`
#'   (always the exact dense one) or `"vecchia"` (the nearest-neighbour
#'   approximation); see "Simulator algebra". `print()` says which ran and
#'   why.
#' @param neighbours For the nearest-neighbour algebra: how many neighbours
#'   each simulator run and each field point conditions on (a whole number,
#'   at least 1; more is closer to exact and slower). `NULL` (the default):
#'   20 below 4000 runs, 10 from 4000 on. Measured on scattered designs
#'   (`bench/RESULTS-vecchia.md`): with 20, `kappa`'s quantiles within
#'   0.05 posterior sd of the exact algebra's at m = 1000; with 10, within
#'   0.1 sd at m = 500, a sweep costs about half and m = 20,000 runs
#'   converged in 31 CPU minutes (4 chains, `nBurn = 3000`) where 20 had not
#'   in 60. Given with an algebra that has no neighbours, it is not used and
#'   a message says so.
#' @param blockSim Deprecated: `TRUE` is `sampler = "blocks"` and `FALSE`
#'   `sampler = "single"`, with a warning.
#' @param checkpoint `NULL` (no checkpoints) or a directory where the chains
#'   save checkpoints (created if needed; see "Checkpoints"). When it holds
#'   a checkpoint of the same run, the run is resumed from it.
#' @param checkpointEvery Seconds between a chain's checkpoints (it also
#'   saves when it stops); `0` saves after every piece of 50 iterations.
#' @param output For several outputs in long format: the name of a factor
#'   (or character) column of both `sim` and `field` saying which output
#'   each row holds; see "Categorical inputs, outputs and data sets" (with
#'   a simulator function, a column of `field`: see "The simulator as a
#'   function").
#' @param outputs With `output`: how the outputs are modelled. `"shared"`
#'   (default): one simulator GP over the inputs and the output, the outputs
#'   correlated by a learned level correlation (`rhoS`; the bias likewise,
#'   `rhoB`). `"independent"`: each output its own simulator and bias GP
#'   (its own length-scales, smoothness and variances), only `kappa` shared.
#'   See "Categorical inputs, outputs and data sets".
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
#'   chain's warm-up (or after `nMCMC` sweeps when given); see "Warm-up and
#'   stopping when converged".
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
#' @return An object of class `fbc`: a list with `Phi` (one row per retained
#'   draw, chains stacked; one column per parameter, in the order `kappa`,
#'   `thetaS`, `alphaS`, `thetaB`, `alphaB`, `sigma2S`, `sigma2B`, `sigma2E`,
#'   `muB`, without `alphaS`/`alphaB` for a family that has no smoothness
#'   and without the bias's parameters under `discrepancy = "none"`),
#'   `chain` (the chain of each row), `estimates` (posterior summaries with
#'   `rhat` and `ess`), `logPost`, `priors`, `acceptance`, `vars` (the names
#'   of `Phi`'s columns), `data`, `scale`, `indices` (for each parameter
#'   class, the columns of `Phi` holding it: `integer(0)` for a smoothness
#'   that is not sampled), `priorFns`, `proposalSD`, `call`, `settings`
#'   (the run's: MCMC sizes, nugget, run time, checkpoint directory, the
#'   convergence rule), `model` (the [fbc_model] fitted: `kernelS`,
#'   `kernelB`, `discrepancy`, `sampler` and its `moves`, the `algebra`
#'   that ran (`name`, `dims` of a product design, `neighbours`, `reason`),
#'   ...), `state` (`chains`: where
#'   each chain stopped, its adapted proposal scales and acceptance, over
#'   the sampler's full parameter vector; `interrupted`), `spec` (the model
#'   description the copies `priors`, `vars`, `indices` and `priorFns` come
#'   from) and `version` (`fbc`: the version of FBC that made it; `format`:
#'   the object's format). A fit saved by an earlier FBC is brought to the
#'   current format by every function that takes one, and an
#'   earlier version's checkpoint directory resumes.
#' @export
#' @examples
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 800, nBurn = 300, nChains = 2)
#' fit
#' \donttest{
#' # the defaults: 4 chains until every R-hat < 1.01 and bulk ESS >= 400
#' # (or in parallel after future::plan(future::multisession, workers = 2))
#' fit <- calibrate(ballSim, ballField)
#' fit$estimates[, c("mean", "lwr80", "upr80", "rhat", "ess")]
#' }
#' # checkpoints: the same call resumes an interrupted run, or returns a
#' # finished one
#' dir <- file.path(tempdir(), "ball-run")
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 400, nBurn = 200, nChains = 2,
#'                  checkpoint = dir)
#' again <- calibrate(ballSim, ballField, nMCMC = 400, nBurn = 200, nChains = 2,
#'                    checkpoint = dir)
#' identical(fit$Phi, again$Phi)
#' unlink(dir, recursive = TRUE)
#' # a Matern 5/2 simulator GP: no alphaS to sample
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 600, nBurn = 200, nChains = 2,
#'                  kernelS = "matern52")
#' colnames(fit$Phi)
#' # no discrepancy: y_f = eta(x, kappa) + eps, no bias parameters
#' set.seed(1)
#' fit <- calibrate(ballSim, ballField, nMCMC = 600, nBurn = 200, nChains = 2,
#'                  discrepancy = "none")
#' colnames(fit$Phi)
#' # the simulator as an R function (no runs, no emulator)
#' f <- function(x, kappa) 5 * exp(-kappa[["u"]] * x$t)
#' set.seed(1)
#' fit <- calibrate(f, as.data.frame(kineticField), kappaDist = "uniform",
#'                  kappaP1 = c(u = 0.5), kappaP2 = c(u = 3), nMCMC = 600,
#'                  nBurn = 200, nChains = 2)
#' fit
calibrate <- function(sim, field, nMCMC = NULL, nBurn = NULL, thinning = 2,
                      nChains = 4, kappaDist = "beta", kappaInit = NA, kappaP1 = 1.1,
                      kappaP2 = 1.1, hypers = set_hyperPriors(), discrepancy = "gp",
                      kernelS = "matern52",
                      kernelB = "matern52", showProgress = NULL, sampler = c("blocks", "single"),
                      blockSim = NULL, algebra = c("auto", "dense", "vecchia"),
                      neighbours = NULL, checkpoint = NULL,
                      checkpointEvery = 60, converge = NULL, output = NULL, source = NULL,
                      sourceBias = c("shared", "own"), outputs = c("shared", "independent"),
                      fit = TRUE, nonFinite = c("error", "reject")) {
  call <- match.call()
  run <- check_run(nMCMC, nBurn, thinning, nChains, converge, showProgress, checkpoint,
                   checkpointEvery)
  if (inherits(sim, "fbc_model")) return(fit_model(model_to_fit(sim, call), run))
  check_flag(fit, "fit")
  if (is.function(sim)) {
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
                       sourceBias = sourceBias, outputs = outputs, modelCall = call)
  if (!fit) return(model)
  fit_model(model, run)
}
