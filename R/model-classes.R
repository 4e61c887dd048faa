# The model description: every parameter class of the KOH model, in one
# table that all code reads (the parameter layout, priors' domains, walks,
# initial proposal scales, the sampler's moves, Phi's columns, plot labels,
# the conflict check, checkpoints' identity and the tests' helpers). Adding a
# class is one row here, its default prior and help in class_priors below
# and the code that computes with it: the compiled core keeps no list of the
# classes, it receives each class's offset and length by name
# (compiled_model()) and looks up those it computes with (src/model.cpp,
# class_needs(): its length, the member holding its offset and the algebras
# that compute with it, which choose the algebra, classes_outside()); the
# package checks when it loads that R's table names every one of them
# (check_model_codes(), R/boundary.R). A class over "asked" is one a user
# adds by giving its prior: models without it keep their layouts.
#
# Columns:
#   class    name, in the vignette's notation; its parameters are named
#            class1, class2, ... (muB, sigma2S ...: one parameter, no index)
#   over     what the class expands over: "calibration" (one per
#            calibration input, q), "inputs" (one per simulator input,
#            p + q: experimental then calibration), "experimental" (p),
#            "noise" (one per measurement-error group of the field data:
#            outputs x sources, see R/factors.R), "levels" (the canonical
#            partial correlations of the categorical inputs' levels,
#            L (L - 1) / 2 per input with L levels), "sources" (the
#            partial correlations between the field data sets' biases when
#            each has its own: L (L - 1) / 2 for L data sets),
#            "replicates" (one when the simulator's own noise is modelled
#            as constant, R/sim_noise.R; else none), "unique" (one per unique
#            simulator input with an input-dependent noise: its latent
#            log-variances; else none), "latent" (one with an
#            input-dependent noise, else none), "latentInputs" (p + q with
#            an input-dependent noise, else none), "one", "asked" (one
#            when the model is given the class's prior, set_hyperPriors()'s
#            <class>Dist, whose default NULL leaves the class out: a
#            parameter a user adds; asked_classes())
#   domain   "real", "positive", "unit12" ([1, 2]) or "corr" ((-1, 1))
#   walk     the scale its random walk runs on: "identity", "log",
#            "logit12" (logit of x - 1), "atanh" (Fisher's z)
#   sd0      initial proposal SD on that scale
#   move     the move of sampler = "blocks" it belongs to: "slice" (the
#            class's parameters all at once by elliptical slice sampling,
#            src/latent_noise.cpp), "each" (one move
#            per parameter, repeated), "sim", "bias" (joint moves of the
#            simulator and bias GPs; "noise": of the latent noise GP's
#            hyperparameters, whose variance and ranges trade off), "single"
#            (single site), "gibbs" (an
#            exact draw when its prior allows, else single site); the
#            simulator's noise variance sigma2R moves with the simulator
#            GP's block, since each of its moves refactors the runs' system
#            (alone it doubled a sweep's cost at m = 1000)
#   joint    (with move "each") also one joint adapted walk of the class's
#            free parameters, beside their own moves, when it has at least
#            two: calibration inputs that trade off move along their ridge
#            (sampler_moves(), "overlay")
#   scaled   multiplied by the common-scale move (see vignette("sampler"))
#   touch    what a move of it touches in the compiled core's cached
#            factors (touch_codes, R/boundary.R): "kappa", "sim" (the
#            simulator GP's correlation), "simPow" (... and the input's
#            power matrix: a smoothness), "simLevels" (... as an
#            experimental input's), "bias", "biasPow" (the bias GP's,
#            likewise), "field" (the field block's variances), "runs" (the
#            simulator block's values), "residual" (the residual only)
#   smooth   the GP ("S" or "B") whose family decides whether the class is
#            a parameter at all (a smoothness), "" when it always is
#   perOutput  with outputs = "independent" (several outputs, each its own
#            simulator and bias GP; see R/outputs.R) the class has one copy
#            per output, output after output; kappa is shared and sigma2E
#            is per measurement-error group (output x data set) already
model_classes <- data.frame(
  class  = c("kappa", "thetaS", "alphaS", "rhoS", "thetaB", "alphaB", "rhoB", "rhoD", "lambdaZ", "sigma2S", "sigma2B", "sigma2E", "muB", "sigma2R", "gR", "muG", "sigma2G", "thetaG"),
  over   = c("calibration", "inputs", "inputs", "levels", "experimental", "experimental", "levels", "sources", "one", "one", "one", "noise", "one", "replicates", "unique", "latent", "latent", "latentInputs"),
  domain = c("real", "positive", "unit12", "corr", "positive", "unit12", "corr", "corr", "positive", "positive", "positive", "positive", "real", "positive", "real", "real", "positive", "positive"),
  walk   = c("identity", "log", "logit12", "atanh", "log", "logit12", "atanh", "atanh", "log", "log", "log", "log", "identity", "log", "identity", "identity", "log", "log"),
  sd0    = c(0.1, 0.5, 0.5, 0.3, 0.5, 0.5, 0.3, 0.3, 0.5, 0.3, 0.3, 0.3, 0.1, 0.1, 0.1, 0.3, 0.3, 0.3),
  move   = c("each", "sim", "sim", "sim", "bias", "bias", "bias", "bias", "bias", "sim", "bias", "single", "gibbs", "sim", "slice", "noise", "noise", "noise"),
  joint  = c(TRUE, FALSE, FALSE, FALSE, FALSE, FALSE, FALSE, FALSE, FALSE, FALSE, FALSE, FALSE, FALSE, FALSE, FALSE, FALSE, FALSE, FALSE),
  scaled = c(FALSE, FALSE, FALSE, FALSE, FALSE, FALSE, FALSE, FALSE, FALSE, TRUE, TRUE, TRUE, FALSE, TRUE, FALSE, FALSE, FALSE, FALSE),
  touch  = c("kappa", "sim", "simPow", "simLevels", "bias", "biasPow", "bias", "bias", "bias", "field", "field", "field", "residual", "runs", "latent", "latentHyper", "latentHyper", "latentK"),
  smooth = c("", "", "S", "", "", "B", "", "", "", "", "", "", "", "", "", "", "", ""),
  perOutput = c(FALSE, TRUE, TRUE, TRUE, TRUE, TRUE, TRUE, TRUE, TRUE, TRUE, TRUE, FALSE, TRUE, FALSE, FALSE, FALSE, FALSE, FALSE),
  stringsAsFactors = FALSE
)

