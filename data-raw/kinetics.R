# Builds kineticField and kineticSim, the chemical kinetics example of
# Bayarri, Berger, Paulo et al. (2007, Technometrics 49(2)); raw files copied
# from ../shared/data/kinetic/ (see its README).
# Run from the package root: Rscript data-raw/kinetics.R

# Field: concentration at 10 times, 3 replicates each -> 30 rows (y, t),
# ordered by time, replicates adjacent. The true process is believed to be
# 3.5 exp(-1.7 t) + 1.5.
raw <- utils::read.table("data-raw/kinetic/field_BayBerPau2007.txt", skip = 3,
                         col.names = c("t", "rep1", "rep2", "rep3"))
stopifnot(nrow(raw) == 10L, !anyNA(raw))
kineticField <- cbind(y = as.vector(t(raw[, c("rep1", "rep2", "rep3")])),
                      t = rep(raw$t, each = 3))

# Simulator: y = 5 exp(-u t) at the 21-point design of the paper
# (design_x221.txt, on [0, 1]^2), x1 mapped to t over the field's time range
# and x2 to the rate u over [0.5, 3]. The simulator has no asymptote at 1.5,
# so it is biased for every u: the discrepancy GP must absorb the difference.
d <- utils::read.table("data-raw/kinetic/design_x221.txt", skip = 5,
                       col.names = c("case", "x1", "x2"))
stopifnot(nrow(d) == 21L)
tt <- min(raw$t) + d$x1 * diff(range(raw$t))
u <- 0.5 + d$x2 * 2.5
kineticSim <- cbind(y = 5 * exp(-u * tt), t = tt, u = u)

save(kineticField, file = "data/kineticField.rda", compress = "xz", version = 2)
save(kineticSim, file = "data/kineticSim.rda", compress = "xz", version = 2)
