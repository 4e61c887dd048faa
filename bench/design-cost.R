# The design step's cost against the fit it follows (goal: the design step
# at most 10% of the time of the fit it follows), on the sinusoid of
# bench/design.R (eta(x, u) = sin(10 u x), field at u = pi / 5, 5
# inputs x 2 replicates, sd 0.1, discrepancy "none"), and the accuracy of
# cheaper look-aheads against a long one. A script, not a timed test:
#
#   Rscript bench/run.R design-cost [--reps=5] [--steps=3] [--part=both|cost|accuracy]
#
# Part 1 (cost): per replicate, 10 maximin runs, a default fit, then `steps`
# loop steps as design.R runs them (propose_runs() with its defaults among
# 100 d uniform candidates, then update(fit, sim = new)); each design step's
# CPU s against the CPU s of the fit just before it, batches of 1 and 5.
# Part 2 (accuracy): on each replicate's first fit (10 runs), the look-ahead
# with `ndraws` S and `nfantasy` J against a reference with 100 draws and
# 400 fantasies (the same candidates): step 1, the reference gain at the
# cheap pick as a fraction of the best reference gain (1 = as good a pick)
# and the gains' relative error (median over candidates with a gain above
# 10% of the best); a batch of 5, the reference's expected reduction from
# the cheap batch (its greedy gains summed over the 5 points alone) as a
# fraction of that from the 100 x 400 batch; CPU s of the batch.
#
#   Rscript bench/run.R design-cost [--reps=5] [--steps=3] [--part=both|cost|accuracy]
suppressPackageStartupMessages(library(FBC))
source("bench/options.R")
opt <- bench_options(list(reps = 5L, steps = 3L, part = "both"))
reps <- opt$reps
steps <- opt$steps
part <- opt$part
eta <- function(x, u) sin(10 * u * x)
xf <- rep(seq(0.1, 0.9, length.out = 5), 2)
d <- 2
runs_at <- function(X) data.frame(y = eta(X[, 1], X[, 2]), x = X[, 1], u1 = X[, 2])
cand <- function() stats::setNames(as.data.frame(matrix(runif(100 * d * d), ncol = d)), c("x", "u1"))
fit_runs <- function(sim, field) {
  suppressWarnings(calibrate(sim, field, discrepancy = "none", nChains = 2, showProgress = FALSE))
}

cost <- list()
acc <- list()
for (r in seq_len(reps)) {
  set.seed(1000 + r)
  field <- data.frame(y = eta(xf, pi / 5) + rnorm(length(xf), 0, 0.1), x = xf)
  start <- lhs::maximinLHS(10, d)
  fit0 <- NULL
  for (batch in if (part != "accuracy") c(1L, 5L)) {
    set.seed(2000 + r)
    sim <- runs_at(start)
    tFit <- cpu(fit <- fit_runs(sim, field))
    if (batch == 1L) fit0 <- fit
    for (k in seq_len(steps)) {
      tDesign <- cpu(pr <- suppressMessages(propose_runs(fit, n = batch, candidates = cand())))
      cost[[length(cost) + 1]] <- data.frame(rep = r, batch = batch, runs = nrow(sim),
                                             fitCpu = tFit, designCpu = tDesign)
      new <- runs_at(as.matrix(pr[c("x", "u1")]))
      sim <- rbind(sim, new)
      tFit <- cpu(fit <- suppressWarnings(update(fit, sim = new)))
    }
  }
  if (part == "cost") next
  # accuracy of cheaper look-aheads on the first fit
  if (is.null(fit0)) fit0 <- fit_runs(runs_at(start), field)
  set.seed(3000 + r)
  U <- matrix(runif(100 * d * d), ncol = d)
  model <- fit0$model
  look <- function(S, J, n, UU = U) {
    parts <- FBC:::design_particles(fit0, S, "joint")
    set.seed(4000 + r)
    t <- cpu(la <- FBC:::look_ahead(parts, UU, model, n, J))
    c(la, t = t)
  }
  # a batch's expected reduction by the reference (its greedy gains summed)
  worth <- function(idx) sum(look(100, 400, length(idx), U[idx, , drop = FALSE])$gain)
  ref <- look(100, 400, 1)$scores[, 1]
  refBatch <- worth(look(100, 400, 5)$chosen)
  for (S in c(100, 50)) for (J in c(50, 30, 25, 12)) {
    g <- look(S, J, 1)$scores[, 1]
    b <- look(S, J, 5)
    big <- ref > 0.1 * max(ref)
    acc[[length(acc) + 1]] <- data.frame(
      rep = r, ndraws = S, nfantasy = J, cpu = b$t,
      regret = ref[which.max(g)] / max(ref), same = which.max(g) == which.max(ref),
      relErr = median(abs(g[big] / ref[big] - 1)), batch = worth(b$chosen) / refBatch)
  }
}
rng <- function(v) sprintf("%.3f (%.3f-%.3f)", median(v), min(v), max(v))
if (length(cost)) {
  cost <- do.call(rbind, cost)
  cost$ratio <- cost$designCpu / cost$fitCpu
  cat("\n## Design step CPU s / the preceding fit's CPU s (sinusoid, median (range))\n\n")
  cat("| batch | steps | fit CPU s | design CPU s | ratio | ratio <= 0.1 |\n|---|---|---|---|---|---|\n")
  for (b in unique(cost$batch)) {
    x <- cost[cost$batch == b, ]
    cat(sprintf("| %d | %d | %s | %s | %s | %d/%d |\n", b, nrow(x), rng(x$fitCpu), rng(x$designCpu),
                rng(x$ratio), sum(x$ratio <= 0.1), nrow(x)))
  }
}
if (length(acc)) {
  acc <- do.call(rbind, acc)
  cat("\n## Cheaper look-aheads against 100 draws x 400 fantasies (200 candidates, median (range))\n\n")
  cat("| ndraws | nfantasy | batch of 5 CPU s | step 1: pick quality | same pick | gains' rel. error | batch of 5: quality |\n|---|---|---|---|---|---|---|\n")
  for (S in unique(acc$ndraws)) for (J in unique(acc$nfantasy)) {
    x <- acc[acc$ndraws == S & acc$nfantasy == J, ]
    cat(sprintf("| %d | %d | %s | %s | %d/%d | %s | %s |\n", S, J, rng(x$cpu), rng(x$regret),
                sum(x$same), nrow(x), rng(x$relErr), rng(x$batch)))
  }
}