# The default prior of each class that set_hyperPriors() takes (kappa's is
# calibrate()'s; gR's is the GP of muG, sigma2G and thetaG, sim_noise_priors()):
# `prior` its family, initial value (NA: from the data, or the family's
# centre) and the family's two parameters, the defaults of set_hyperPriors()'
# arguments <class>Dist, <class>Init, <class>P1 and <class>P2 (in this
# order, which is theirs; a class over "asked" has the family NULL: none
# unless a user gives one); `help` those arguments' help (roxygen markdown,
# pasted; a class without one is documented with the class before it;
# "{with}" stands for the discrepancy models with the class, "{without}"
# for those with a bias GP but without it: class_models_docs()).
class_priors <- list(
  thetaS = list(prior = alist("gamma", 1, 1.1, 0.1),
    help = "Simulator GP correlation scales."),
  alphaS = list(prior = alist("betashift", 1.9, 5, 2),
    help = c("Simulator GP smoothness, in `[1, 2]` (power-exponential family only: with",
      "another `kernelS` in [calibrate()] it is not a parameter and these are ignored,",
      "with a warning).")),
  thetaB = list(prior = alist("gamma", 1, 1.1, 0.1),
    help = "Bias GP correlation scales."),
  alphaB = list(prior = alist("betashift", 1.9, 5, 2),
    help = c("Bias GP smoothness, in `[1, 2]` (power exponential only, as for `alphaS` with",
      "`kernelB`).")),
  sigma2S = list(prior = alist("inversegamma", 1, 1.5, 1.5),
    help = "Simulator GP marginal variance."),
  sigma2B = list(prior = alist("inversegamma", 0.1, 1.5, 1.5),
    help = "Bias GP marginal variance."),
  sigma2E = list(prior = alist("halft_sd", 0.1, 1, 1),
    help = "Measurement error variance."),
  muB = list(prior = alist("gaussian", 0, 0, 1),
    help = c("Bias GP mean (not under {without}, whose bias has mean 0).")),
  lambdaZ = list(prior = alist("lognormal", 20, log(20), 1.5),
    help = c("Scale \\eqn{\\lambda_z} of the S-GaSP discrepancy ({with} in",
      "[calibrate()] only): how strongly the bias's L2 norm is shrunk. The default",
      "lognormal prior has median 20 (meanlog `log(20)`, sdlog 1.5: 95% between about 1",
      "and 380), around the value RobustCalibration's default rule \\eqn{\\sqrt{n \\|\\beta",
      "L\\| \\sigma^2_B / \\sigma^2_E}} gives on the ball and kinetics data; fix it with",
      "`lambdaZDist = \"fixed\", lambdaZInit =`.")),
  rhoS = list(prior = alist("uniform", 0, -1, 1),
    help = c("The levels' correlations of categorical inputs (see \"Categorical inputs\" in",
      "[calibrate()]), in the simulator and bias GPs: their canonical partial",
      "correlations, in `(-1, 1)`, \\eqn{L(L-1)/2} per input with \\eqn{L} levels (with",
      "two levels, the correlation itself). Default uniform on `(-1, 1)`, starting at 0",
      "(levels uncorrelated).")),
  rhoB = list(prior = alist("uniform", 0, -1, 1)),
  rhoD = list(prior = alist("uniform", 0, -1, 1),
    help = c("With `sourceBias = \"own\"` in [calibrate()], the correlation between the field",
      "data sets' biases: its canonical partial correlations, as for `rhoB` (one for",
      "two data sets). Default uniform on `(-1, 1)`; `rhoDDist = \"fixed\", rhoDInit = 0`",
      "makes the biases independent.")),
  sigma2R = list(prior = alist("halft_sd", NA, 1, 1),
    help = c("The simulator's own noise variance \\eqn{r} of a stochastic simulator (`simNoise",
      "= \"constant\"` in [calibrate()]; see [simulator_noise]). Default: a half-Cauchy",
      "on its sd (`\"halft_sd\"`, 1 degree of freedom, scale 1, the standardised",
      "response's sd), weakly informative, as for \\eqn{\\sigma^2_E}: the replicates'",
      "spread sets it. Started at the pooled within-replicate variance unless",
      "`sigma2RInit` is given.")),
  muG = list(prior = alist("gaussian", NA, -3, 3),
    help = c("An input-dependent simulator noise (`simNoise = \"input\"`; see",
      "[simulator_noise]): its log-variance on the standardised response's scale is a",
      "GP with mean \\eqn{\\mu_g} (default gaussian, mean -3, sd 3: noise sds from 0.001",
      "to 20 times the response's sd within two prior sds; started at the mean of the",
      "unique inputs' log within-replicate variances), variance \\eqn{\\sigma^2_g}",
      "(half-Cauchy on its sd, scale 1: the log-variance varying by a factor of about e",
      "over the inputs) and the Mat\u00e9rn 5/2 correlation's \\eqn{\\theta_{g,k}} (\\eqn{h_k =",
      "\\sqrt{\\theta_{g,k}} d_k}) over the inputs scaled to \\eqn{[0, 1]} (default",
      "lognormal, median 2, sdlog 0.7: 95% between 0.5 and 8, a correlation of 0.8 to",
      "0.07 across an input's range, a noise that changes smoothly; its tail towards 0",
      "kept thin, as there the correlation flattens while \\eqn{\\sigma^2_g} grows",
      "without bound, a ridge the sampler crosses slowly).")),
  sigma2G = list(prior = alist("halft_sd", 1, 1, 1)),
  thetaG = list(prior = alist("lognormal", 2, log(2), 0.7))
)

