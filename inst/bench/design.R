# Design of new runs (issue 30): kappa's posterior against a reference as
# runs are added by each method, from the same maximin start and field
# noise per replicate (paired). A script, not a timed test:
#
#   Rscript inst/bench/design.R [reps] [batch] [added] [problem] [first]
#
# (replicates first .. first + reps - 1; each replicate's rows are saved to
# design-<problem>-b<batch>-r<rep>.rds as it ends, so a run stopped early
# keeps what it did; summarise with inst/bench/design-table.R.)
#
# Problems, all with discrepancy "none" (where new runs can matter: with a
# KOH bias the confounding sets kappa's width, see ?propose_runs):
# - "sinus": eta(x, u) = sin(10 u x) on [0, 1]^2 (Koermer et al. 2024,
#   without their bias), field at u = pi / 5, 5 inputs x 2 replicates,
#   noise sd 0.1.
# - "two": two calibration inputs, eta(x, u1, u2) = exp(-2 u1 x) sin(8 u2 x)
#   on [0, 1]^3, field at u = (0.5, 0.6), 8 inputs x 2 replicates, sd 0.1.
# Reference: the same model fitted on 150 maximin runs of the true
# simulator (the emulator's error is then negligible; same priors and
# noise model), per replicate (its field noise).
# Methods: ours (propose_runs, joint), plug-in (the same criterion at the
# MAP hyperparameters, kappa weighted on a grid: KOH-IMSPE/EIVAR's way),
# lhs::augmentLHS (nested maximin augmentation), random; ours and the
# plug-in choose among 100 d uniform candidates on [0, 1]^d per step.
# Metrics per step: Hellinger distance of kappa's posterior to the
# reference (kernel densities on a grid; the largest over the calibration
# inputs' marginals), kappa1's sd, whether the 90% intervals cover the
# truth, CPU s of the design step and of the (warm-started) fit before it.
suppressPackageStartupMessages(library(FBC))
args <- commandArgs(TRUE)
reps <- if (length(args) >= 1) as.integer(args[1]) else 3L
batch <- if (length(args) >= 2) as.integer(args[2]) else 5L
added <- if (length(args) >= 3) as.integer(args[3]) else 40L
problem <- if (length(args) >= 4) args[4] else "sinus"
first <- if (length(args) >= 5) as.integer(args[5]) else 1L
pb <- switch(problem,
  sinus = list(eta = function(x, u) sin(10 * u[, 1] * x), u0 = pi / 5,
               xf = rep(seq(0.1, 0.9, length.out = 5), 2)),
  two = list(eta = function(x, u) exp(-2 * u[, 1] * x) * sin(8 * u[, 2] * x), u0 = c(0.5, 0.6),
             xf = rep(seq(0.05, 0.95, length.out = 8), 2)),
  stop("problem must be sinus or two"))
q <- length(pb$u0)
d <- 1 + q
unames <- paste0("u", seq_len(q))
grid <- seq(0.0025, 0.9975, by = 0.005)

cpu <- function(expr) {
  t0 <- proc.time()
  force(expr)
  tm <- proc.time() - t0
  sum(tm[c(1, 2)]) + sum(tm[c(4, 5)], na.rm = TRUE)
}
dens <- function(v) {
  k <- density(v, from = min(grid), to = max(grid), n = length(grid), bw = "SJ")$y
  k / sum(k * 0.005)
}
# largest Hellinger distance over the calibration inputs' marginals
hellinger <- function(K, ref) {
  max(vapply(seq_len(q), function(j) {
    sqrt(max(0, 1 - sum(sqrt(dens(K[, j]) * ref[[j]]) * 0.005)))
  }, 0))
}
runs_at <- function(X) {
  X <- matrix(X, ncol = d)
  out <- data.frame(y = pb$eta(X[, 1], X[, -1, drop = FALSE]), x = X[, 1])
  out[unames] <- X[, -1]
  out
}
fit_runs <- function(sim, field, ...) {
  suppressWarnings(calibrate(sim, field, discrepancy = "none", nChains = 2, showProgress = FALSE, ...))
}
kappas <- function(fit) as.matrix(fit$Phi[, paste0("kappa", seq_len(q)), drop = FALSE])
next_runs <- function(method, fit, n, lhsState) {
  cand <- function() stats::setNames(as.data.frame(matrix(runif(100 * d * d), ncol = d)), c("x", unames))
  switch(method,
    ours = as.matrix(propose_runs(fit, n = n, candidates = cand())[c("x", unames)]),
    plugin = as.matrix(suppressMessages(propose_runs(fit, n = n, candidates = cand(), method = "plugin"))[c("x", unames)]),
    random = matrix(runif(d * n), n, d),
    lhs = {
      A <- lhs::augmentLHS(lhsState, n)
      A[(nrow(A) - n + 1):nrow(A), , drop = FALSE]
    })
}

one_replicate <- function(r) {
  rows <- list()
  set.seed(1000 + r)
  field <- data.frame(y = pb$eta(pb$xf, matrix(pb$u0, length(pb$xf), q, byrow = TRUE)) +
                        rnorm(length(pb$xf), 0, 0.1), x = pb$xf)
  start <- lhs::maximinLHS(10, d)
  tRef <- cpu(refFit <- fit_runs(runs_at(lhs::maximinLHS(150, d)), field))
  ref <- lapply(seq_len(q), function(j) dens(kappas(refFit)[, j]))
  for (method in c("ours", "plugin", "lhs", "random")) {
    set.seed(2000 + r)
    sim <- runs_at(start)
    lhsState <- start
    tFit <- cpu(fit <- fit_runs(sim, field))
    repeat {
      K <- kappas(fit)
      cov <- all(vapply(seq_len(q), function(j) {
        b <- quantile(K[, j], c(0.05, 0.95))
        b[1] <= pb$u0[j] && pb$u0[j] <= b[2]
      }, TRUE))
      row <- data.frame(problem = problem, batch = batch, rep = r, method = method,
                        runs = nrow(sim), hellinger = hellinger(K, ref), sd = sd(K[, 1]),
                        covers = cov, fitCpu = tFit, designCpu = NA_real_, refCpu = tRef)
      if (nrow(sim) >= 10 + added) { rows[[length(rows) + 1]] <- row; break }
      tDesign <- cpu(X <- next_runs(method, fit, batch, lhsState))
      row$designCpu <- tDesign
      rows[[length(rows) + 1]] <- row
      if (method == "lhs") lhsState <- rbind(lhsState, X)
      new <- runs_at(X)
      sim <- rbind(sim, new)
      tFit <- cpu(fit <- suppressWarnings(update(fit, sim = new)))
    }
    h <- vapply(rows[vapply(rows, function(x) x$method == method, TRUE)], `[[`, 0, "hellinger")
    cat(sprintf("%s b%d rep %d %-6s Hellinger %s\n", problem, batch, r, method,
                paste(sprintf("%.2f", h), collapse = " ")))
  }
  res <- do.call(rbind, rows)
  saveRDS(res, sprintf("design-%s-b%d-r%02d.rds", problem, batch, r))
  res
}

for (r in first:(first + reps - 1L)) one_replicate(r)
