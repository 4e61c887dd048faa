# Builds analyticField and analyticSim: a synthetic calibration problem with
# known truth, two experimental inputs (x1, x2) and two calibration inputs
# (t1, t2). Run from the package root: Rscript data-raw/analytic.R
#
# Generating function (smooth, both calibration inputs identifiable):
#   eta(x1, x2, t1, t2) = exp(-t1 * x1) + t2 * sin(pi * x2)
# on x1, x2 in [0, 1], t1 in [1, 4], t2 in [0, 2].
# Truth: kappa = (t1, t2) = (2.5, 0.8); no discrepancy; noise sd 0.03.
eta <- function(x1, x2, t1, t2) exp(-t1 * x1) + t2 * sin(pi * x2)
kappa <- c(t1 = 2.5, t2 = 0.8)
noise_sd <- 0.03

set.seed(606)
# Simulator: 60 runs at a maximin Latin hypercube over (x1, x2, t1, t2).
D <- lhs::maximinLHS(60, 4)
x1 <- D[, 1]; x2 <- D[, 2]
t1 <- 1 + 3 * D[, 3]; t2 <- 2 * D[, 4]
analyticSim <- cbind(y = eta(x1, x2, t1, t2), x1 = x1, x2 = x2, t1 = t1, t2 = t2)

# Field: 30 points at a maximin Latin hypercube over (x1, x2), observed at the
# true kappa with N(0, noise_sd^2) errors.
F <- lhs::maximinLHS(30, 2)
analyticField <- cbind(y = eta(F[, 1], F[, 2], kappa[["t1"]], kappa[["t2"]]) +
                         stats::rnorm(30, sd = noise_sd),
                       x1 = F[, 1], x2 = F[, 2])

save(analyticField, file = "data/analyticField.rda", compress = "xz", version = 2)
save(analyticSim, file = "data/analyticSim.rda", compress = "xz", version = 2)