# The smoothness classes (parameters only for a family that has one), the
# argument of calibrate() choosing that family, and the classes with one
# parameter per input (labelled with the input's name).
smooth_classes <- model_classes$class[model_classes$smooth != ""]
kernel_arg <- function(cls) paste0("kernel", model_classes$smooth[match(cls, model_classes$class)])
per_input_classes <- model_classes$class[model_classes$over %in% c("inputs", "experimental")]


# The domains of the table's `domain` column, with numeric bounds: a
# sampled parameter lies strictly inside (its walk maps the open interval
# onto the line), a fixed one may sit on a bound; `what` says it in words.
model_domains <- data.frame(
  domain = c("real", "positive", "unit12", "corr"),
  lower  = c(-Inf, 0, 1, -1),
  upper  = c(Inf, Inf, 2, 1),
  what   = c("finite", "positive", "in [1, 2]", "in [-1, 1]"),
  stringsAsFactors = FALSE
)
# The bounds c(lower, upper) of class `cls`'s domain.
domain_bounds <- function(cls) {
  row <- match(class_domain[[cls]], model_domains$domain)
  c(model_domains$lower[row], model_domains$upper[row])
}

# Lookups by class, all read off the table.
param_classes <- model_classes$class
class_domain <- stats::setNames(model_classes$domain, model_classes$class)
class_transform <- stats::setNames(walk_codes[model_classes$walk], model_classes$class)

