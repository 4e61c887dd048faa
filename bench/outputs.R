# Several outputs on a product design: 3 outputs x 50 points x
# 80 runs (m = 12,000 simulator rows), the Kronecker algebra over
# (output x point) x run. Time to a converged posterior (every R-hat < 1.01,
# bulk ESS >= 400: calibrate(converge = ...)), 4 chains on the sequential
# plan, CPU seconds, and the 90% intervals of kappa against the truth;
# with `single`, the same for the first output alone (its intervals are
# wider).
# --nburn=<sweeps> sets the burn-in (default 2000, calibrate()'s); the first stretch is
# nburn + 1000 sweeps, then checks every 500.
#   Rscript bench/run.R outputs [--quick] [--single] [--nburn=2000] [--outputs=independent|shared]
suppressPackageStartupMessages(library(FBC))
source("bench/options.R")
# --outputs=independent|shared: how the outputs are modelled (calibrate(outputs =))
opt <- bench_options(list(single = FALSE, nburn = 2000L, outputs = "shared"))
quick <- opt$quick
nBurn <- opt$nburn
outputs <- opt$outputs
set.seed(1)
x <- seq(0, 4, length.out = 50)
runs <- if (requireNamespace("lhs", quietly = TRUE)) lhs::maximinLHS(80, 2) else
  cbind(runif(80), runif(80))
t1 <- 1 + 2 * runs[, 1]; t2 <- 0.2 + runs[, 2]
eta <- function(x, t1, t2) list(
  amount = t1 * exp(-t2 * x),
  rate = t1 * t2 * exp(-t2 * x),
  converted = t1 * (1 - exp(-t2 * x)))
sim <- do.call(rbind, lapply(seq_len(80), function(r) {
  e <- eta(x, t1[r], t2[r])
  do.call(rbind, lapply(names(e), function(o) data.frame(y = e[[o]], x = x, output = o,
                                                        t1 = t1[r], t2 = t2[r])))
}))
xf <- seq(0.2, 3.8, length.out = 10)
truth <- c(2, 0.7)
ef <- eta(xf, truth[1], truth[2])
field <- do.call(rbind, lapply(names(ef), function(o) {
  data.frame(y = ef[[o]] + 0.05 * xf / 4 + rnorm(10, 0, 0.03), x = xf, output = o)
}))
run <- function(sim, field, output) {
  t0 <- proc.time()
  fit <- calibrate(sim, field, output = output, outputs = outputs, kernelS = "gaussian", kernelB = "gaussian",
                   nMCMC = if (quick) 300 else nBurn + 1000, nBurn = if (quick) 150 else nBurn,
                   converge = until_converged(every = if (quick) 100 else 500,
                                              maxMCMC = if (quick) 400 else 30000))
  cpu <- sum((proc.time() - t0)[c(1, 2, 4, 5)], na.rm = TRUE)
  q <- apply(fit$Phi[, 1:2], 2, quantile, c(0.05, 0.95))
  data.frame(m = nrow(sim), outputs = if (is.null(output)) "one" else outputs, algebra = fit$model$algebra$name, nBurn = fit$settings$nBurn,
             converged = fit$settings$converge$converged, sweeps = fit$settings$nMCMC,
             cpu.s = cpu, max.rhat = max(fit$estimates$rhat, na.rm = TRUE),
             min.ess = min(fit$estimates$ess, na.rm = TRUE),
             t1 = sprintf("[%.3f, %.3f]", q[1, 1], q[2, 1]), t2 = sprintf("[%.3f, %.3f]", q[1, 2], q[2, 2]),
             covers = all(q[1, ] <= truth & truth <= q[2, ]))
}
res <- run(sim, field, "output")
if (opt$single) {
  one <- function(d) d[d$output == "amount", names(d) != "output"]
  res <- rbind(res, run(one(sim), one(field), NULL))
}
print(res, row.names = FALSE)
