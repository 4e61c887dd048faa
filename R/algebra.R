# The algebra of the simulator block, chosen once when the model is built
# (build_model()). This minimal version keeps the rules calibrate() has
# always had (algebra_code(), sim_algebra_info()); the "defaults" work owns
# this file and replaces it.
#
# choose_algebra(algebra, neighbours, Xs, p, kernelS, n): `algebra` one of
# "auto", "dense", "vecchia"; `neighbours` NULL (auto) or a count; `Xs` the
# scaled simulator inputs; `p` the number of experimental inputs; `kernelS`
# the simulator GP's family; `n` the number of field rows. Returns
# list(name = "dense" | "kronecker" | "vecchia", code (the integer the
# compiled core takes: 0 dense or Kronecker by the design, 1 dense, 2
# vecchia), neighbours (integer or NULL), reason (one sentence), forced
# (TRUE when the user named the algebra)).
choose_algebra <- function(algebra, neighbours, Xs, p, kernelS, n) {
  code <- algebra_code(algebra, Xs, p)
  forced <- algebra != "auto"
  if (code == algebra_codes[["vecchia"]]) {
    k <- as.integer(neighbours %||% 20L)
    why <- if (forced) "asked for" else
      sprintf("more than %d runs that are not a product design", fbc_vecchia_m)
    return(list(name = "vecchia", code = code, neighbours = k, forced = forced,
                reason = sprintf("nearest-neighbour approximation with %d neighbours (%s).", k, why)))
  }
  kron <- length(.sim_algebra(Xs, p, code)) > 0L
  name <- if (kron) "kronecker" else "dense"
  reason <- if (kron) "the simulator runs are a product design (exact Kronecker algebra)." else
    if (forced) "the exact dense algebra, as asked for." else
      "the exact dense algebra (the runs are not a product design that pays)."
  list(name = name, code = code, neighbours = NULL, forced = forced, reason = reason)
}
