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

# A functional output on a complete product design: J run settings (t1,
# t2) x I output points x on [0, 4], y = t1 exp(-t2 x); field: 10 points
# of the curve at (t1, t2) = (2, 0.7) with a bias 0.05 x / 4 and noise sd
# 0.03. `g` the grid's cells (i: output point, j: run setting), in the
# rows' order.
product_curves <- function(J, I, seed = 1) {
  set.seed(seed)
  x <- seq(0, 4, length.out = I)
  runs <- cbind(stats::runif(J), stats::runif(J))
  t1 <- 1 + 2 * runs[, 1]; t2 <- 0.2 + runs[, 2]
  g <- expand.grid(i = seq_len(I), j = seq_len(J))
  sim <- data.frame(y = t1[g$j] * exp(-t2[g$j] * x[g$i]), x = x[g$i], t1 = t1[g$j],
                    t2 = t2[g$j])
  xf <- seq(0.2, 3.8, length.out = 10)
  truth <- c(2, 0.7)
  field <- data.frame(y = truth[1] * exp(-truth[2] * xf) + 0.05 * xf / 4 +
                        stats::rnorm(10, 0, 0.03), x = xf)
  list(sim = sim, field = field, g = g, t1 = t1, t2 = t2, truth = truth)
}
