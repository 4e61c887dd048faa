# FBC beside its peers on the same data, in the same R process: CPU seconds
# of each package's default run (user + system of this process).
#
#   Rscript bench/run.R peers [--problem=ball,m1000] [--seeds=1,2,3] [--quick]
#
# Problems:
#   ball   ballSim / ballField (m = 100 runs, n = 63 field points, q = 1)
#   m1000  bench/problems.R's scattered problem: p = q = 2, n = 60, m = 1000
# FBC: calibrate(sim, field) with every argument at its default (4 chains on
# the sequential plan, run until every R-hat < 1.01 and bulk ESS >= 400).
# RobustCalibration (when installed; never a dependency of FBC):
# rcalibration() with its defaults (S-GaSP discrepancy; and again with
# discrepancy_type = "GaSP", its other model), one chain of 10,000
# sweeps with 2000 burn-in, the emulator's hyperparameters plugged in at
# their estimates). The runs alternate, FBC then the peer, seed by seed, so
# the machine's load falls on both alike. Prints each run, then the median
# and range of the CPU seconds over the seeds and the ratio of medians.
suppressPackageStartupMessages(library(FBC))
source("bench/options.R")
source("bench/problems.R")
opt <- bench_options(list(problem = c("ball", "m1000"), seeds = 1:3))
future::plan(future::sequential)
peer <- requireNamespace("RobustCalibration", quietly = TRUE)
cpu <- function() sum(proc.time()[c("user.self", "sys.self")])
blas <- tryCatch(FBC:::blas_kind(), error = function(e) NA_character_)
cat(sprintf("FBC %s peers benchmark, %s; %s; BLAS %s (%s); RobustCalibration %s\n",
            utils::packageVersion("FBC"), format(Sys.time(), "%Y-%m-%d %H:%M"),
            R.version.string, extSoftVersion()[["BLAS"]], blas,
            if (peer) as.character(utils::packageVersion("RobustCalibration")) else "not installed"))

problem <- function(name) {
  if (name == "ball") {
    return(list(sim = ballSim[, c("t", "h", "g")], field = ballField[, c("t", "h")], p = 1L))
  }
  pr <- scattered_problem(as.integer(sub("^m", "", name)))
  c(pr, p = 2L)
}

rows <- list()
for (name in opt$problem) {
  pr <- problem(name)
  sim <- as.matrix(pr$sim)
  field <- as.matrix(pr$field)
  q <- ncol(sim) - 1L - pr$p
  for (seed in opt$seeds) {
    set.seed(seed)
    t0 <- cpu()
    fit <- suppressWarnings(if (opt$quick) calibrate(pr$sim, pr$field, nMCMC = 600, nBurn = 200)
                            else calibrate(pr$sim, pr$field))
    t <- cpu() - t0
    est <- fit$estimates
    k <- fit$Phi[, seq_len(q), drop = FALSE]
    rows[[length(rows) + 1L]] <- data.frame(
      problem = name, m = nrow(sim), package = "FBC", seed = seed, cpu.s = round(t, 2),
      max.rhat = round(max(est$rhat, na.rm = TRUE), 4), min.ess = round(min(est$ess, na.rm = TRUE)),
      kappa1.90 = sprintf("[%.3g, %.3g]", stats::quantile(k[, 1], 0.05), stats::quantile(k[, 1], 0.95)))
    print(rows[[length(rows)]], row.names = FALSE)
    if (!peer) next
    rng <- apply(sim[, -seq_len(pr$p + 1L), drop = FALSE], 2, range)
    for (type in c("S-GaSP", "GaSP")) {
      set.seed(seed)
      t0 <- cpu()
      invisible(utils::capture.output(rc <- suppressWarnings(RobustCalibration::rcalibration(
        design = field[, -1, drop = FALSE], observations = field[, 1], p_theta = q,
        simul_type = 0, input_simul = sim[, -1, drop = FALSE], output_simul = sim[, 1],
        theta_range = t(rng), discrepancy_type = type,
        S = if (opt$quick) 500 else 10000, S_0 = if (opt$quick) 100 else 2000))))
      t <- cpu() - t0
      th <- rc@post_sample[, 1]
      rows[[length(rows) + 1L]] <- data.frame(
        problem = name, m = nrow(sim), package = paste("RobustCalibration", type), seed = seed,
        cpu.s = round(t, 2), max.rhat = NA, min.ess = round(posterior::ess_bulk(matrix(th, ncol = 1))),
        kappa1.90 = sprintf("[%.3g, %.3g]", stats::quantile(th, 0.05), stats::quantile(th, 0.95)))
      print(rows[[length(rows)]], row.names = FALSE)
    }
    print(rows[[length(rows)]], row.names = FALSE)
  }
}
all <- do.call(rbind, rows)
cat("\nAll runs:\n")
print(all, row.names = FALSE)
cat("\nCPU s, median [min, max] over seeds", paste(opt$seeds, collapse = ", "), ":\n")
for (name in unique(all$problem)) {
  med <- c()
  for (pk in unique(all$package)) {
    x <- all$cpu.s[all$problem == name & all$package == pk]
    if (!length(x)) next
    med[pk] <- stats::median(x)
    cat(sprintf("  %-6s %-18s %8.2f [%.2f, %.2f]\n", name, pk, med[pk], min(x), max(x)))
  }
  for (pk in setdiff(names(med), "FBC")) {
    cat(sprintf("  %-6s %s / FBC (medians): %.2f\n", name, pk, med[[pk]] / med[["FBC"]]))
  }
  # seed by seed: FBC's CPU s over the GaSP peer's in the same process
  f <- all[all$problem == name & all$package == "FBC", c("seed", "cpu.s")]
  g <- all[all$problem == name & all$package == "RobustCalibration GaSP", c("seed", "cpu.s")]
  if (nrow(g)) {
    r <- merge(f, g, by = "seed")
    cat(sprintf("  %-6s FBC / GaSP seed by seed: %s\n", name,
                paste(sprintf("%.2f", r$cpu.s.x / r$cpu.s.y), collapse = ", ")))
  }
}
