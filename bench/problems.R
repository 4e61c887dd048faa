# The scattered problems the benchmarks share (vecchia.R, defaults.R): a
# Latin hypercube design of a smooth simulator and field data at a known
# kappa with a small bias (0.1 x1) and noise (sd 0.05).
#   m <= 2000: p = q = 2, n = 60 (bench/scale.R's problem)
#   larger:    p = 2, q = 3, n = 100 (an iid uniform design above 20,000 runs,
#              where a Latin hypercube is slow to build)
# Sourced from the package root: source("bench/problems.R").
scattered_problem <- function(m, seed = 1) {
  set.seed(seed)
  if (m <= 2000) {
    eta <- function(x1, x2, t1, t2) sin(2 * pi * x1) * (1 + t1) + exp(-x2) * t2 + x1 * x2 * t1 * t2
    D <- lhs::randomLHS(m, 4)
    sim <- data.frame(y = eta(D[, 1], D[, 2], D[, 3], D[, 4]), x1 = D[, 1], x2 = D[, 2],
                      t1 = D[, 3], t2 = D[, 4])
    xf <- matrix(stats::runif(2 * 60), 60)
    field <- data.frame(y = eta(xf[, 1], xf[, 2], 0.3, 0.7) + 0.1 * xf[, 1] +
                          stats::rnorm(60, 0, 0.05), x1 = xf[, 1], x2 = xf[, 2])
    return(list(sim = sim, field = field, truth = c(0.3, 0.7)))
  }
  eta <- function(x1, x2, t1, t2, t3) {
    sin(2 * pi * x1) * (1 + t1) + exp(-x2) * t2 + x1 * x2 * t1 * t2 + 0.5 * cos(pi * x2) * t3
  }
  D <- if (m <= 20000) lhs::randomLHS(m, 5) else matrix(stats::runif(5 * m), m)
  sim <- data.frame(y = eta(D[, 1], D[, 2], D[, 3], D[, 4], D[, 5]), x1 = D[, 1], x2 = D[, 2],
                    t1 = D[, 3], t2 = D[, 4], t3 = D[, 5])
  xf <- matrix(stats::runif(2 * 100), 100)
  field <- data.frame(y = eta(xf[, 1], xf[, 2], 0.3, 0.7, 0.5) + 0.1 * xf[, 1] +
                        stats::rnorm(100, 0, 0.05), x1 = xf[, 1], x2 = xf[, 2])
  list(sim = sim, field = field, truth = c(0.3, 0.7, 0.5))
}
