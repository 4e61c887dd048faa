# The model of a fit (class "fbc_model"): everything calibrate() knows before
# it runs a chain, built once by build_model() from calibrate()'s model
# arguments, and fitted by fit_model() (calibrate() does both; calibrate(...,
# fit = FALSE) returns the model and calibrate(model) fits it).
#
# Parts:
#   data       the scaled data (scale_data(): Xf, yf, Xs, ys, and with
#              several outputs outS, outF)
#   raw        the numeric sim and field the data were scaled from (a run's
#              identity, run_identity(), is stated in them)
#   scale      the scaling (fbc_scale()) with the design's labels
#   design     factors, output, source, noise (each field row's
#              measurement-error group, NULL for one), noiseLabels, levels
#              (model_levels()), biasSource (list(codes, L) with a bias per
#              data set)
#   dims       p, q, m (runs), n (field rows), noise (groups), levels and
#              sources (partial correlations), d (parameters of phi)
#   classes    the classes of this model: class, offset (0-based, in phi),
#              length
#   priors     the priors by class, families by name (what the user gave,
#              completed)
#   spec       the prior table, initial values and proposal scales, names
#              and classes of phi, prior functions (R/model-spec.R) and
#              `model`, the compiled model description (compiled_model(),
#              built once by build_model())
#   kernelS, kernelB, discrepancy, sampler   the choices, by name
#   algebra    choose_algebra()'s choice, the one record of the algebra the
#              compiled core runs (name, code, neighbours, dims, reason)
#   moves      the sampler's schedule (sampler_moves())
#   options    the other model arguments as checked (algebra asked for,
#              neighbours, output, source, sourceBias) and `args`, the
#              arguments as given (update(fit, sim = ) rebuilds from them)
#   call       the call that built it

#' The model of a calibration, without fitting it
#'
#' `calibrate(sim, field, ..., fit = FALSE)` checks the data and the model
#' arguments, scales the data, expands the priors, chooses the algebra and
#' the sampler's moves, and returns the result: an `fbc_model`.
#' `calibrate(model, ...)` fits it later, with the run's settings (`nMCMC`,
#' `nBurn`, `thinning`, `nChains`, `showProgress`, `checkpoint`,
#' `checkpointEvery`, `converge`): after the same [set.seed()] it gives the
#' draws `calibrate(sim, field, ...)` gives (the pattern of mgcv's
#' `gam(..., fit = FALSE)`). The fit keeps its model as `fit$model`.
#'
#' @param x An `fbc_model`.
#' @param ... Not used.
#' @return `print()` returns `x` invisibly.
#' @seealso [calibrate()]
#' @name fbc_model
#' @examples
#' model <- calibrate(ballSim, ballField, fit = FALSE)
#' model
#' set.seed(1)
#' fit <- calibrate(model, nMCMC = 600, nBurn = 200, nChains = 2)
NULL

# ------------------------------------------------------------- builder ----

