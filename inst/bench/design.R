# Design of new runs (issue 30): kappa's posterior against a reference as
# runs are added by each method, from the same 10 maximin runs and field
# noise per replicate (paired).
#
#   Rscript inst/bench/design.R [reps] [batch] [added] [problem]
#
# Problem "sinus-none": eta(x, u) = sin(10 u x) on [0, 1]^2, field at u =
# pi/5, 5 inputs x 2 replicates, noise sd 0.1, no bias, discrepancy "none";
# "sinus-gp": the same with the bias 1 - x/3 - 2x^2/3 (Koermer et al. 2024)
# and discrepancy "gp". Reference: kappa's posterior with the true
# simulator in place of the emulator (grid; noise sd 0.1 known, no bias for
# "sinus-none"; for "sinus-gp" the bias GP at the hyperparameters' posterior
# is not available in closed form, so the reference is a fit on 150
# maximin runs). Methods: ours (propose_runs, joint), plug-in (MAP),
# lhs::augmentLHS (nested maximin augmentation), random. Metrics per step:
# Hellinger distance to the reference (kappa's draws by a kernel density on
# the grid), posterior sd, whether the 90% interval covers pi/5, CPU s of
# the design step and of the fit (warm-started update) against a fresh fit.
suppressPackageStartupMessages(library(FBC))
args <- commandArgs(TRUE)
reps <- if (length(args) >= 1) as.integer(args[1]) else 3L
batch <- if (length(args) >= 2) as.integer(args[2]) else 5L
added <- if (length(args) >= 3) as.integer(args[3]) else 20L
problem <- if (length(args) >= 4) args[4] else "sinus-none"
u0 <- pi / 5
eta <- function(x, u) sin(10 * u * x)
bias <- function(x) if (problem == "sinus-gp") 1 - x / 3 - 2 * x^2 / 3 else 0 * x
disc <- if (problem == "sinus-gp") "gp" else "none"
grid <- seq(0.0025, 0.9975, by = 0.005)

cpu <- function(expr) {
  t0 <- proc.time()
  force(expr)
  tm <- proc.time() - t0
  sum(tm[c(1, 2)]) + sum(tm[c(4, 5)], na.rm = TRUE)
}
reference <- function(field) {
  lp <- vapply(grid, function(u) sum(dnorm(field$y, eta(field$x, u), 0.1, log = TRUE)), 0) +
    dbeta(grid, 1.1, 1.1, log = TRUE)
  d <- exp(lp - max(lp))
  d / sum(d * 0.005)
}
hellinger <- function(draws, ref) {
  k <- density(draws, from = min(grid), to = max(grid), n = length(grid), bw = "SJ")$y
  k <- k / sum(k * 0.005)
  sqrt(max(0, 1 - sum(sqrt(k * ref) * 0.005)))
}
runs_at <- function(X) data.frame(y = eta(X[, 1], X[, 2]), x = X[, 1], u = X[, 2])
fit_runs <- function(sim, field) {
  suppressWarnings(calibrate(sim, field, discrepancy = disc, nChains = 2, showProgress = FALSE))
}
next_runs <- function(method, fit, sim, n, lhsState) {
  X <- as.matrix(sim[c("x", "u")])
  switch(method,
    ours = as.matrix(propose_runs(fit, n = n)[c("x", "u")]),
    plugin = as.matrix(propose_runs(fit, n = n, method = "plugin")[c("x", "u")]),
    random = matrix(runif(2 * n), n, 2),
    lhs = {
      A <- lhs::augmentLHS(lhsState, n)
      A[(nrow(A) - n + 1):nrow(A), , drop = FALSE]
    })
}

rows <- list()
for (r in seq_len(reps)) {
  set.seed(1000 + r)
  xf <- rep(seq(0.1, 0.9, length.out = 5), 2)
  field <- data.frame(y = eta(xf, u0) + bias(xf) + rnorm(10, 0, 0.1), x = xf)
  ref <- reference(field)
  start <- lhs::maximinLHS(10, 2)
  for (method in c("ours", "plugin", "lhs", "random")) {
    set.seed(2000 + r)
    sim <- runs_at(start)
    lhsState <- start
    tFit <- cpu(fit <- fit_runs(sim, field))
    repeat {
      k <- fit$Phi[, "kappa1"]
      q <- quantile(k, c(0.05, 0.95))
      row <- data.frame(rep = r, method = method, runs = nrow(sim), hellinger = hellinger(k, ref),
                        sd = sd(k), covers = q[1] <= u0 && u0 <= q[2], fitCpu = tFit,
                        designCpu = NA_real_, freshCpu = NA_real_)
      if (nrow(sim) >= 10 + added) { rows[[length(rows) + 1]] <- row; break }
      tDesign <- cpu(X <- next_runs(method, fit, sim, batch, lhsState))
      row$designCpu <- tDesign
      rows[[length(rows) + 1]] <- row
      if (method == "lhs") lhsState <- rbind(lhsState, X)
      new <- runs_at(X)
      sim <- rbind(sim, new)
      tFit <- cpu(fit <- suppressWarnings(update(fit, sim = new)))
    }
    cat(sprintf("rep %d %-6s done: Hellinger %s\n", r, method,
                paste(sprintf("%.3f", vapply(rows[vapply(rows, function(x) x$rep == r && x$method == method, TRUE)], `[[`, 0, "hellinger")), collapse = " ")))
  }
  # a fresh fit on the last design, against the warm-started update
  rows[[length(rows)]]$freshCpu <- cpu(fit_runs(sim, field))
}
res <- do.call(rbind, rows)
saveRDS(res, sprintf("design-%s-b%d.rds", problem, batch))
cat(sprintf("\n%s, batches of %d, %d replicates (median [quartiles] over replicates)\n", problem, batch, reps))
q3 <- function(v) sprintf("%.3f [%.3f, %.3f]", median(v), quantile(v, 0.25), quantile(v, 0.75))
tab <- aggregate(cbind(hellinger, sd) ~ method + runs, res, function(v) c(med = median(v)))
for (m in unique(res$method)) for (n in sort(unique(res$runs))) {
  s <- res[res$method == m & res$runs == n, ]
  cat(sprintf("%-6s runs %3d  Hellinger %s  sd %s  covers %d/%d  design CPU %s\n", m, n,
              q3(s$hellinger), q3(s$sd), sum(s$covers), nrow(s),
              if (all(is.na(s$designCpu))) "-" else q3(s$designCpu)))
}
up <- res[res$runs > 10, ]
cat(sprintf("\nwarm-started update CPU s: %s; fresh fit on the last design: %s\n",
            q3(up$fitCpu), q3(res$freshCpu[!is.na(res$freshCpu)])))
# runs to reach Hellinger <= 0.1 (NA: not within the budget)
reach <- aggregate(cbind(runs = ifelse(hellinger <= 0.1, runs, NA)) ~ rep + method, res,
                   function(v) if (all(is.na(v))) NA else min(v, na.rm = TRUE), na.action = na.pass)
print(reach)
