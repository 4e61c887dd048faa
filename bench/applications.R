# The applications with the defaults (no slower than before, no '!' warning
# unless the data warrant it): each shipped application calibrated with
# `calibrate(sim, field, converge = TRUE)` and nothing else, 4 chains on the
# sequential plan, seed 1.
#
#   Rscript bench/run.R applications [--apps=ball,sw]   # the FBC on .libPaths()
#   R_LIBS=/path/to/old/FBC Rscript bench/run.R applications
#
# Run it once with the current FBC and once with an earlier one installed in
# another library to compare versions (each process loads one FBC; the
# header says which ran). Columns: CPU s (user + system of this process),
# sweeps a chain, max R-hat and min bulk ESS over every parameter, and the
# lines print(fit) starts with "!" (cli's warning bullet), with warnings
# raised during the fit.
suppressPackageStartupMessages(library(FBC))
`%||%` <- function(a, b) if (is.null(a)) b else a
cpu <- function() sum(proc.time()[c(1, 2, 4, 5)], na.rm = TRUE)
cat(sprintf("FBC %s (%s) applications benchmark, %s; %s; load %s\n",
            utils::packageVersion("FBC"), dirname(find.package("FBC")),
            format(Sys.time(), "%Y-%m-%d %H:%M"), R.version.string,
            paste(readLines("/proc/loadavg", warn = FALSE), collapse = " ")))
apps <- list(analytic = c("analyticSim", "analyticField"),
             ball = c("ballSim", "ballField"),
             sw = c("swSim", "swField"),
             kinetic = c("kineticSim", "kineticField"),
             decay = c("decaySim", "decayField"))
source("bench/options.R")
opt <- bench_options(list(apps = names(apps)))
apps <- apps[intersect(opt$apps, names(apps))]
rows <- lapply(names(apps), function(a) {
  sim <- get(apps[[a]][1])
  field <- get(apps[[a]][2])
  warns <- character()
  set.seed(1)
  t0 <- cpu()
  fit <- withCallingHandlers(
    calibrate(sim, field, converge = TRUE),
    warning = function(w) {
      warns <<- c(warns, conditionMessage(w))
      invokeRestart("muffleWarning")
    })
  used <- cpu() - t0
  printed <- utils::capture.output(print(fit))
  bang <- trimws(grep("^\\s*!", printed, value = TRUE))
  est <- fit$estimates
  s <- fit$settings
  cat(sprintf("\n== %s: %.1f CPU s\n", a, used))
  if (length(bang)) cat(paste0("  print: ", bang, collapse = "\n"), "\n")
  if (length(warns)) cat(paste0("  warning: ", warns, collapse = "\n"), "\n")
  data.frame(app = a, m = nrow(sim), n = nrow(field), cpu.s = round(used, 1),
             sweeps = s$converge$sweeps %||% s$nMCMC,
             max.rhat = round(max(est$rhat, na.rm = TRUE), 3),
             min.ess = round(min(est$ess, na.rm = TRUE)),
             bang.lines = length(bang), warnings = length(warns))
})
cat("\n")
print(do.call(rbind, rows), row.names = FALSE)