# The model of calibrate()'s model arguments (as calibrate() takes them;
# `kappaDefault`: kappaP1 and kappaP2 were left at their defaults).
build_model <- function(sim, field, kappa, kappaDefault, hypers, discrepancy, kernelS, kernelB,
                        sampler, blockSim, algebra, neighbours, output, source, sourceBias,
                        outputs = "shared", failedRuns = "setAside", simNoise = "auto",
                        fieldLink = "mean", modelCall = NULL, call = parent.frame()) {
  dd <- model_data(sim, field, output, source, failedRuns, call = call)
  # replicate runs and the simulator's own noise (R/sim_noise.R)
  noise <- sim_noise_model(simNoise, dd$sim, fieldLink, call = call)
  opt <- model_options(dd, discrepancy, sampler, blockSim, algebra, neighbours, hypers,
                       kernelS, kernelB, sourceBias, call = call)
  opt[c("output", "source")] <- list(output, source)
  opt$outputs <- check_outputs(outputs, dd, opt$algebra, call = call)
  pr <- model_priors(dd, opt, kappa, kappaDefault, noise, call = call)
  p <- dd$p
  dat <- pr$dat
  # independent outputs: the algebra of the largest output's block
  XsAlg <- largest_output_sim(dat, opt$outputs)
  refuse_sim_noise_options(noise, output, nrow(dat$Xs), call = call)
  # the classes the model has (its priors'), some of which only some
  # algebras compute with
  K <- output_count(pr$outputs)
  classes <- unique(pr$spec$classes)
  alg <- choose_algebra(opt$algebra, opt$neighbours, XsAlg, p, opt$kernelS, nrow(dat$Xf),
                        general = length(pr$levels) == 0L,
                        without = classes_outside("kronecker", classes, K))
  if (alg$name == "vecchia") check_outputs(opt$outputs %||% "shared", dd, "vecchia", call = call)
  check_class_algebra(alg, classes, K, call = call)
  kS <- kernel_codes[[opt$kernelS]]
  spec <- pr$spec
  spec$model <- compiled_model(p, dd$q, kS, kernel_codes[[opt$kernelB]], algebra = alg$code,
                               opt$discrepancy,
                               vecchia = if (alg$name == "vecchia") {
                                 vecchia_design(dat$Xs, dat$ys, kS, alg$neighbours, alg$neighbours)
                               }, noise = dd$fac$noise, levels = pr$levels, source = pr$biasSource,
                               outputs = pr$outputs, replicates = pr$replicates, Xf = dat$Xf,
                               asked = intersect(classes, user_classes))
  if (noise$link == "realization") spec$model$replicates$realization <- TRUE
  moves <- sampler_moves(opt$sampler, spec, large = large_dense(nrow(dat$Xs), alg))
  design <- c(dd$fac[c("factors", "output", "source", "noise", "noiseLabels")],
              list(levels = pr$levels, biasSource = pr$biasSource, outputs = pr$outputs,
                   failed = dd$failed),
              if (!is.null(noise$info)) list(simNoise = noise$info))
  new_fbc_model(data = dat, raw = list(sim = dd$sim, field = dd$field), scale = pr$scale,
                design = design, spec = spec, kernelS = opt$kernelS, kernelB = opt$kernelB,
                discrepancy = opt$discrepancy, sampler = opt$sampler, algebra = alg,
                moves = moves,
                options = c(opt[c("algebra", "neighbours", "output", "source", "sourceBias", "outputs")],
                            # the arguments as given, to rebuild the model with more runs
                            # (update(fit, sim = ...), R/update_runs.R)
                            list(args = list(sim = sim, field = field, kappa = kappa,
                                             kappaDefault = kappaDefault, hypers = hypers,
                                             discrepancy = discrepancy, kernelS = kernelS,
                                             kernelB = kernelB, sampler = sampler,
                                             blockSim = blockSim, algebra = algebra,
                                             neighbours = neighbours, output = output,
                                             source = source, sourceBias = sourceBias,
                                             outputs = outputs, failedRuns = failedRuns,
                                             simNoise = simNoise, fieldLink = fieldLink))),
                call = modelCall)
}

# The data as numeric matrices with the factors read (read_factors()) and
# the columns aligned (align_columns()): list(fac, sim, field, p, q, named).
model_data <- function(sim, field, output, source, failedRuns = "setAside", call) {
  runs <- split_failed_runs(sim, field, failedRuns, call = call)
  fac <- read_factors(runs$sim, field, output, source, call = call)
  sim <- check_data_matrix(fac$sim, "sim", min_cols = 2L, min_rows = 3L, call = call)
  check_experimental_input(fac$field, call = call)
  field <- check_data_matrix(fac$field, "field", min_cols = 2L, min_rows = 1L, call = call)
  cols <- align_columns(sim, field, call = call)
  sim <- cols$sim
  field <- cols$field
  p <- ncol(field) - 1L
  q <- ncol(sim) - 1L - p
  if (q < 1L) {
    cli::cli_abort(c(
      "{.arg sim} needs a calibration input: a column besides the response and the {cli::qty(p)}experimental input{?s} it shares with {.arg field}.",
      i = if (cols$named) {
        "{.arg sim} has {.val {colnames(sim)}} and {.arg field} {.val {colnames(field)}}: every input of {.arg sim} is an experimental input of {.arg field}, so nothing is left to calibrate."
      } else {
        "{.arg field} has {ncol(field)} column{?s} (response + {p} input{?s}), so {.arg sim} needs at least {p + 2}; it has {ncol(sim)}."
      },
      i = "A calibration input is a simulator input that the field experiment does not set (such as {.code g} in {.code ballSim})."
    ), call = call)
  }
  list(fac = fac, sim = sim, field = field, p = p, q = q, named = cols$named,
       failed = runs$failed)
}

