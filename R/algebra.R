# Which algebra the simulator block runs on, and with how many neighbours:
# one decision, made once when the model is built (calibrate()), by
# projected cost and measured accuracy.
#
# The rule (see "Simulator algebra" in ?calibrate):
# - a product design of the runs: the Kronecker algebra (exact and cheap);
# - else the dense algebra (exact) while a sweep of it is projected to cost
#   under fbc_dense_sweep_max seconds;
# - else the nearest-neighbour (Vecchia) approximation with
#   vecchia_neighbours(m) neighbours.
#
# Projected dense sweep: fbc_dense_flop_s * (m + n)^3 seconds on the
# reference BLAS. A dense sweep costs about 1.2 Cholesky factorisations of
# the (m + n) x (m + n) block (bench/RESULTS-scale.md: 1.22 at m = 1000,
# 1.08 at 2000), and R's chol() took 1.22e-10 to 1.56e-10 s per N^3 at N =
# 400 to 1500 on the reference BLAS of our 2-core machine (timed for this
# rule, 2026-11-25; RESULTS-scale.md: 125 ms at N = 1060): 1.2 * 1.3e-10 =
# 1.5e-10 s per (m + n)^3.
#
# The choice is made on this projection whatever BLAS runs, so the same data
# get the same algebra (and set.seed() the same draws, up to rounding) on
# every machine. An optimized BLAS does not move the line in the dense
# algebra's favour (measured 2026-11-25, OpenBLAS 0.3.21, one thread, m =
# 1000 scattered runs, n = 60): a dense sweep cost 17.6 ms against the
# Vecchia algebra's 7.0 ms, and the default run on the dense algebra had not
# converged after 49 CPU minutes where the Vecchia one takes 5-8 minutes on
# the reference BLAS (bench/RESULTS-defaults.md).
fbc_dense_flop_s <- 1.5e-10
# The dense algebra while its projected sweep costs less than this (s),
# m + n up to about 870. At the limit 4 chains of 8000 sweeps take about 53
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

# Projected CPU seconds of one dense sweep with m runs and n field rows.
dense_sweep_cost <- function(m, n) {
  fbc_dense_flop_s * (m + n)^3
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
# product design's experimental x calibration settings, for Kronecker, else
# NULL). The model records this one choice (model$algebra): the product
# design is detected here only (the compiled core finds the same one from
# the same code, src/kronecker.cpp). Says so when
# `neighbours` is given for an algebra that does not use it.
choose_algebra <- function(algebra, neighbours, Xs, p, kernelS, n) {
  m <- nrow(Xs)
  cost <- dense_sweep_cost(m, n)
  costTxt <- sprintf("about %s s a sweep", format(signif(cost, 2), scientific = FALSE))
  dims <- if (algebra == "auto") .sim_algebra(Xs, p, algebra_codes[["auto"]]) else integer(0)
  out <- if (algebra == "vecchia") {
    k <- as.integer(neighbours %||% vecchia_neighbours(m))
    list(name = "vecchia", code = algebra_codes[["vecchia"]], neighbours = k, forced = TRUE,
         reason = sprintf("as asked (`algebra = \"vecchia\"`); the exact dense algebra would cost %s", costTxt))
  } else if (algebra == "dense") {
    list(name = "dense", code = algebra_codes[["dense"]], neighbours = NULL, forced = TRUE,
         reason = sprintf("as asked (`algebra = \"dense\"`); exact, projected at %s", costTxt))
  } else if (length(dims)) {
    list(name = "kronecker", code = algebra_codes[["auto"]], neighbours = NULL, forced = FALSE,
         reason = "exact; the runs are a product design, so no m x m matrix is formed",
         dims = dims)
  } else if (cost < fbc_dense_sweep_max) {
    list(name = "dense", code = algebra_codes[["auto"]], neighbours = NULL, forced = FALSE,
         reason = sprintf("exact; projected at %s (m + n = %d; under %g s)", costTxt,
                          m + n, fbc_dense_sweep_max))
  } else {
    k <- as.integer(neighbours %||% vecchia_neighbours(m))
    list(name = "vecchia", code = algebra_codes[["vecchia"]], neighbours = k, forced = FALSE,
         reason = sprintf(
           "the exact dense algebra would cost %s (m + n = %d; over %g s): `algebra = \"dense\"` is exact, a larger `neighbours =` comes closer",
           costTxt, m + n, fbc_dense_sweep_max))
  }
  if (!is.null(neighbours) && out$name != "vecchia") {
    ran <- if (out$name == "kronecker") "Kronecker" else out$name
    cli::cli_inform(c(
      "i" = "{.arg neighbours} = {neighbours} is not used: the {ran} algebra runs, which is exact and has no neighbours.",
      " " = "It applies to the nearest-neighbour algebra ({.code algebra = \"vecchia\"}, or {.code \"auto\"} on a large scattered design)."
    ))
  }
  out["dims"] <- list(out$dims)
  out[c("name", "code", "neighbours", "reason", "forced", "dims")]
}
