# sensitivity() where the closed form does not fit: the sampling estimator
# on the nearest-neighbour algebra, beside the closed form where both run.
#
#   Rscript bench/run.R sensitivity-large [--m=1500,5000] [--closed_max=2000]
#
# Problem: bench/problems.R's scattered design (p = 2; q = 2 up to m = 2000,
# q = 3 above), `calibrate(sim, field, algebra = "vecchia", nMCMC = 300,
# nBurn = 200, nChains = 1)` after set.seed(1) (a fixed, short run: what is
# timed is sensitivity(), not the fit). Then sensitivity(fit) with every
# default (200 draws, 128 support points, 1024 points per sample, the
# prediction's part) after set.seed(2), with the sampling estimator and, at
# m <= closed_max, the closed form. Per row: CPU seconds, peak memory of
# the process so far, and per index the medians and the sampling error of
# one draw; where both ran, the largest |difference| of the medians in
# units of the sampling error.
suppressPackageStartupMessages(library(FBC))
source("bench/options.R")
source("bench/problems.R")
opt <- bench_options(list(m = c(1500L, 5000L), closed_max = 2000L))
if (opt$quick) opt$m <- 300L
cpu <- function() sum(proc.time()[c("user.self", "sys.self")])
peak_mb <- function() {
  s <- grep("^VmHWM", readLines("/proc/self/status"), value = TRUE)
  if (length(s)) as.numeric(gsub("[^0-9]", "", s)) / 1024 else NA_real_
}
cat(sprintf("FBC %s sensitivity-large, %s; %s; BLAS %s\n", utils::packageVersion("FBC"),
            format(Sys.time(), "%Y-%m-%d %H:%M"), R.version.string, extSoftVersion()[["BLAS"]]))
rows <- list()
for (m in opt$m) {
  pr <- scattered_problem(m)
  set.seed(1)
  fit <- suppressWarnings(calibrate(pr$sim, pr$field, algebra = "vecchia", nMCMC = 300,
                                    nBurn = 200, nChains = 1))
  res <- list()
  for (est in c("sampling", if (m <= opt$closed_max) "closed")) {
    set.seed(2)
    t0 <- cpu()
    s <- sensitivity(fit, estimator = est)
    t <- cpu() - t0
    res[[est]] <- s
    tab <- rbind(cbind(of = "simulator", s$simulator[c("input", "index", "median")]),
                 cbind(of = "prediction", s$prediction[c("input", "index", "median")]))
    sd <- c(s$simulator$sampling_sd, s$prediction$sampling_sd)
    rows[[length(rows) + 1L]] <- data.frame(
      m = m, algebra = fit$model$algebra$name, estimator = est, cpu.s = round(t, 1),
      peak.mb = round(peak_mb()), median.sampling.sd = if (length(sd)) signif(stats::median(sd), 2) else NA,
      max.sampling.sd = if (length(sd)) signif(max(sd), 2) else NA,
      max.diff.in.sd = NA_real_)
    print(rows[[length(rows)]], row.names = FALSE)
  }
  if (length(res) == 2L) {
    d <- abs(c(res$sampling$simulator$median - res$closed$simulator$median,
               res$sampling$prediction$median - res$closed$prediction$median))
    sd <- c(res$sampling$simulator$sampling_sd, res$sampling$prediction$sampling_sd)
    rows[[length(rows)]]$max.diff.in.sd <- round(max(d / pmax(sd, 1e-12)), 2)
    cat(sprintf("m = %d: largest |sampling - closed| of the medians %.3g (%.2f sampling sds)\n",
                m, max(d), max(d / pmax(sd, 1e-12))))
  }
}
cat("\n")
print(do.call(rbind, rows), row.names = FALSE)