# The model's choices, checked: discrepancy, sampler, algebra, neighbours,
# kernels, sourceBias and the hyperparameter priors of this model.
model_options <- function(dd, discrepancy, sampler, blockSim, algebra, neighbours, hypers,
                          kernelS, kernelB, sourceBias, call) {
  fac <- dd$fac
  sourceBias <- match_choice(sourceBias, c("shared", "own"), "sourceBias", call = call)
  if (sourceBias == "own" && (is.null(fac$source) || length(fac$source$levels) < 2L)) {
    cli::cli_abort(c(
      if (is.null(fac$source)) "{.code sourceBias = \"own\"} needs several field data sets, but no {.arg source} column was named." else
        "{.code sourceBias = \"own\"} needs several field data sets, but the {.arg source} column has one.",
      i = "Name the column of {.arg field} that says which data set each row belongs to with {.arg source}."
    ), call = call)
  }
  discrepancy <- match_choice(discrepancy, names(discrepancy_codes), "discrepancy", call = call)
  if (sourceBias == "own" && discrepancy == "none") {
    cli::cli_abort("{.code sourceBias = \"own\"} gives each field data set its own bias, but {.code discrepancy = \"none\"} has no bias.", call = call)
  }
  sampler <- check_sampler(sampler, blockSim, call = call)
  algebra <- match_choice(algebra, c("auto", "dense", "vecchia"), "algebra", call = call)
  if (!is.null(neighbours)) neighbours <- check_neighbours(neighbours, call = call)
  if (!inherits(hypers, "fbc_hypers")) {
    cli::cli_abort("{.arg hypers} must come from {.fn set_hyperPriors}, not {.obj_type_friendly {hypers}}.", call = call)
  }
  kernelS <- check_kernel(kernelS, "kernelS", call = call)
  kernelB <- check_kernel(kernelB, "kernelB", call = call)
  hypers <- kernel_hypers(discrepancy_hypers(hypers, discrepancy, kernelB, call = call),
                          kernelS, kernelB, call = call)
  hypers <- indicator_hypers(hypers, match(unlist(lapply(fac$factors, `[[`, "columns")),
                                           colnames(dd$field)[-1]), dd$p, dd$q)
  list(discrepancy = discrepancy, sampler = sampler, algebra = algebra, neighbours = neighbours,
       hypers = hypers, kernelS = kernelS, kernelB = kernelB, sourceBias = sourceBias)
}

