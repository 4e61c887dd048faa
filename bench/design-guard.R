# Paired comparison of two builds' default picks (propose_runs(), design.R
# method "plugin") on the same replicates: runs to Hellinger 0.1 per
# replicate from each build's saved rows (design.R --until=0.1), their
# medians, and the paired difference (new - reference) with its Monte Carlo
# error. A replicate that does not reach 0.1 within its budget counts as
# its budget plus one batch (a lower bound; the count is shown).
#
#   Rscript bench/design-guard.R <reference dir> <new dir>
#
# (each directory holds design-<problem>-b<batch>-i10-r<rep>.rds files of
# one build, e.g. R_LIBS=<its library> Rscript bench/run.R design
# --problem=sinus --batch=1 --init=10 --reps=30 --methods=plugin
# --until=0.1 --added=60 --out=<dir>)
args <- commandArgs(trailingOnly = TRUE)
stopifnot(length(args) == 2L)
reach <- function(file) {
  r <- readRDS(file)
  r <- r[r$method == "plugin", ]
  hit <- which(r$hellinger <= 0.1)
  if (length(hit)) c(r$runs[hit[1]], 0) else c(max(r$runs) + r$batch[1], 1)
}
runs_of <- function(dir) {
  f <- list.files(dir, "^design-.*-i10-r[0-9]+\\.rds$", full.names = TRUE)
  key <- sub("^design-(.*)-i10-r([0-9]+)\\.rds$", "\\1 \\2", basename(f))
  v <- t(vapply(f, reach, numeric(2)))
  data.frame(key = key, runs = v[, 1], censored = v[, 2])
}
ref <- runs_of(args[1])
new <- runs_of(args[2])
both <- merge(ref, new, by = "key", suffixes = c("Ref", "New"))
both$problem <- sub(" .*", "", both$key)
set.seed(1)
cat("| problem | batch | paired replicates | reference: median runs | this build: median runs | paired difference: mean (MC error) | median (bootstrap MC error) | not reached (ref / new) |\n")
cat("|---|---|---|---|---|---|---|---|\n")
for (pb in unique(both$problem)) {
  x <- both[both$problem == pb, ]
  d <- x$runsNew - x$runsRef
  boot <- replicate(2000, stats::median(sample(d, replace = TRUE)))
  nm <- sub("-b([0-9]+)$", "", pb)
  b <- sub(".*-b", "", pb)
  cat(sprintf("| %s | %s | %d | %g | %g | %+.2f (%.2f) | %+g (%.2f) | %d / %d |\n", nm, b, nrow(x),
              stats::median(x$runsRef), stats::median(x$runsNew), mean(d), stats::sd(d) / sqrt(length(d)),
              stats::median(d), stats::sd(boot), sum(x$censoredRef), sum(x$censoredNew)))
}
