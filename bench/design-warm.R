# Warm refits against fresh fits. Two problems:
#   sinusoid  eta = sin(10 u x), 5 field inputs x 2 replicates, sd 0.1, no
#             bias; a default fit on 10 maximin runs, then 5 more runs
#   ball      ballSim[1:40, ] then ballSim[41:50, ] (default discrepancy)
# Each replicate: the default fit on the first runs, then the new runs added
# by update_runs() with its defaults, and a fresh default calibrate() on all
# runs under the same seed. CPU s (user + system), sweeps a chain (total)
# and the chains' warm-up lengths.
#   Rscript bench/run.R design-warm [--reps=4]
suppressPackageStartupMessages(library(FBC))
source("bench/options.R")
reps <- bench_options(list(reps = 4L))$reps
eta <- function(x, u) sin(10 * u * x)
cpu <- function(expr) {
  t <- proc.time()
  v <- suppressWarnings(expr)
  list(value = v, cpu = sum((proc.time() - t)[1:2]))
}
problem <- function(name, rep) {
  set.seed(rep)
  if (name == "ball") {
    return(list(sim = ballSim[1:40, ], new = ballSim[41:50, ], field = ballField, disc = "gp"))
  }
  x0 <- rep(seq(0, 1, length = 5), 2)
  field <- data.frame(y = eta(x0, pi / 5) + rnorm(10, sd = 0.1), x = x0)
  d <- lhs::maximinLHS(10, 2)
  d2 <- lhs::maximinLHS(5, 2)
  list(sim = data.frame(y = eta(d[, 1], d[, 2]), x = d[, 1], u = d[, 2]),
       new = data.frame(y = eta(d2[, 1], d2[, 2]), x = d2[, 1], u = d2[, 2]),
       field = field, disc = "none")
}
rows <- list()
for (name in c("sinusoid", "ball")) for (rep in seq_len(reps)) {
  pb <- problem(name, rep)
  fit <- cpu(calibrate(pb$sim, pb$field, discrepancy = pb$disc, showProgress = FALSE))$value
  set.seed(100 + rep)
  warm <- cpu(update_runs(fit, pb$new, showProgress = FALSE))
  set.seed(100 + rep)
  fresh <- cpu(calibrate(rbind(pb$sim, pb$new), pb$field, discrepancy = pb$disc,
                         showProgress = FALSE))
  rows[[length(rows) + 1]] <- data.frame(
    problem = name, rep = rep, warm.cpu = warm$cpu, fresh.cpu = fresh$cpu,
    warm.sweeps = warm$value$settings$nMCMC, fresh.sweeps = fresh$value$settings$nMCMC,
    warm.warmup = paste(warm$value$settings$warmup, collapse = "/"),
    fresh.warmup = paste(fresh$value$settings$warmup, collapse = "/"))
}
res <- do.call(rbind, rows)
cat(sprintf("FBC %s, %s; BLAS %s\n", packageVersion("FBC"), format(Sys.time(), "%Y-%m-%d %H:%M"),
            basename(extSoftVersion()[["BLAS"]])))
print(res, row.names = FALSE, digits = 3)
cat("\nwarm / fresh CPU, median (range) per problem:\n")
for (name in unique(res$problem)) {
  r <- with(res[res$problem == name, ], warm.cpu / fresh.cpu)
  cat(sprintf("  %-9s %.2f (%.2f-%.2f)\n", name, median(r), min(r), max(r)))
}
