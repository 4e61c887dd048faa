# Builds swField and swSim, the resistance spot welding example of
# Bayarri et al. (2007, Technometrics 49(2)); raw files copied from
# ../shared/data/spotweld/ (see its README).
# Run from the package root: Rscript data-raw/spotweld.R
#
# Inputs: gauge G (sheet gauge, coded 1 / 2 as in the source), load L (kN),
# current C (kA); simulator calibration input: the heat-generation factor tau.
# Response: weld nugget diameter (mm).

# Field: 12 settings x 10 replicates. Columns Case, Gauge, Load, Current, Field.
f <- utils::read.table("data-raw/spotweld/sw_field.txt", header = TRUE)
stopifnot(nrow(f) == 120L, !anyNA(f))
swField <- cbind(diameter = f$Field, gauge = f$Gauge, load = f$Load, current = f$Current)

# Simulator: columns Case, Gauge, t (= tau), Load, Current, NuggetDiam. Runs
# whose output is NA (the code failed there) are dropped; the columns are
# reordered to response, experimental inputs (as in swField), calibration input.
s <- utils::read.table("data-raw/spotweld/sw_sim.txt", header = TRUE)
s <- s[!is.na(s$NuggetDiam), ]
swSim <- cbind(diameter = s$NuggetDiam, gauge = s$Gauge, load = s$Load,
               current = s$Current, tau = s$t)
rownames(swSim) <- NULL
# calibrate() needs every simulator input to vary, and the field inputs
# should lie inside the simulator design's range (they are scaled by it).
stopifnot(apply(swSim[, -1], 2, function(x) length(unique(x)) > 1L))
for (j in c("gauge", "load", "current")) {
  stopifnot(all(swField[, j] >= min(swSim[, j]) & swField[, j] <= max(swSim[, j])))
}

save(swField, file = "data/swField.rda", compress = "xz", version = 2)
save(swSim, file = "data/swSim.rda", compress = "xz", version = 2)