# The discrepancy models of calibrate(discrepancy =), one row each, the one
# description all code and help read (the compiled core sees a model only
# through its layout: a bias GP when sigma2B has parameters, see src/fbc.h):
#   name     the choice's name (the first is the default)
#   code     its code in a fit's compiled model (spec$model$discrepancy;
#            fits store it, so a code never changes)
#   label    print()'s name of the model
#   classes  the classes of the bias GP it has (space separated); a class
#            named by no model is in every model
#   help     what it is, for calibrate()'s help (roxygen markdown, after
#            the name: discrepancy_docs())
discrepancy_models <- rows_table(
  list(name = "gp", code = 0L, label = "Kennedy-O'Hagan",
       classes = "thetaB alphaB rhoB rhoD sigma2B muB",
       help = "the bias GP, with mean `muB`"),
  list(name = "sgasp", code = 2L, label = "S-GaSP discrepancy, Gu and Wang 2018",
       classes = "thetaB alphaB rhoB rhoD sigma2B lambdaZ",
       help = "the scaled GP of Gu and Wang 2018, with mean 0 and scale `lambdaZ`"),
  list(name = "none", code = 1L, label = "no discrepancy: y_f = eta(x, kappa) + eps",
       classes = "", help = "no discrepancy")
)
discrepancy_codes <- stats::setNames(discrepancy_models$code, discrepancy_models$name)

# The discrepancy model of a code, and column `what` of a model's row.
discrepancy_name <- function(code) names(discrepancy_codes)[match(code, discrepancy_codes)]
discrepancy_info <- function(discrepancy, what) {
  discrepancy_models[[what]][match(discrepancy, discrepancy_models$name)]
}

# Does each class have parameters under the discrepancy model? (A logical
# vector over model_classes.)
class_in_model <- function(discrepancy) {
  has <- strsplit(discrepancy_models$classes, " ", fixed = TRUE)
  some <- unique(unlist(has))
  !model_classes$class %in% some |
    model_classes$class %in% has[[match(discrepancy, discrepancy_models$name)]]
}

# The discrepancy models with parameters of class `cls` (in the table's
# order); bias = TRUE: only those with a bias GP (sigma2B).
class_models <- function(cls, bias = FALSE) {
  has <- function(d, cls) class_in_model(d)[match(cls, model_classes$class)]
  keep <- vapply(discrepancy_models$name, function(d) has(d, cls) && (!bias || has(d, "sigma2B")),
                 logical(1))
  discrepancy_models$name[keep]
}

