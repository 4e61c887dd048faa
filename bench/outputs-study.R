# Several outputs, known truth: does pooling outputs ever make
# kappa's posterior worse than the better output alone?
#
# Each problem: two outputs sharing kappa = (t1, t2), 40 runs (maximin LHS
# over t1 in [1, 3], t2 in [0.2, 1.2]) x 12 x-points on [0, 2] (a product
# design: the Kronecker algebra), 15 field points per output on [0.1, 1.9]
# at the truth (2, 0.7) with 1% noise (sd 1% of the output's mean |value|),
# discrepancy "none" (the right model), Matern 5/2 (the default).
#   AB  (shapes differ, the original):  A = t1 exp(-t2 x),  B = 100 (t1 + t2 x^2 / 2)
#   AR  (shapes alike):                A = t1 exp(-t2 x),  R = t1 t2 exp(-t2 x)
# Per replicate (new design, new noise): each output alone, both under
# outputs = "independent" and under outputs = "shared"; 2 chains x 2000
# sweeps (burn-in 1000). Prints per fit: the 90% widths of t1 and t2, whether
# each covers the truth, CPU s, max R-hat; then per problem and structure
# the median over replicates of width / the better single output's width
# ("ratio"), the coverage, the CPU s, and the Gaussian independent
# combination of the two single-output widths (1 / sqrt(1/wA^2 + 1/wB^2)).
#   Rscript bench/run.R outputs-study [--reps=20] [--problems=AB,AR] [--sweeps=2000]
#     [--runs=40] [--nx=12] [--lo=1,0.2] [--hi=3,1.2] [--xmax=2] [--out=file.rds]
# (runs, nx: the runs and x-points; lo, hi: the runs' ranges of t1, t2;
# xmax: the x range [0, xmax]; out: the rows saved as they come)
suppressPackageStartupMessages(library(FBC))
source("bench/options.R")
opt <- bench_options(list(reps = 20L, problems = c("AB", "AR"), sweeps = 2000L, out = "",
                          lo = c(1, 0.2), hi = c(3, 1.2), xmax = 2, runs = 40L, nx = 12L))
reps <- opt$reps
problems <- opt$problems
sweeps <- opt$sweeps
out <- opt$out
truth <- c(2, 0.7)
lo <- opt$lo
hi <- opt$hi
xmax <- opt$xmax
nRuns <- opt$runs
nx <- opt$nx
shapes <- list(
  AB = list(A = function(x, t1, t2) t1 * exp(-t2 * x), B = function(x, t1, t2) 100 * (t1 + t2 * x^2 / 2)),
  AR = list(A = function(x, t1, t2) t1 * exp(-t2 * x), R = function(x, t1, t2) t1 * t2 * exp(-t2 * x))
)

make_problem <- function(fs, seed) {
  set.seed(seed)
  u <- if (requireNamespace("lhs", quietly = TRUE)) lhs::maximinLHS(nRuns, 2) else cbind(runif(nRuns), runif(nRuns))
  t1 <- lo[1] + (hi[1] - lo[1]) * u[, 1]; t2 <- lo[2] + (hi[2] - lo[2]) * u[, 2]
  x <- seq(0, xmax, length.out = nx)
  sim <- do.call(rbind, lapply(names(fs), function(o) do.call(rbind, lapply(seq_len(nRuns), function(r)
    data.frame(y = fs[[o]](x, t1[r], t2[r]), x = x, output = o, t1 = t1[r], t2 = t2[r])))))
  xf <- seq(0.05, 0.95, length.out = 15) * xmax
  field <- do.call(rbind, lapply(names(fs), function(o) {
    y0 <- fs[[o]](xf, truth[1], truth[2])
    data.frame(y = y0 + rnorm(15, 0, 0.01 * mean(abs(y0))), x = xf, output = o)
  }))
  list(sim = sim, field = field)
}

