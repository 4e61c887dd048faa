# The boundary to the compiled core: the integer codes it switches on, by
# name, in one place (kernel_codes, of the correlation families, lives
# with them in R/correlation.R; the prior families' in R/priors.R), and the
# check, when the package loads, that they are the compiled core's
# (src/posterior.cpp, .model_codes(); src/priors.cpp, .prior_codes()).
# compiled_model() (R/model-classes.R) is the one function that turns the model
# into the list the compiled entry points take.

# A table written row by row (one list per row, the same names in each),
# so that a new entry of a code table is one line.
rows_table <- function(...) {
  do.call(rbind, lapply(list(...), as.data.frame, stringsAsFactors = FALSE))
}

# The walks of the model description's `walk` column (src/fbc.h, enum
# Transform).
walk_codes <- c(identity = 0L, log = 1L, logit12 = 2L, atanh = 3L)

# The algebras of calibrate(algebra =) (enum AlgebraChoice): "auto" lets
# the compiled core use the Kronecker algebra on a product design.
algebra_codes <- c(auto = 0L, dense = 1L, vecchia = 2L)

# The types of predict.fbc() (enum PredictType).
predict_type_codes <- c(field = 1L, mean = 2L, simulator = 3L, bias = 4L)

# What a move of a class touches (model_classes$touch; enum TouchKind).
touch_codes <- c(residual = 0L, kappa = 1L, sim = 2L, simPow = 3L, simLevels = 4L, bias = 5L,
                 biasPow = 6L, field = 7L, runs = 8L, latent = 9L, latentHyper = 10L, latentK = 11L)

# R's code tables, as .model_codes() gives the compiled core's (the
# discrepancy models' codes stay in R: the compiled core reads the model off
# the layout). The classes are handed over by name: every class the
# compiled core computes with must be one of model_classes (`class`: those
# of them it names).
model_code_tables <- function(compiled = NULL) {
  list(walk = walk_codes, kernel = kernel_codes, kernelAlpha = kernels$name[kernels$alpha],
       algebra = algebra_codes, type = predict_type_codes, touch = touch_codes,
       class = sort(intersect(compiled$class, model_classes$class)))
}

# Every code table of R against the compiled core's (`compiled`), name for
# name; the package refuses to load when one differs.
check_model_codes <- function(compiled = .model_codes()) {
  compiled$class <- sort(as.character(compiled$class))
  mine <- model_code_tables(compiled)
  tables <- union(names(mine), names(compiled))
  differ <- tables[!vapply(tables, function(t) {
    a <- mine[[t]]
    b <- compiled[[t]]
    identical(a[order(names(a) %||% a)], b[order(names(b) %||% b)])
  }, logical(1))]
  if (length(differ)) {
    cli::cli_abort(c(
      "The code tables of R (R/boundary.R) and of the compiled core (src/posterior.cpp) differ.",
      x = "They differ for {.val {differ}}."
    ))
  }
  invisible(TRUE)
}

# The compiled entry points, each with the model description attached. The
# first arguments are the scaled data; kernS, kernB and algebra give the
# model codes, or `model` a whole compiled_model().
.fbc_loglik <- function(Xf, yf, Xs, ys, phi, nugget, kernS = 1L, kernB = 1L, algebra = 0L,
                        model = compiled_model(ncol(Xf), ncol(Xs) - ncol(Xf), kernS, kernB, algebra,
                                               Xf = Xf)) {
  .fbc_loglik_c(Xf, yf, Xs, ys, phi, nugget, model)
}

.fbc_sample <- function(Xf, yf, Xs, ys, prior, moves, state, nIter, nBurn, thinning, nugget,
                        progress, kernS = 1L, kernB = 1L, algebra = 0L,
                        model = compiled_model(ncol(Xf), ncol(Xs) - ncol(Xf), kernS, kernB, algebra,
                                               Xf = Xf)) {
  .fbc_sample_c(Xf, yf, Xs, ys, prior, moves, state, nIter, nBurn, thinning, nugget, progress, model)
}

.fbc_predict <- function(Xf, yf, Xs, ys, phis, Xnew, type, nugget, block, kernS = 1L, kernB = 1L,
                         algebra = 0L,
                         model = compiled_model(ncol(Xf), ncol(Xs) - ncol(Xf), kernS, kernB, algebra,
                                               Xf = Xf),
                         noise = integer(), source = integer()) {
  .fbc_predict_c(Xf, yf, Xs, ys, phis, Xnew, type, nugget, block, model, as.integer(noise),
                 as.integer(source))
}

.loglik_path <- function(Xf, yf, Xs, ys, phis, nugget, groups = NULL, decoys = FALSE,
                         scale = FALSE, kernS = 1L, kernB = 1L, algebra = 0L,
                         model = compiled_model(ncol(Xf), ncol(Xs) - ncol(Xf), kernS, kernB, algebra,
                                               Xf = Xf)) {
  .loglik_path_c(Xf, yf, Xs, ys, phis, nugget, groups, decoys, scale, model)
}

.fbc_loo <- function(Xf, yf, Xs, ys, phis, nugget, group,
                     model = compiled_model(ncol(Xf), ncol(Xs) - ncol(Xf), Xf = Xf)) {
  .fbc_loo_c(Xf, yf, Xs, ys, phis, nugget, group, model)
}

.fbc_heldout <- function(Xf, yf, Xs, ys, phis, nugget, fold, kernS = 1L, kernB = 1L, algebra = 0L,
                         model = compiled_model(ncol(Xf), ncol(Xs) - ncol(Xf), kernS, kernB, algebra,
                                               Xf = Xf)) {
  .fbc_heldout_c(Xf, yf, Xs, ys, phis, nugget, fold, model)
}