# "a", "a or b", "a, b or c".
or_list <- function(x) {
  if (length(x) < 2L) return(x)
  paste(paste(x[-length(x)], collapse = ", "), "or", x[length(x)])
}

# Why the discrepancy model has no parameter of class `cls`, and which
# models have one (for messages): a model without a bias GP has none of
# its classes; a class some models with a bias GP lack says so in its own
# words (class_lacks).
class_lacks <- c(muB = "has no bias mean (its bias has mean 0)",
                 lambdaZ = "has no S-GaSP scale")
discrepancy_lacks <- function(cls, discrepancy) {
  if (!discrepancy %in% class_models("sigma2B")) return("has no bias GP")
  if (cls %in% names(class_lacks)) class_lacks[[cls]] else "has no such parameter"
}
discrepancy_having <- function(cls) {
  sprintf("Use %s in `calibrate()` to sample `%s`.",
          or_list(sprintf("`discrepancy = \"%s\"`", class_models(cls))), cls)
}

# The help of calibrate()'s argument `discrepancy` (roxygen, @eval): the
# models in the table's order with their `help`, the first the default.
discrepancy_docs <- function() {
  d <- discrepancy_models
  what <- paste0(c("the default, ", rep("", nrow(d) - 1L)), d$help)
  paste0("@param discrepancy The discrepancy model: ",
         or_list(sprintf("`\"%s\"` (%s)", d$name, what)), ".")
}

# A class's help with "{with}" and "{without}" (class_priors) replaced by
# the models with the class and those with a bias GP but without it
# (`discrepancy = "a"` or `"b"`).
class_models_docs <- function(help, cls) {
  name <- function(x) if (length(x)) or_list(sprintf(c("`discrepancy = \"%s\"`", rep("`\"%s\"`", length(x) - 1L)), x)) else "none"
  help <- gsub("{with}", name(class_models(cls)), help, fixed = TRUE)
  gsub("{without}", name(setdiff(class_models("sigma2B"), class_models(cls))), help, fixed = TRUE)
}

# How many parameters each class has with p experimental and q calibration
# inputs under the discrepancy model `discrepancy`, with `noise`
# measurement-error groups (named by class, in the table's order; the bias
# classes have none without a bias), `outputs` independent outputs (the
# perOutput classes have a copy per output) and, for a simulator given as
# a function (`emulator` FALSE), no simulator-GP classes; `replicates`
# the noise classes' sizes (noise_sizes(), R/sim_noise.R): 1 for a
# constant noise (sigma2R), c(0, m) for an input-dependent one over m
# unique inputs (gR, muG, sigma2G, thetaG); `asked` the classes over
# "asked" that the model has (asked_classes()).
class_sizes <- function(p, q, discrepancy = "gp", noise = 1L, levels = 0L, sources = 0L,
                        outputs = 1L, emulator = TRUE, replicates = 0L, asked = character()) {
  rp <- c(as.integer(replicates), 0L)[1:2]
  n <- c(calibration = q, inputs = p + q, experimental = p, one = 1L, noise = noise,
         levels = levels, sources = sources, replicates = rp[1], unique = rp[2],
         latent = as.integer(rp[2] > 0L), latentInputs = if (rp[2] > 0L) p + q else 0L, asked = 1L)
  n <- as.integer(n[model_classes$over])
  n[model_classes$over == "asked" & !model_classes$class %in% asked] <- 0L
  n[!class_in_model(discrepancy)] <- 0L
  n[model_classes$perOutput] <- n[model_classes$perOutput] * as.integer(outputs)
  # a simulator given as a function (R/simulator_function.R) has no
  # simulator GP, hence none of its classes
  if (!emulator) n[model_classes$class %in% emulator_classes] <- 0L
  stats::setNames(n, model_classes$class)
}