# The scaling, the scaled data and the priors expanded (build_priors());
# with the simulator's own noise (`noise`, sim_noise_model()) the data on
# the unique inputs and the replicates' sufficient statistics.
model_priors <- function(dd, opt, kappa, kappaDefault, noise = NULL, call) {
  fac <- dd$fac
  sim <- dd$sim
  field <- dd$field
  p <- dd$p
  q <- dd$q
  biasSource <- if (opt$sourceBias == "own") list(codes = fac$source$codes, L = length(fac$source$levels))
  lv <- output_levels(fac, colnames(field)[-1], opt$outputs)
  levels <- lv$levels
  units <- if (dd$named) paste(colnames(sim)[-seq_len(p + 1L)], collapse = ", ") else "the calibration inputs"
  check_family_switch(kappa$dist, "beta", kappaDefault[[1]], kappaDefault[[2]], "kappa", units,
                      call = call)
  scale <- fbc_scale(sim, p, named = dd$named, out = fac$outS, call = call)
  scale[c("factors", "output", "source", "noiseLabels")] <-
    list(fac$factors, fac$output, fac$source[c("name", "levels")], fac$noiseLabels)
  if (opt$sourceBias == "own") scale$sourceBias <- TRUE
  modelled <- !is.null(noise) && noise$mode != "none"
  if (!modelled) inform_duplicated_runs(sim, call = call)
  warn_wide_outputs(sim, p, named = dd$named, call = call)
  warn_field_outside(sim, field, scale, call = call)
  dat <- scale_data(sim, field, scale, fac$outS, fac$outF)
  replicates <- NULL
  if (modelled) {
    cr <- collapse_replicates(dat, noise$reps, latent = noise$mode == "input")
    dat <- cr$dat
    replicates <- cr$replicates
    opt$hypers <- sim_noise_priors(opt$hypers, cr, noise$mode, call = call)
  }
  noise <- length(fac$noiseLabels %||% 1L)
  kappaSpec <- check_class_spec(kappa, "kappa", q, call = call)
  check_kappa_design(kappaSpec, scale, call = call)
  spec <- build_priors(kappaSpec, opt$hypers, scale, p, q, opt$discrepancy, noise = noise,
                       levels = levels, source = biasSource, outputs = lv$outputs,
                       replicates = replicates, call = call)
  list(scale = scale, dat = dat, spec = spec, levels = levels, biasSource = biasSource,
       outputs = lv$outputs, replicates = replicates)
}

# Each row's distinct row of X (1, 2, ... in order of first appearance):
# rows equal in every column (and in `group`, when given) share one. Rows
# are compared exactly (==, as numbers, not as their printed digits): the
# rows in order, each against the next. The compiled core takes this
# grouping (compiled_model()'s fieldRows) and checks it.
distinct_rows <- function(X, group = NULL) {
  X <- unname(cbind(as.matrix(X), group))
  n <- nrow(X)
  if (n < 2L || ncol(X) == 0L) return(rep(1L, n))
  o <- do.call(order, lapply(seq_len(ncol(X)), function(k) X[, k]))
  Xo <- X[o, , drop = FALSE]
  run <- cumsum(c(TRUE, rowSums(Xo[-1L, , drop = FALSE] != Xo[-n, , drop = FALSE]) > 0))
  run <- run[order(o)]
  match(run, unique(run))
}

# --------------------------------------------------------- constructor ----

new_fbc_model <- function(data, raw, scale, design, spec, kernelS, kernelB, discrepancy, sampler,
                          algebra, moves, options, call) {
  # the sizes and the layout of phi from the model's own parts (the compiled
  # description, spec$model, is built from the same; the validator checks
  # that it holds this layout)
  dims <- list(p = scale$p, q = scale$q, m = nrow(data$Xs), n = nrow(data$Xf),
               noise = if (is.null(design$noise)) 1L else as.integer(max(design$noise)),
               levels = level_count(design$levels),
               sources = if (discrepancy == "none") 0L else source_count(design$biasSource),
               outputs = output_count(design$outputs), d = length(spec$vars))
  lay <- layout_codes(dims$p, dims$q, discrepancy, dims$noise, dims$levels, dims$sources,
                      outputs = dims$outputs, emulator = algebra$name != "function",
                      replicates = noise_sizes(spec$model$replicates),
                      asked = asked_classes(compiled = spec$model))
  x <- structure(list(
    data = data, raw = raw, scale = scale, design = design, dims = dims,
    classes = data.frame(class = names(lay$offset), offset = unname(lay$offset),
                         length = unname(lay$length), stringsAsFactors = FALSE),
    priors = spec$priors, spec = spec, kernelS = kernelS, kernelB = kernelB,
    discrepancy = discrepancy, sampler = sampler, algebra = algebra,
    moves = moves, options = options, call = call
  ), class = "fbc_model")
  validate_fbc_model(x)
}

# ----------------------------------------------------------- validator ----

