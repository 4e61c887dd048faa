# Builds ballField and ballSim (see ../shared/data/README.md).
# Run from the package root: Rscript data-raw/ball.R
raw <- utils::read.csv("data-raw/ball.csv", strip.white = TRUE)
ballField <- cbind(t = raw$time, h = raw$height)

# Simulator: t = sqrt(2 h / g) at a maximin Latin hypercube of 100 runs over
# h in the range of the field heights and g in [6, 14], rounded to 3 decimals.
set.seed(2023)
design <- lhs::maximinLHS(100, 2)
h <- min(raw$height) + design[, 1] * diff(range(raw$height))
g <- 6 + design[, 2] * 8
ballSim <- round(cbind(t = sqrt(2 * h / g), h = h, g = g), 3)

save(ballField, file = "data/ballField.rda", compress = "xz", version = 2)
save(ballSim, file = "data/ballSim.rda", compress = "xz", version = 2)