# The classes of the simulator GP (the emulator): none when the simulator
# is a function.
emulator_classes <- c("thetaS", "alphaS", "rhoS", "sigma2S")

# The classes a user adds (over "asked"), and those of them a model has:
# those `hypers` gives a prior (an fbc_hypers), or, from a compiled model
# (its `offset` and `length`), those its layout holds.
user_classes <- model_classes$class[model_classes$over == "asked"]
asked_classes <- function(hypers = NULL, compiled = NULL) {
  if (!is.null(compiled)) return(intersect(user_classes, names(compiled$length)[compiled$length > 0L]))
  user_classes[!vapply(user_classes, function(cls) is.null(hypers[[cls]]), logical(1))]
}

# The layout of phi, the sampler's parameter vector: for each class, its
# 1-based positions (a named list; integer(0) for an empty class).
param_indices <- function(p, q, discrepancy = "gp", noise = 1L, levels = 0L,
                           sources = 0L, outputs = 1L, emulator = TRUE, replicates = 0L,
                           asked = character()) {
  sizes <- class_sizes(p, q, discrepancy, noise, levels, sources, outputs = outputs,
                       emulator = emulator, replicates = replicates, asked = asked)
  # the simulator's own noise and the classes a user adds are in the layout
  # only of the models that have them: every other model's layout is the one
  # it has always been (fits and checkpoints made before the classes existed
  # keep theirs)
  later <- c(sim_noise_classes, user_classes)
  sizes <- sizes[!(names(sizes) %in% later & sizes == 0L)]
  ends <- unname(cumsum(sizes))
  stats::setNames(lapply(seq_along(sizes), function(i) seq_len(sizes[[i]]) + ends[i] - sizes[[i]]),
                  names(sizes))
}

# Parameter names in the order of phi: the class name, with an index when
# the class expands over inputs (or over several noise groups); with
# independent outputs (`outputs`: their labels, or a count) a perOutput
# class's copies end in "[label]" (thetaS1[amount], sigma2S[amount]).
param_names <- function(p, q, discrepancy = "gp", noise = 1L, levels = 0L,
                         sources = 0L, outputs = 1L, emulator = TRUE, replicates = 0L,
                         asked = character()) {
  K <- if (is.character(outputs)) length(outputs) else as.integer(outputs)
  lab <- if (is.character(outputs)) outputs else as.character(seq_len(K))
  sizes <- class_sizes(p, q, discrepancy, noise, levels, sources, emulator = emulator,
                       replicates = replicates, asked = asked)
  unlist(lapply(seq_along(sizes), function(i) {
    cls <- names(sizes)[i]
    one <- if (sizes[i] == 0L) character(0)
    else if (model_classes$over[i] %in% c("one", "replicates", "latent", "asked") ||
             (model_classes$over[i] == "noise" && sizes[i] == 1L)) cls
    else paste0(cls, seq_len(sizes[i]))
    if (K > 1L && model_classes$perOutput[i] && length(one)) {
      paste0(rep(one, K), "[", rep(lab, each = length(one)), "]")
    } else one
  }), use.names = FALSE)
}

# The class of each parameter of phi.
param_class_of <- function(p, q, discrepancy = "gp", noise = 1L, levels = 0L,
                            sources = 0L, outputs = 1L, emulator = TRUE, replicates = 0L,
                            asked = character()) {
  rep(model_classes$class, class_sizes(p, q, discrepancy, noise, levels, sources,
                                       outputs = outputs, emulator = emulator,
                                       replicates = replicates, asked = asked))
}

# The output (1-based) each parameter of phi belongs to with `outputs`
# independent outputs: 0 for the shared ones (kappa, sigma2E).
param_output_of <- function(p, q, discrepancy = "gp", noise = 1L, levels = 0L,
                             sources = 0L, outputs = 1L, asked = character()) {
  one <- class_sizes(p, q, discrepancy, noise, levels, sources, asked = asked)
  unlist(lapply(seq_along(one), function(i) {
    if (outputs > 1L && model_classes$perOutput[i]) rep(seq_len(outputs), each = one[[i]])
    else rep(0L, one[[i]])
  }), use.names = FALSE)
}