# Checks the structure of an fbc_model; returns it (invisibly) or aborts
# with one line per problem found.
validate_fbc_model <- function(x, arg = "model", call = parent.frame()) {
  abort_problems(fbc_model_problems(x), "{.arg {arg}} is not a valid {.cls fbc_model}:", arg, call)
  invisible(x)
}

# The problems of an fbc_model, in words (character(0) when none).
fbc_model_problems <- function(x) {
  if (!inherits(x, "fbc_model") || !is.list(x)) return("It is not a list of class {.cls fbc_model}.")
  need <- c("data", "scale", "design", "dims", "classes", "spec", "kernelS", "kernelB",
            "discrepancy", "sampler", "algebra", "moves")
  miss <- setdiff(need, names(x))
  if (length(miss)) return(sprintf("`%s` is missing.", miss))
  d <- x$dims
  out <- character()
  if (!identical(dim(x$data$Xs), c(d$m, d$p + d$q)) || length(x$data$ys) != d$m) {
    out <- c(out, sprintf("The simulator data must be %d runs of %d inputs (`dims`).", d$m, d$p + d$q))
  }
  if (!identical(dim(x$data$Xf), c(d$n, d$p)) || length(x$data$yf) != d$n) {
    out <- c(out, sprintf("The field data must be %d rows of %d inputs (`dims`).", d$n, d$p))
  }
  if (!x$discrepancy %in% names(discrepancy_codes)) {
    out <- c(out, sprintf("`discrepancy` must be one of %s.", format_names(names(discrepancy_codes))))
  }
  for (k in c("kernelS", "kernelB")) {
    if (!isTRUE(x[[k]] %in% names(kernel_codes))) {
      out <- c(out, sprintf("`%s` must be one of %s.", k, format_names(names(kernel_codes))))
    }
  }
  if (length(out)) return(out)
  lay <- layout_codes(d$p, d$q, x$discrepancy, d$noise, d$levels, d$sources,
                      outputs = d$outputs %||% 1L, emulator = is.null(x$spec$model$simulator),
                      replicates = noise_sizes(x$spec$model$replicates),
                      asked = asked_classes(compiled = x$spec$model))
  if (!identical(x$classes$length, unname(lay$length)) ||
      !identical(x$classes$offset, unname(lay$offset)) ||
      !identical(x$classes$class, names(lay$length))) {
    out <- c(out, sprintf("`classes` must give the layout of phi for p = %d, q = %d and discrepancy \"%s\".",
                          d$p, d$q, x$discrepancy))
  } else if (!identical(unname(x$spec$model$offset), x$classes$offset) ||
             !identical(unname(x$spec$model$length), x$classes$length)) {
    out <- c(out, sprintf("`spec$model` must hold the layout of phi for p = %d, q = %d and discrepancy \"%s\" (`classes`).",
                          d$p, d$q, x$discrepancy))
  }
  if (sum(x$classes$length) != d$d || length(x$spec$vars) != d$d ||
      NROW(x$spec$table) != d$d || length(x$spec$init) != d$d) {
    out <- c(out, sprintf("`spec` must describe the %d parameters of `dims$d`.", d$d))
  }
  if (!isTRUE(x$algebra$name %in% c("dense", "kronecker", "vecchia", "function")) ||
      !identical(as.integer(x$algebra$code), x$spec$model$algebra)) {
    out <- c(out, "`algebra` must be a choice of `choose_algebra()` whose code the compiled model holds.")
  }
  if (!identical(x$moves$params, x$spec$vars)) {
    out <- c(out, "`moves` must move the parameters of `spec$vars`.")
  }
  out
}

# --------------------------------------------------------------- print ----

