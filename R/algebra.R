# Which algebra the simulator block runs on, and with how many neighbours:
# one decision, made once when the model is built (calibrate()), by
# projected cost and measured accuracy.
#
# The rule (see "Simulator algebra" in ?calibrate):
# - a product design of the runs: the Kronecker algebra (exact and cheap),
#   on the experimental x calibration split when the runs are one, else on
#   the cheapest split of the input columns into two groups whose
#   combinations are the runs (an output index crossed with scattered run
#   settings; numeric inputs only), also when some combinations have no
#   run (missing cells, left out exactly: see src/kronecker.cpp) while that
#   is projected cheaper than a Cholesky factor of the runs' block;
# - else the dense algebra (exact) while a sweep of it is projected to cost
#   under fbc_dense_sweep_max seconds;
# - else the nearest-neighbour (Vecchia) approximation with
#   vecchia_neighbours(m) neighbours.
#
# Projected dense sweep: what a sweep does, move by move, with constants
# measured per input and per move (bench/dense-cost.R --constants, on the
# reference BLAS of the 2-core machine, RESULTS-dense-cost.md). A move of
# the simulator block builds the m x m correlation (d = p + q inputs), factors
# it and solves the cross block to the n field rows:
#   sim(m, n, d)   = A m^3 + B d m^2 + C n m^2;
# a kappa move (its walk, its jump, kappa's joint walk) rebuilds the m x n
# cross correlation and solves it with the kept factor:
#   kappa(m, n, d) = C n m^2 + D d n m;
# every move refactors the n x n field block: E n^3. The sweep is the sum
# over the default schedule (sampler_moves(): its repeats, the large-problem
# schedule from fbc_large_m runs). The old rule, 1.5e-10 (m + n)^3, ignored
# the inputs and the moves and was 1.6-8 times too low at p = q = 3.
# The dense algebra while its projected sweep (of the small-problem
# schedule) costs less than this (s): m up to about 530 at p = q = 1,
# n = 30, 440 at p = q = 2, n = 60. At the limit 4 chains of 8000 sweeps take about 53
# CPU minutes on the reference BLAS, 4 x 3000 (a run the stopping rule ends
# early) 20; the Vecchia algebra's sweep costs 8 ms at m = 1000, k = 20
# (RESULTS-vecchia.md), so above the limit the exact algebra is an hour or
# more and the approximation minutes.
fbc_dense_sweep_max <- 0.1

# Neighbours of the Vecchia algebra for m runs when not given (measured,
# bench/RESULTS-vecchia.md, scattered designs, against the exact
# algebra; the scale issue's bounds are kappa quantiles within 0.1 posterior
# sd, predictive means within 2% RMSE): 20 below fbc_vecchia_k10_m runs
# (m = 1000: 0.05 sd, 0.2% RMSE; m = 500: 0.10 sd, within the quantiles'
# Monte Carlo error, 0.5%); 10 from there on, where a sweep costs half as
# much and the chains converge sooner (m = 5000: 758 against 1230 CPU s,
# kappa's 90% intervals within 0.008 of k = 20's; m = 20,000: converged in 31
# CPU min, k = 20 not within 60; at m = 500, k = 10 was still within the
# bounds: 0.095 sd, 1.0% RMSE).
fbc_vecchia_k10_m <- 4000L
vecchia_neighbours <- function(m) if (m < fbc_vecchia_k10_m) 20L else 10L

fbc_dense_cost <- c(A = 2.36e-10, B = 7.93e-9, C = 4.15e-10, D = 8.22e-12, E = 1.88e-9)

# Moves a default sweep makes (sampler_moves(), "blocks" sampler, kappa's
# priors proper and free): of the simulator block, of kappa (walks, jumps,
# the joint walk), and the others (bias block, sigma2E, muB, scale).
dense_sweep_moves <- function(q, large, bias = TRUE) {
  joint <- q >= 2L
  walks <- q * (if (large || joint) 1L else 3L)
  out <- c(sim = if (large) 1L else 2L,
           kappa = walks + q + (if (joint) (if (large) 1L else fbc_kappa_joint_repeats) else 0L),
           other = (if (bias) 2L + 1L else 0L) + 2L)
  storage.mode(out) <- "integer"
  out
}

