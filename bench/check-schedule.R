# Where the default stopping rule would stop under other check schedules
# The draws do not depend on when the rule checks (each chain
# continues its own random stream between checks), so one default run,
# cut to each schedule's check points, says where that schedule stops.
#
#   Rscript bench/run.R check-schedule [--m=1000] [--seed=1] [--dir=.]
#
# Fits scattered_problem(m) (bench/problems.R) with calibrate()'s
# defaults (saving the fit as <dir>/fit-m<m>-s<seed>.rds, reused if there),
# then for check growth factors 1.5 (the default), 1.25 and 1.15 prints the
# max R-hat and min bulk ESS at each check (retained sweeps a chain) and the
# first check that meets the rule (every R-hat < 1.01, bulk ESS >= 400).
# Run from the package root.
suppressPackageStartupMessages(library(FBC))
source("bench/options.R")
opt <- bench_options(list(m = 1000L, seed = 1L, dir = "."))
m <- opt$m; seed <- opt$seed; dir <- opt$dir
source("bench/problems.R")
f <- file.path(dir, sprintf("fit-m%d-s%d.rds", m, seed))
if (!file.exists(f)) {
  pr <- scattered_problem(m)
  set.seed(seed)
  t0 <- proc.time()
  fit <- calibrate(pr$sim, pr$field)
  cat(sprintf("default fit: %.1f CPU s\n", sum((proc.time() - t0)[1:2])))
  saveRDS(fit, f)
}
fit <- readRDS(f)
th <- fit$settings$thinning
n <- min(table(fit$chain))
idx <- split(seq_along(fit$chain), fit$chain)
at <- function(r) {  # the rule's view after r retained draws a chain
  est <- FBC:::estimate_table(fit$Phi[unlist(lapply(idx, utils::head, r)), , drop = FALSE],
                              rep(seq_along(idx), each = r))
  o <- !is.na(est$rhat) & !is.na(est$ess)
  c(max.rhat = max(est$rhat[o]), min.ess = min(est$ess[o]),
    met = all(est$rhat[o] < 1.01) && all(est$ess[o] >= 400))
}
cat(sprintf("m = %d, seed %d: stopped at %d retained sweeps a chain after %d checks; warm-ups %s\n",
            m, seed, n * th, fit$settings$converge$checks,
            paste(fit$settings$warmup, collapse = "/")))
for (g in c(1.5, 1.25, 1.15)) {
  s <- 500
  while (tail(s, 1) < 1e5) s <- c(s, ceiling(g * tail(s, 1) / 50) * 50)
  s <- s[s / th <= n]
  res <- t(vapply(s, function(x) at(x / th), numeric(3)))
  hit <- which(res[, "met"] == 1)[1]
  cat(sprintf("\ngrowth %.2f: first met at %s retained sweeps a chain\n", g,
              if (is.na(hit)) sprintf("> %d (beyond this run)", max(s)) else s[hit]))
  print(data.frame(sweeps = s, round(res[, 1:2], 4), met = res[, 3] == 1), row.names = FALSE)
}