#' @rdname fbc_model
#' @export
print.fbc_model <- function(x, ...) {
  validate_fbc_model(x, "x")
  d <- x$dims
  sc <- x$scale
  cat("<fbc_model> FBC model\n")
  if (!is.null(x$simulator)) {
    cat(sprintf("  Data:        a simulator function, %d field rows\n", d$n))
  } else {
    cat(sprintf("  Data:        %d simulator runs, %d field rows\n", d$m, d$n))
  }
  noiseLine <- sim_noise_line(x)
  if (!is.null(noiseLine)) cat(sprintf("  Replicates:  %s\n", noiseLine))
  cat(sprintf("  Inputs:      %s (experimental); %s (calibration)\n",
              paste(sc$names$inputs, collapse = ", "), paste(sc$names$calibration, collapse = ", ")))
  cat(if (is.null(x$simulator)) {
    sprintf("  Discrepancy: %s; kernels %s (simulator), %s (bias)\n", x$discrepancy, x$kernelS, x$kernelB)
  } else {
    sprintf("  Discrepancy: %s; kernel %s (bias)\n", x$discrepancy, x$kernelB)
  })
  if (!is.null(x$options$output)) cat(sprintf("  Outputs:     %s\n", outputs_line(x)))
  cat(sprintf("  Algebra:     %s%s\n", x$algebra$name,
              if (is.null(x$algebra$reason)) "" else paste0(": ", x$algebra$reason)))
  cat(sprintf("  Sampler:     %s, %d parameters\n", x$sampler, d$d))
  cls <- x$classes[x$classes$length > 0L, , drop = FALSE]
  cat(sprintf("  Classes:     %s\n", paste(sprintf("%s (%d)", cls$class, cls$length), collapse = ", ")))
  cat("Fit it with calibrate(model, nMCMC = ..., ...).\n")
  invisible(x)
}

# ----------------------------------------------------------------- fit ----

# The run's settings of calibrate(), checked.
check_run <- function(nMCMC, nBurn, thinning, nChains, converge, showProgress, checkpoint,
                      checkpointEvery, threads = 1L, call = parent.frame()) {
  # nMCMC, nBurn, thinning and the rule (check_run_length(): NULL nBurn is
  # the adaptive warm-up's bounds, NULL nMCMC a run until converged)
  len <- check_run_length(nMCMC, nBurn, thinning, converge, call = call)
  nChains <- check_count(nChains, "nChains", min = 1, call = call)
  showProgress <- default_progress(showProgress, call = call)
  check_checkpoint(checkpoint, checkpointEvery, call = call)
  threads <- check_threads(threads, call = call)
  list(nMCMC = len$nMCMC, nBurn = len$nBurn, thinning = len$thinning, nChains = nChains,
       converge = len$converge, showProgress = showProgress, checkpoint = checkpoint,
       every = checkpointEvery, threads = threads)
}

# Checks `threads`: a whole number, at least 1 (the draws do not depend on
# it, so it is no part of a run's identity).
check_threads <- function(threads, call = parent.frame()) {
  check_count(threads, "threads", min = 1, call = call)
}

# The arguments of calibrate() that describe the model (the others are the
# run's settings).
model_args <- c("field", "kappaDist", "kappaInit", "kappaP1", "kappaP2", "hypers", "discrepancy",
                "kernelS", "kernelB", "sampler", "blockSim", "algebra", "neighbours", "output",
                "source", "sourceBias", "outputs", "nonFinite", "simNoise",
                "fieldLink")

# calibrate(model, ...): the model, with the call that will be the fit's
# (the model's call with this call's run settings). A model argument given
# here is refused: the model is fixed.
model_to_fit <- function(model, call, caller = parent.frame()) {
  validate_fbc_model(model, "sim", call = caller)
  given <- intersect(names(call)[-1], model_args)
  if (length(given)) {
    cli::cli_abort(c(
      "{.arg sim} is a model: {.arg {given}} cannot be given with it.",
      i = "Give the model's arguments when building it, {.code calibrate(sim, field, ..., fit = FALSE)}; here only the run's settings."
    ), call = caller)
  }
  fc <- model$call
  fc$fit <- NULL
  for (a in setdiff(names(call)[-1], c("sim", "fit", ""))) fc[[a]] <- call[[a]]
  model$call <- fc
  model
}