# Projected CPU seconds of one dense sweep with m runs, n field rows, p
# experimental and q calibration inputs (see the top).
dense_sweep_cost <- function(m, n, p, q, large = m >= fbc_large_m, bias = TRUE) {
  k <- fbc_dense_cost
  d <- p + q
  mv <- dense_sweep_moves(q, large, bias)
  mv[["sim"]] * (k[["A"]] * m^3 + k[["B"]] * d * m^2 + k[["C"]] * n * m^2) +
    mv[["kappa"]] * (k[["C"]] * n * m^2 + k[["D"]] * d * n * m) +
    sum(mv) * k[["E"]] * n^3
}

# The algebra for a calibration (the contract shared with the model code):
# `algebra` the user's choice ("auto", "dense", "vecchia"), `neighbours`
# NULL (chosen here) or a count, `Xs` the scaled simulator inputs (m x (p +
# q)), `p` the experimental inputs, `kernelS` the simulator kernel's name
# (the measured rule does not depend on it), `n` the field rows. Returns
# list(name = "dense", "kronecker" or "vecchia"; code = the integer the
# compiled core takes (0 auto: Kronecker or dense, 1 dense, 2 Vecchia);
# neighbours = the count for Vecchia, else NULL; reason = one sentence for
# print(); forced = whether the user named the algebra; dims = c(I, J), the
# product design's settings of its two groups, for Kronecker, else NULL;
# split, only on a product design of another split than experimental x
# calibration: its first group's columns, 1-based; missing, only when some
# combinations have no run: their number). `general`: other splits
# than experimental x calibration may be used (numeric inputs only). The
# model records this one choice (model$algebra): the product design is
# detected here only (the compiled core finds the same one from
# the same code, src/kronecker.cpp). Says so when
# `neighbours` is given for an algebra that does not use it. `without`: the
# model's classes that the Kronecker algebra does not compute with
# (classes_outside()): with any, a product design is left to the rule's
# dense or nearest-neighbour algebra, and the reason says why.
choose_algebra <- function(algebra, neighbours, Xs, p, kernelS, n, general = FALSE,
                           without = character()) {
  m <- nrow(Xs)
  # the sweep the dense algebra would run (the large-problem schedule from
  # fbc_large_m runs), and the rule's yardstick: the sweep of the
  # small-problem schedule, which grows with m (the large schedule's sweep
  # is cheaper, so a rule on it would switch dense, Vecchia, dense again as
  # m grows past fbc_large_m)
  cost <- dense_sweep_cost(m, n, p, ncol(Xs) - p)
  rule <- dense_sweep_cost(m, n, p, ncol(Xs) - p, large = FALSE)
  txt <- function(x) sprintf("about %s s a sweep", format(signif(x, 2), scientific = FALSE))
  costTxt <- txt(cost)
  dims <- if (algebra == "auto") .sim_algebra(Xs, p, algebra_codes[["auto"]], general) else integer(0)
  split <- attr(dims, "a")
  if (identical(split, seq_len(p))) split <- NULL
  missing <- attr(dims, "missing")
  dims <- as.vector(dims)
  why <- ""
  if (length(dims) && length(without)) {
    why <- sprintf("; the runs are a product design, but the Kronecker algebra does not compute with %s",
                   paste0("`", without, "`", collapse = ", "))
    dims <- integer(0)
  }
  out <- if (algebra == "vecchia") {
    k <- as.integer(neighbours %||% vecchia_neighbours(m))
    list(name = "vecchia", code = algebra_codes[["vecchia"]], neighbours = k, forced = TRUE,
         reason = sprintf("as asked (`algebra = \"vecchia\"`); the exact dense algebra would cost %s", costTxt))
  } else if (algebra == "dense") {
    list(name = "dense", code = algebra_codes[["dense"]], neighbours = NULL, forced = TRUE,
         reason = sprintf("as asked (`algebra = \"dense\"`); exact, projected at %s", costTxt))
  } else if (length(dims)) {
    list(name = "kronecker", code = algebra_codes[["auto"]], neighbours = NULL, forced = FALSE,
         reason = if (is.null(missing)) "exact; the runs are a product design, so no m x m matrix is formed" else
           sprintf("exact; the runs are a product design but for %d of its %d cells, which the algebra leaves out exactly, so no m x m matrix is formed",
                   missing, prod(dims)),
         dims = dims, split = split, missing = missing)
  } else if (rule < fbc_dense_sweep_max) {
    list(name = "dense", code = algebra_codes[["auto"]], neighbours = NULL, forced = FALSE,
         reason = sprintf("exact; projected at %s (m = %d, n = %d, %d inputs; under %g s)%s", costTxt,
                          m, n, ncol(Xs), fbc_dense_sweep_max, why))
  } else {
    k <- as.integer(neighbours %||% vecchia_neighbours(m))
    list(name = "vecchia", code = algebra_codes[["vecchia"]], neighbours = k, forced = FALSE,
         reason = sprintf(
           "the exact dense algebra is projected at %s (m = %d, n = %d, %d inputs; over %g s): `algebra = \"dense\"` is exact, a larger `neighbours =` comes closer%s",
           txt(rule), m, n, ncol(Xs), fbc_dense_sweep_max, why))
  }
  if (!is.null(neighbours) && out$name != "vecchia") {
    ran <- if (out$name == "kronecker") "Kronecker" else out$name
    cli::cli_inform(c(
      "i" = "{.arg neighbours} = {neighbours} is not used: the {ran} algebra runs, which is exact and has no neighbours.",
      " " = "It applies to the nearest-neighbour algebra ({.code algebra = \"vecchia\"}, or {.code \"auto\"} on a large scattered design)."
    ))
  }
  out["dims"] <- list(out$dims)
  out[c("name", "code", "neighbours", "reason", "forced", "dims",
        if (!is.null(out$split)) "split", if (!is.null(out$missing)) "missing")]
}