# The classes that are not parameters for these correlation families: the
# smoothness of a GP whose family has none (see ?correlation).
absent_classes <- function(kernS, kernB) {
  has <- c(S = kernel_has_alpha(kernS), B = kernel_has_alpha(kernB))
  model_classes$class[model_classes$smooth %in% names(has)[!has]]
}

# The layout as the compiled core receives it (read_model() in src/posterior.cpp):
# 0-based offsets and lengths named by class (sigma2R only when the
# simulator's own noise is modelled: param_indices()).
layout_codes <- function(p, q, discrepancy = "gp", noise = 1L, levels = 0L,
                          sources = 0L, outputs = 1L, emulator = TRUE, replicates = 0L,
                          asked = character()) {
  idx <- param_indices(p, q, discrepancy, noise, levels, sources, outputs = outputs,
                       emulator = emulator, replicates = replicates, asked = asked)
  len <- lengths(idx)
  ends <- cumsum(len)
  list(offset = stats::setNames(as.integer(ends - len), names(idx)),
       length = stats::setNames(as.integer(len), names(idx)))
}

# The model description the compiled entry points take: the correlation
# families of the simulator and bias GPs (kernel_codes()), the algebra
# (0 auto: Kronecker on a product design, else dense; 1 dense; 2 the
# nearest-neighbour approximation, whose design vecchia_design() makes),
# the discrepancy model (discrepancy_codes), the layout of phi and, with
# several measurement-error groups, each field row's group (`noise`,
# 1-based: sigma2E has max(noise) entries) and, with categorical inputs,
# their indicator columns (`levels`, model_levels()) and, with a bias per
# field data set, each field row's data set and their number (`source`:
# list(codes, L), 1-based codes; the bias classes take it only with a bias)
# and, with independent outputs (outputs = "independent", R/outputs.R), the
# output's indicator columns (`outputs`: list(col, ncol, L) as
# model_levels() gives one input; `levels` then leaves the output out) and,
# with the simulator's own noise, the replicates' sufficient statistics
# (`replicates`: list(count, ssw), R/sim_noise.R; with an input-dependent
# noise `latent` TRUE and ssw one per unique input) and, given the scaled
# field inputs Xf, each field row's distinct row (`fieldRows`,
# distinct_rows(): by input and, with a bias per data set, data set; the
# compiled core computes the field's correlations once per distinct row,
# and finds them itself without it).
compiled_model <- function(p, q, kernS = 1L, kernB = 1L, algebra = 0L, discrepancy = "gp",
                           vecchia = NULL, noise = NULL, levels = NULL, source = NULL,
                           outputs = NULL, simulator = NULL, replicates = NULL, Xf = NULL,
                           asked = character()) {
  if (discrepancy == "none") source <- NULL
  lay <- layout_codes(p, q, discrepancy, if (is.null(noise)) 1L else max(noise), level_count(levels),
                      source_count(source), outputs = output_count(outputs),
                      emulator = is.null(simulator), replicates = noise_sizes(replicates),
                      asked = asked)
  c(list(kernS = as.integer(kernS), kernB = as.integer(kernB), algebra = as.integer(algebra),
         discrepancy = discrepancy_codes[[discrepancy]]),
    lay, class_roles(names(lay$offset)),
    if (!is.null(replicates)) list(replicates = c(list(count = as.numeric(replicates$count),
                                                       ssw = as.numeric(replicates$ssw)),
                                                  if (isTRUE(replicates$latent)) list(latent = TRUE))),
    if (!is.null(outputs)) list(outputs = lapply(outputs, as.integer)),
    if (!is.null(vecchia)) list(vecchia = vecchia),
    if (!is.null(noise)) list(noise = as.integer(noise)),
    if (!is.null(Xf)) list(fieldRows = distinct_rows(Xf, source$codes)),
    if (!is.null(levels)) list(levels = levels),
    if (!is.null(source)) list(source = as.integer(source$codes),
                               sourceLevels = as.integer(source$L)),
    # a simulator given as a function: the closures the compiled core calls
    # (function_closures(), R/simulator_function.R)
    if (!is.null(simulator)) list(simulator = simulator))
}