# The settings that make a run the same run (run_identity()): the run's
# and the model's, as calibrate() has always recorded them.
identity_settings <- function(model, run) {
  o <- model$options
  s <- list(nMCMC = run$nMCMC, nBurn = run$nBurn, thinning = run$thinning,
            nChains = run$nChains, nugget = fbc_nugget, sampler = model$sampler,
            kernelS = model$kernelS, kernelB = model$kernelB, discrepancy = model$discrepancy)
  # a run under a rule is another run (its length depends on the rule), as
  # is one under another approximation
  if (!is.null(run$converge)) s$converge <- unclass(run$converge)
  if (model$algebra$name == "vecchia") s$neighbours <- model$algebra$neighbours
  if (!is.null(o$output)) s$output <- o$output
  if (!is.null(o$source)) s$source <- o$source
  if (o$sourceBias == "own") s$sourceBias <- o$sourceBias
  if (identical(o$outputs, "independent")) s$outputs <- o$outputs
  if (!is.null(model$spec$model$replicates))
    s$simNoise <- if (isTRUE(model$spec$model$replicates$latent)) "input" else "constant"
  if (isTRUE(model$spec$model$replicates$realization)) s$fieldLink <- "realization"
  # a simulator given as a function: its code and what a non-finite value does
  if (!is.null(model$simulator)) s$simulator <- function_identity(model$simulator)
  s
}

# Runs the chains of `model` with the run's settings `run` (check_run())
# and returns the fit.
fit_model <- function(model, run, call = model$call) {
  # the compiled core reads the threads from the model description (absent:
  # one); the fit keeps them there, so update() runs with the same
  model$spec$model$threads <- if (run$threads > 1L) run$threads
  spec <- model$spec
  dat <- model$data
  d <- model$dims
  check_run_length_size(run, length(param_names(d$p, d$q, model$discrepancy)), run$nChains)
  # only the dense algebra factors an m x m block
  if (identical(model$algebra$name, "dense")) blas_hint(d$m)
  inits <- dispersed_inits(run$nChains, dat, spec)
  seeds <- chain_seeds(run$nChains)
  starts <- lapply(inits, function(x) chain_start(initial_state(x, spec), length(x), 0L))
  rd <- open_run(model, run, starts, seeds)
  t0 <- proc.time()[["elapsed"]]
  here <- parent.frame()
  assemble <- function(results, target) {
    results <- check_chain_results(results, max(target), checkpoint = rd$dir, call = here)
    # the run's settings (the model's are in fit$model)
    settings <- list(nMCMC = max(target), nBurn = run$nBurn, thinning = run$thinning,
                     nChains = length(results), nugget = fbc_nugget,
                     time = proc.time()[["elapsed"]] - t0, checkpoint = rd$dir)
    new_fbc_chains(results, model, call, settings = settings)
  }
  run_rounds(rd$starts, rd$seeds, rep(run$nMCMC, run$nChains), run$converge, assemble,
             nBurn = run$nBurn, thinning = run$thinning, showProgress = run$showProgress,
             dat = dat, spec = spec, moves = model$moves, run = rd$run, every = run$every)
}

# The run directory of `checkpoint` (NULL: none) and the chains' starts and
# streams from it: a directory holding this run's checkpoint continues it,
# with the chains' saved starts and streams (the session's RNG is advanced
# as for a new run all the same). `dir` is the directory as used
# (absolute): workers and later sessions may start elsewhere.
open_run <- function(model, run, starts, seeds, call = parent.frame(2)) {
  if (is.null(run$checkpoint)) return(list(run = NULL, dir = NULL, starts = starts, seeds = seeds))
  identity <- run_identity(model$raw$sim, model$raw$field, model$spec,
                           identity_settings(model, run))
  rd <- open_checkpoint(run$checkpoint, run$every, identity, starts, seeds, model$spec$vars,
                        call = call)
  if (rd$resumed) inform_resumed(run$checkpoint, rd$starts, run$nMCMC, run$converge)
  list(run = rd, dir = rd$dir, starts = rd$starts, seeds = rd$seeds)
}