# The classes of `classes` (those the model has parameters of) that the
# algebra `name` ("dense", "kronecker", "vecchia", "function"), with
# `outputs` independent outputs, does not compute with: the compiled core
# computes with some classes on some algebras only (src/model.cpp,
# class_needs(), read here through .class_algebras()).
classes_outside <- function(name, classes, outputs = 1L) {
  have <- .class_algebras()
  have <- have[intersect(names(have), classes)]
  kind <- c(name, if (outputs > 1L) "outputs")
  names(have)[!vapply(have, function(a) all(kind %in% a), logical(1))]
}

# The algebra `alg` (choose_algebra()'s, which leaves the Kronecker one out
# where a class needs it), refused when it does not compute with a class of
# the model, naming the class and the algebras that do.
check_class_algebra <- function(alg, classes, outputs = 1L, call = parent.frame()) {
  lacks <- classes_outside(alg$name, classes, outputs)
  if (!length(lacks)) return(invisible(alg))
  label <- c(dense = "dense", kronecker = "Kronecker", vecchia = "nearest-neighbour",
             "function" = "simulator function's", outputs = "independent outputs'")
  cls <- lacks[1]
  ways <- .class_algebras()[[cls]]
  what <- paste(label[[alg$name]], "algebra", if (outputs > 1L) "of independent outputs")
  cli::cli_abort(c(
    "The {what} does not compute with {.field {cls}}.",
    i = "Only the {.or {label[setdiff(ways, 'outputs')]}} algebra{?s} {?does/do}{if (!'outputs' %in% ways) ', of one output'}.",
    i = if (alg$name != "dense" && alg$name != "function" && "dense" %in% ways && outputs == 1L) "Use {.code algebra = \"dense\"}."
  ), call = call)
}
