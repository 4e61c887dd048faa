# The design step's cost against the fit it follows (issue 30: "the design
# step <= 10% of the time of the fit it follows"), on the sinusoid of
# inst/bench/design.R (eta(x, u) = sin(10 u x), field at u = pi / 5, 5
# inputs x 2 replicates, sd 0.1, discrepancy "none"), and the accuracy of
# cheaper look-aheads against a long one. A script, not a timed test:
#
#   Rscript inst/bench/design-cost.R [reps] [steps]
#
# Part 1 (cost): per replicate, 10 maximin runs, a default fit, then `steps`
# loop steps as design.R runs them (propose_runs() with its defaults among
# 100 d uniform candidates, then update(fit, sim = new)); each design step's
# CPU s against the CPU s of the fit just before it, batches of 1 and 5.
# Part 2 (accuracy): on each replicate's first fit, every candidate's gain
# (step 1) from the look-ahead with `nfantasy` J and `ndraws` S against a
# reference with 400 fantasies (same draws, same candidates): the reference
# gain at the cheap pick as a fraction of the best reference gain (1 = the
# same quality of pick), whether the pick is the same, and the gains'
# relative error (median over candidates with a gain above 10% of the best).
suppressPackageStartupMessages(library(FBC))
args <- commandArgs(TRUE)
reps <- if (length(args) >= 1) as.integer(args[1]) else 5L
steps <- if (length(args) >= 2) as.integer(args[2]) else 3L
eta <- function(x, u) sin(10 * u * x)
xf <- rep(seq(0.1, 0.9, length.out = 5), 2)
d <- 2
cpu <- function(expr) {
  t0 <- proc.time()
  force(expr)
  tm <- proc.time() - t0
  sum(tm[c(1, 2)]) + sum(tm[c(4, 5)], na.rm = TRUE)
}
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
  for (batch in c(1L, 5L)) {
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
  # accuracy of cheaper look-aheads on the first fit (step 1 of a batch)
  set.seed(3000 + r)
  U <- matrix(runif(100 * d * d), ncol = d)
  model <- fit0$model
  scores <- function(S, J) {
    parts <- FBC:::design_particles(fit0, S, "joint")
    set.seed(4000 + r)
    t <- cpu(la <- FBC:::look_ahead(parts, U, model, 1, J))
    list(g = la$scores[, 1], t = t)
  }
  ref <- scores(100, 400)
  for (S in c(100, 50)) for (J in c(50, 25, 12)) {
    ch <- scores(S, J)
    big <- ref$g > 0.1 * max(ref$g)
    acc[[length(acc) + 1]] <- data.frame(
      rep = r, ndraws = S, nfantasy = J, cpu = ch$t,
      regret = ref$g[which.max(ch$g)] / max(ref$g), same = which.max(ch$g) == which.max(ref$g),
      relErr = median(abs(ch$g[big] / ref$g[big] - 1)))
  }
}
cost <- do.call(rbind, cost)
cost$ratio <- cost$designCpu / cost$fitCpu
acc <- do.call(rbind, acc)
rng <- function(v) sprintf("%.3f (%.3f-%.3f)", median(v), min(v), max(v))
cat("\n## Design step CPU s / the preceding fit's CPU s (sinusoid, median (range))\n\n")
cat("| batch | steps | fit CPU s | design CPU s | ratio |\n|---|---|---|---|---|\n")
for (b in unique(cost$batch)) {
  x <- cost[cost$batch == b, ]
  cat(sprintf("| %d | %d | %s | %s | %s |\n", b, nrow(x), rng(x$fitCpu), rng(x$designCpu), rng(x$ratio)))
}
cat("\n## Cheaper look-aheads against 100 draws x 400 fantasies (step 1, 200 candidates)\n\n")
cat("| ndraws | nfantasy | CPU s | pick quality (ref gain / best) | same pick | gains' rel. error |\n|---|---|---|---|---|---|\n")
for (S in unique(acc$ndraws)) for (J in unique(acc$nfantasy)) {
  x <- acc[acc$ndraws == S & acc$nfantasy == J, ]
  cat(sprintf("| %d | %d | %s | %s | %d/%d | %s |\n", S, J, rng(x$cpu), rng(x$regret),
              sum(x$same), nrow(x), rng(x$relErr)))
}
