# Shared by the Kronecker algebra's tests (test-kronecker*.R).

# A path from phi0 that moves every class and every dimension, one at a
# time, then everything at once, then back.
kron_path <- function(phi0, p, q, discrepancy = "gp") {
  idx <- FBC:::param_indices(p, q, discrepancy)
  rows <- list(phi0)
  move <- function(j, value) {
    phi <- rows[[length(rows)]]
    phi[j] <- value
    rows[[length(rows) + 1]] <<- phi
  }
  for (j in idx$kappa) move(j, runif(1))
  for (k in seq_len(p + q)) {
    move(idx$thetaS[k], rgamma(1, 2, 2))
    move(idx$alphaS[k], runif(1, 1.1, 1.95))
    move(idx$kappa[1], runif(1))
  }
  for (k in seq_len(length(idx$thetaB))) {  # p with a bias, else none
    move(idx$thetaB[k], rgamma(1, 2, 2))
    move(idx$alphaB[k], runif(1, 1.1, 1.95))
  }
  for (j in c(idx$sigma2S, idx$sigma2B, idx$sigma2E)) move(j, rgamma(1, 2, 2) + 0.05)
  for (j in idx$muB) move(j, rnorm(1))
  for (j in idx$lambdaZ) move(j, 20 * rgamma(1, 2, 2))  # S-GaSP only
  move(idx$alphaS[1], 2)
  rows[[length(rows) + 1]] <- random_phi(p, q, discrepancy)
  rows[[length(rows) + 1]] <- phi0
  do.call(rbind, rows)
}
