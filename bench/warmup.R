# Warm-up that ends when it is done, and a run that stops when converged:
# the ball drop with calibrate()'s defaults against the old fixed
# run (nMCMC = 8000, nBurn = 2000, converge = TRUE), 4 chains, sequential
# plan, CPU seconds of this process (user + sys) to every R-hat < 1.01 and
# bulk ESS >= 400. RobustCalibration's default run on the same data is timed
# in the same process when it is installed (never a dependency of FBC).
#
#   R_LIBS=<lib> Rscript bench/run.R warmup [--seeds=1,2,3]
#
# Prints one row per run and a summary (median and range over the seeds).

library(FBC)
source("bench/options.R")
seeds <- bench_options(list(seeds = 1:3))$seeds
future::plan(future::sequential)
`%||%` <- function(x, y) if (is.null(x)) y else x

cpu <- function() {
  t <- proc.time()
  t[["user.self"]] + t[["sys.self"]]
}

configs <- list(
  "defaults" = list(),
  "defaults, matern52" = list(kernelS = "matern52", kernelB = "matern52"),
  "old: nMCMC 8000, nBurn 2000, converge" = list(nMCMC = 8000, nBurn = 2000, converge = TRUE),
  "old, matern52" = list(nMCMC = 8000, nBurn = 2000, converge = TRUE,
                         kernelS = "matern52", kernelB = "matern52")
)

rows <- list()
for (name in names(configs)) {
  for (seed in seeds) {
    set.seed(seed)
    t0 <- cpu()
    fit <- do.call(calibrate, c(list(ballSim, ballField), configs[[name]]))
    t <- cpu() - t0
    s <- fit$settings
    est <- fit$estimates
    rows[[length(rows) + 1L]] <- data.frame(
      run = name, seed = seed, cpu.s = round(t, 2),
      warmup = if (length(unique(s$warmup)) == 1L) as.character(s$warmup[1]) else
        sprintf("%d-%d", min(s$warmup), max(s$warmup)),
      sweeps = s$converge$sweeps %||% s$nMCMC, checks = s$converge$checks %||% NA,
      converged = isTRUE(s$converge$converged),
      max.rhat = round(max(est$rhat, na.rm = TRUE), 4),
      min.ess = round(min(est$ess, na.rm = TRUE)),
      kappa.ess = round(est["kappa1", "ess"]),
      g.95 = sprintf("[%.2f, %.2f]", stats::quantile(fit$Phi[, 1], 0.025),
                     stats::quantile(fit$Phi[, 1], 0.975))
    )
    print(rows[[length(rows)]], row.names = FALSE)
  }
}

# RobustCalibration's default run (S-GaSP discrepancy, 10000 sweeps with
# 2000 burn-in, plug-in emulator), one chain; its ESS by the posterior
# package's bulk ESS of its one chain.
if (requireNamespace("RobustCalibration", quietly = TRUE)) {
  for (seed in seeds) {
    set.seed(seed)
    t0 <- cpu()
    rc <- suppressWarnings(utils::capture.output(fit <- RobustCalibration::rcalibration(
      design = ballField[, "h", drop = FALSE], observations = ballField[, "t"], p_theta = 1,
      simul_type = 0, input_simul = ballSim[, c("h", "g")], output_simul = ballSim[, "t"],
      theta_range = matrix(range(ballSim[, "g"]), 1))))
    t <- cpu() - t0
    th <- fit@post_sample[, 1]
    rows[[length(rows) + 1L]] <- data.frame(
      run = "RobustCalibration default (S-GaSP)", seed = seed, cpu.s = round(t, 2),
      warmup = "2000", sweeps = nrow(fit@post_sample) + 2000, checks = NA, converged = NA,
      max.rhat = NA, min.ess = NA,
      kappa.ess = round(posterior::ess_bulk(matrix(th, ncol = 1))),
      g.95 = sprintf("[%.2f, %.2f]", stats::quantile(th, 0.025), stats::quantile(th, 0.975))
    )
    print(rows[[length(rows)]], row.names = FALSE)
  }
}

all <- do.call(rbind, rows)
cat("\nAll runs:\n")
print(all, row.names = FALSE)
cat("\nCPU s by run (median [min, max] over seeds", paste(seeds, collapse = ", "), "):\n")
for (r in unique(all$run)) {
  x <- all$cpu.s[all$run == r]
  cat(sprintf("  %-40s %6.2f [%.2f, %.2f]\n", r, stats::median(x), min(x), max(x)))
}