fit_one <- function(sim, field, ...) {
  t0 <- proc.time()
  fit <- calibrate(sim, field, nMCMC = sweeps, nBurn = sweeps / 2, nChains = 2,
                   discrepancy = "none", converge = FALSE, showProgress = FALSE, ...)
  cpu <- sum((proc.time() - t0)[c(1, 2, 4, 5)], na.rm = TRUE)
  q <- apply(fit$Phi[, 1:2], 2, stats::quantile, c(0.05, 0.95), names = FALSE)
  data.frame(w1 = q[2, 1] - q[1, 1], w2 = q[2, 2] - q[1, 2],
             c1 = q[1, 1] <= truth[1] & truth[1] <= q[2, 1],
             c2 = q[1, 2] <= truth[2] & truth[2] <= q[2, 2],
             cpu = cpu, rhat = max(fit$estimates$rhat, na.rm = TRUE))
}

rows <- list()
for (pb in problems) for (r in seq_len(reps)) {
  fs <- shapes[[pb]]
  d <- make_problem(fs, 1000 * match(pb, names(shapes)) + r)
  for (o in names(fs)) {
    one <- function(x) x[x$output == o, names(x) != "output"]
    set.seed(r)
    rows[[length(rows) + 1]] <- cbind(problem = pb, rep = r, fit = paste(o, "alone"),
                                      fit_one(one(d$sim), one(d$field)))
  }
  for (st in c("independent", "shared")) {
    set.seed(r)
    rows[[length(rows) + 1]] <- cbind(problem = pb, rep = r, fit = st,
                                      fit_one(d$sim, d$field, output = "output", outputs = st))
  }
  res <- do.call(rbind, rows)
  print(utils::tail(res, 4), row.names = FALSE, digits = 3)
  if (nzchar(out)) saveRDS(res, out)
}
res <- do.call(rbind, rows)

# per problem and structure: medians over replicates of the width ratio to
# the better single output (per kappa), coverage, CPU
summ <- do.call(rbind, lapply(split(res, list(res$problem, res$rep), drop = TRUE), function(d) {
  alone <- d[grepl("alone", d$fit), ]
  best <- c(min(alone$w1), min(alone$w2))
  comb <- 1 / sqrt(colSums(1 / as.matrix(alone[, c("w1", "w2")])^2))
  pooled <- d[!grepl("alone", d$fit), ]
  rbind(data.frame(problem = d$problem[1], rep = d$rep[1], fit = pooled$fit,
                   ratio1 = pooled$w1 / best[1], ratio2 = pooled$w2 / best[2],
                   comb1 = pooled$w1 / comb[1], comb2 = pooled$w2 / comb[2],
                   cover = pooled$c1 & pooled$c2, cpu = pooled$cpu, rhat = pooled$rhat),
        data.frame(problem = d$problem[1], rep = d$rep[1], fit = alone$fit,
                   ratio1 = alone$w1 / best[1], ratio2 = alone$w2 / best[2],
                   comb1 = alone$w1 / comb[1], comb2 = alone$w2 / comb[2],
                   cover = alone$c1 & alone$c2, cpu = alone$cpu, rhat = alone$rhat))
}))
rng <- function(x) sprintf("%.2f [%.2f, %.2f]", stats::median(x), min(x), max(x))
tab <- do.call(rbind, lapply(split(summ, list(summ$problem, summ$fit), drop = TRUE), function(d) {
  data.frame(problem = d$problem[1], fit = d$fit[1], reps = nrow(d),
             `t1 ratio` = rng(d$ratio1), `t2 ratio` = rng(d$ratio2),
             `t1 vs comb` = sprintf("%.2f", stats::median(d$comb1)),
             `t2 vs comb` = sprintf("%.2f", stats::median(d$comb2)),
             `both cover` = sprintf("%d/%d", sum(d$cover), nrow(d)),
             `CPU s` = rng(d$cpu), `max R-hat` = sprintf("%.3f", max(d$rhat)), check.names = FALSE)
}))
print(tab, row.names = FALSE)
