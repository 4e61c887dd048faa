# Builds decaySim and decayField: a functional-output calibration problem with
# known truth. Each simulator run returns a whole decay curve, the response at
# the same 50 times, for one of 80 settings of the two calibration inputs
# (m = 80 x 50 = 4000 rows, a product design: calibrate() uses the Kronecker
# algebra). Run from the package root: Rscript data-raw/decay.R
#
# Generating function: eta(x, t1, t2) = t1 * exp(-t2 * x) on x in [0, 3]
# (time), t1 in [1, 3] (initial amount), t2 in [0.2, 1.5] (decay rate).
# Truth: kappa = (t1, t2) = (2, 0.7); no discrepancy; noise sd 0.03.
eta <- function(x, t1, t2) t1 * exp(-t2 * x)
kappa <- c(t1 = 2, t2 = 0.7)
noise_sd <- 0.03

set.seed(1107)
# Simulator: 80 runs at a maximin Latin hypercube over (t1, t2), each output
# at the 50 equally spaced times 0, 3/49, ..., 3 (run by run in long format).
times <- seq(0, 3, length.out = 50)
D <- lhs::maximinLHS(80, 2)
t1 <- 1 + 2 * D[, 1]
t2 <- 0.2 + 1.3 * D[, 2]
run <- rep(seq_len(80), each = 50)
x <- rep(times, times = 80)
decaySim <- cbind(y = eta(x, t1[run], t2[run]), x = x, t1 = t1[run], t2 = t2[run])

# Field: 30 observations at times drawn uniformly on [0, 3] (off the
# simulator's grid), at the true kappa with N(0, noise_sd^2) errors.
xf <- sort(stats::runif(30, 0, 3))
decayField <- cbind(y = eta(xf, kappa[["t1"]], kappa[["t2"]]) + stats::rnorm(30, sd = noise_sd),
                    x = xf)

save(decayField, file = "data/decayField.rda", compress = "xz", version = 2)
save(decaySim, file = "data/decaySim.rda", compress = "xz", version = 2)