# Each class's role in the compiled core, named by class: what a move of it
# touches (touch_codes) and whether the scale move multiplies it.
class_roles <- function(classes) {
  row <- match(classes, model_classes$class)
  list(touch = stats::setNames(touch_codes[model_classes$touch[row]], classes),
       scaled = stats::setNames(model_classes$scaled[row], classes))
}

# A fit's compiled model written before it held the classes' roles and the
# field rows' grouping (format 6 and before), with them.
complete_compiled_model <- function(mc, Xf) {
  if (is.null(mc$touch)) mc <- append(mc, class_roles(names(mc$offset)), match("length", names(mc)))
  if (is.null(mc$fieldRows)) mc$fieldRows <- distinct_rows(Xf, mc$source)
  mc
}

# The number of partial correlations between the field data sets' biases
# (class rhoD), from list(codes, L) or a compiled model.
source_count <- function(source) {
  L <- source$sourceLevels %||% source$L
  if (is.null(L)) 0L else as.integer(L * (L - 1L) / 2L)
}

# The number of independent outputs (1: none, or shared), from
# list(col, ncol, L) or a compiled model.
output_count <- function(outputs) {
  if (!is.null(outputs$outputs)) outputs <- outputs$outputs
  if (is.null(outputs$L)) 1L else as.integer(outputs$L)
}

# The number of measurement-error groups of a compiled model.
noise_count <- function(model) if (is.null(model$noise)) 1L else max(model$noise)

# The categorical inputs as the compiled core takes them (src/fbc.h,
# LevelInput): for each, the first of its indicator columns among the
# experimental inputs `names` (1-based), their number and the number of
# levels; NULL without categorical inputs (`factors` as read_factors()
# gives them).
model_levels <- function(factors, names) {
  if (!length(factors)) return(NULL)
  list(col = vapply(factors, function(f) match(f$columns[1], names), integer(1), USE.NAMES = FALSE),
       ncol = vapply(factors, function(f) length(f$columns), integer(1), USE.NAMES = FALSE),
       L = vapply(factors, function(f) length(f$levels), integer(1), USE.NAMES = FALSE))
}

# The number of partial correlations of the levels (class rhoS: L (L - 1) / 2
# per categorical input with L levels), from model_levels() or a compiled
# model.
level_count <- function(levels) {
  if (!is.null(levels$levels)) levels <- levels$levels
  if (is.null(levels$L)) 0L else as.integer(sum(levels$L * (levels$L - 1L) / 2L))
}

# The dense algebra with at least this many simulator runs gets the
# large-problem move schedule (sampler_moves(large = TRUE)).
fbc_large_m <- 500L
large_dense <- function(m, algebra) {
  algebra$name %in% c("dense", "vecchia") && m >= fbc_large_m
}

# The sampler's walk scale (vignette("sampler")) and back, by walk
# code (walk_codes; src/transforms.cpp computes the same).
walk_maps <- list(
  identity = list(to = function(x) x, from = function(w) w),
  log = list(to = function(x) log(x), from = function(w) exp(w)),
  logit12 = list(to = function(x) stats::qlogis(x - 1), from = function(w) 1 + stats::plogis(w)),
  atanh = list(to = function(x) atanh(x), from = function(w) tanh(w))
)
walk_map <- function(transform) {
  name <- names(walk_codes)[match(transform, walk_codes)]
  if (length(name) != 1L || is.na(name)) stop("unknown walk code ", format(transform))
  walk_maps[[name]]
}
to_walk <- function(x, transform) walk_map(transform)$to(x)
from_walk <- function(w, transform) walk_map(transform)$from(w)
