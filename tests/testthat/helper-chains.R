# Helpers for the chain, SBC and recovery tests.

# A random Latin hypercube on [0, 1]^k with m points.
lhs_like <- function(m, k) {
  vapply(seq_len(k), function(j) (sample(m) - stats::runif(m)) / m, numeric(m))
}
