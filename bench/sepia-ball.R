# SEPIA's ball-drop example 1 (bench/data/sepia-ball/, see its README): 25
# simulator settings of (R, C), each a curve of fall times at 16 heights
# (400 runs), 12 field points (3 radii x 4 heights); R and the height
# experimental, C calibrated. The runs are every combination of the 16
# heights and the 25 (R, C) settings, so the Kronecker algebra runs on
# height x (R, C). Every argument of calibrate() at its default: CPU seconds
# to the end of the run (the stopping rule's), sweeps, R-hat and bulk ESS,
# and C's posterior quantiles; with --dense the same run on
# `algebra = "dense"` beside it (the same posterior, exact; its quantiles
# differ by Monte Carlo error only).
#   Rscript bench/run.R sepia-ball [--quick] [--dense] [--seed=1]
suppressPackageStartupMessages(library(FBC))
source("bench/options.R")
opt <- bench_options(list(dense = FALSE, seed = 1L))
dir <- "bench/data/sepia-ball"
rd <- function(f) as.matrix(utils::read.table(file.path(dir, f)))
design <- rd("sim.design")          # 25 x (R, C)
hs <- as.vector(rd("sim.height"))  # 16 heights
ys <- rd("sim.dat")                 # heights x settings
hf <- as.vector(rd("field.height"))
rf <- as.vector(rd("field.radii"))
yf <- rd("field.dat")               # radii x heights
g <- expand.grid(h = seq_along(hs), s = seq_len(nrow(design)))
sim <- data.frame(time = ys[cbind(g$h, g$s)], height = hs[g$h], R = design[g$s, 1],
                  C = design[g$s, 2])
gf <- expand.grid(r = seq_along(rf), h = seq_along(hf))
field <- data.frame(time = yf[cbind(gf$r, gf$h)], height = hf[gf$h], R = rf[gf$r])

run <- function(algebra) {
  set.seed(opt$seed)
  args <- list(sim, field)
  if (algebra != "auto") args$algebra <- algebra
  if (opt$quick) args[c("nMCMC", "nBurn", "nChains")] <- list(200, 100, 2)
  fit <- NULL
  s <- cpu(fit <- suppressWarnings(do.call(calibrate, args)))
  C <- fit$Phi[, "kappa1"]
  q <- quantile(C, c(0.05, 0.5, 0.95))
  est <- fit$estimates
  data.frame(algebra = fit$model$algebra$name, cpu.s = round(s, 1),
             sweeps = fit$settings$nMCMC, converged = isTRUE(fit$settings$converge$converged),
             max.rhat = round(max(est$rhat, na.rm = TRUE), 3),
             min.ess = round(min(est$ess, na.rm = TRUE)),
             C.mean = signif(mean(C), 4), C.sd = signif(sd(C), 3),
             C.q05 = signif(q[[1]], 4), C.q50 = signif(q[[2]], 4), C.q95 = signif(q[[3]], 4),
             C.mcse = signif(sd(C) / sqrt(est["kappa1", "ess"]), 2))
}
res <- run("auto")
if (opt$dense) res <- rbind(res, run("dense"))
cat(sprintf("m = %d runs, n = %d field points\n", nrow(sim), nrow(field)))
print(res, row.names = FALSE)
