# Functional output on a product design with missing cells: an output
# index x (I points in [0, 4]) crossed with J scattered settings of (t1, t2),
# eta = t1 exp(-t2 x), 10 field points (truth t1 = 2, t2 = 0.7, a small
# discrepancy). A share of the cells is missing completely at random
# ("mcar") or not at random ("mnar": the runs with t1 above its median stop
# after an output index, as a crashing transient code does). Per row: CPU s
# to the end of a default run (4 chains, sequential, the stopping rule's
# length), sweeps, R-hat, kappa's 5/50/95% quantiles; "kronecker" on the
# grid with its missing cells, against the exact reference (the dense
# algebra on the same observed cells, `--dense`) as the largest gap over
# kappa's quantiles in posterior sd, against the complete design (ratio of
# CPU), and against dropping every run with a missing cell (`--drop`).
# --moves: instead, the mean CPU ms of a likelihood evaluation along a path
# of moves (every class and dimension in turn) on random data, grids of
# 80 x 50 and 30 x 20 runs with `share` of the cells missing at random.
# --sweeps: instead, on --grid (80x50 for the bound) at each share (and
# complete), the CPU ms of a sweep of a short default fit (one chain,
# `nsweep` retained sweeps and half as many of burn-in, set-up included),
# and the CPU ms of one Cholesky factor of a k x k matrix, k the missing
# cells: the least that a draw of the k cells from their exact joint
# conditional costs (data augmentation), against the complete sweep.
#   Rscript bench/run.R missing-cells [--quick] [--grid=30x20] [--share=0.1,0.2,0.4]
#     [--pattern=mcar,mnar] [--dense] [--drop] [--seed=1] [--moves]
#     [--sweeps --nsweep=40]
suppressPackageStartupMessages(library(FBC))
source("bench/options.R")
source("bench/problems.R")
opt <- bench_options(list(grid = "30x20", share = c(0.1, 0.2, 0.4), pattern = c("mcar", "mnar"),
                          dense = FALSE, drop = FALSE, seed = 1L, moves = FALSE,
                          sweeps = FALSE, nsweep = 40L))
if (opt$moves) {
  out <- NULL
  for (sz in list(c(50L, 80L), c(20L, 30L))) for (share in c(0, opt$share)) {
    set.seed(opt$seed)
    I <- sz[1]; J <- sz[2]
    g <- expand.grid(i = seq_len(I), j = seq_len(J))
    Xs <- cbind(seq(0, 1, length.out = I)[g$i], matrix(runif(2 * J), J)[g$j, ])
    keep <- setdiff(seq_len(I * J), sample(I * J, round(share * I * J)))
    Xs <- Xs[keep, ]
    alg <- FBC:::.sim_algebra(Xs, 1L, 0L, TRUE)
    phi0 <- c(0.5, 0.5, 2, 2, 2, 1.9, 1.9, 1.9, 2, 1.9, 1, 0.1, 0.01, 0)
    phis <- rbind(phi0, replace(phi0, 3, 3), replace(phi0, 4, 1), replace(phi0, 5, 1.5),
                  replace(phi0, 1, 0.3), replace(phi0, 2, 0.6), phi0)
    t <- cpu(FBC:::.loglik_path(matrix(runif(10), 10), rnorm(10), Xs, rnorm(nrow(Xs)), phis, 1e-6))
    out <- rbind(out, data.frame(grid = sprintf("%d x %d", J, I), missing = share,
                                 cells = I * J - nrow(Xs),
                                 algebra = if (length(alg)) "kronecker" else "dense",
                                 ms.per.move = round(1000 * t / (nrow(phis) - 1), 1)))
  }
  print(out, row.names = FALSE)
  quit(save = "no")
}
sz <- as.integer(strsplit(opt$grid, "x", fixed = TRUE)[[1]])
J <- sz[1]; I <- sz[2]  # J run settings x I output points
pc <- product_curves(J, I, seed = opt$seed)
full <- pc$sim; field <- pc$field; g <- pc$g; t1 <- pc$t1; truth <- pc$truth

# the cells of `share` missing: at random, or the runs with t1 above its
# median losing their last output points (as many as make the share; at
# most half the cells)
missing_cells <- function(share, pattern) {
  k <- round(share * nrow(full))
  if (pattern == "mcar") return(sort(sample(nrow(full), k)))
  hi <- which(t1[g$j] > stats::median(t1))
  o <- hi[order(-g$i[hi])]  # the high-t1 runs' cells, last output points first
  sort(o[seq_len(min(k, length(o)))])
}

run <- function(sim, label, share, pattern, algebra = "auto") {
  set.seed(opt$seed + 1L)
  args <- list(sim, field)
  if (algebra != "auto") args$algebra <- algebra
  if (opt$quick) args[c("nMCMC", "nBurn", "nChains")] <- list(200, 100, 2)
  fit <- NULL
  s <- cpu(fit <- suppressMessages(suppressWarnings(do.call(calibrate, args))))
  q <- apply(fit$Phi[, c("kappa1", "kappa2")], 2, quantile, c(0.05, 0.5, 0.95))
  list(row = data.frame(grid = opt$grid, pattern = pattern, missing = share, fit = label,
                        algebra = paste0(fit$model$algebra$name,
                                         if (!is.null(fit$model$algebra$missing)) sprintf(" (%d missing)", fit$model$algebra$missing) else ""),
                        runs = nrow(sim), cpu.s = round(s, 1), sweeps = fit$settings$nMCMC,
                        rhat = round(max(fit$estimates$rhat, na.rm = TRUE), 3),
                        t1 = sprintf("%.3f [%.3f, %.3f]", q[2, 1], q[1, 1], q[3, 1]),
                        t2 = sprintf("%.3f [%.3f, %.3f]", q[2, 2], q[1, 2], q[3, 2])),
       q = q, sd = apply(fit$Phi[, c("kappa1", "kappa2")], 2, sd))
}

if (opt$sweeps) {
  out <- NULL
  for (share in c(0, opt$share)) {
    set.seed(opt$seed + 1L)
    miss <- if (share > 0) missing_cells(share, "mcar") else integer(0)
    sim <- if (length(miss)) full[-miss, ] else full
    ns <- if (share > 0) opt$nsweep else 25L * opt$nsweep  # the complete sweep: longer, for its set-up
    s <- cpu(suppressMessages(suppressWarnings(
      calibrate(sim, field, nMCMC = ns, nBurn = ns / 2, nChains = 1))))
    k <- length(miss)
    ch <- NA
    if (k) {
      A <- crossprod(matrix(rnorm(k * k), k)) + diag(k)
      ch <- 1000 * cpu(for (r in 1:3) chol(A)) / 3
    }
    out <- rbind(out, data.frame(grid = opt$grid, missing = share, cells = k,
                                 ms.per.sweep = round(1000 * s / (1.5 * ns), 1),
                                 ms.chol.k = round(ch, 1)))
  }
  out$chol.over.complete.sweep <- round(out$ms.chol.k / out$ms.per.sweep[1], 1)
  out$sweep.over.complete <- round(out$ms.per.sweep / out$ms.per.sweep[1], 1)
  print(out, row.names = FALSE)
  quit(save = "no")
}

complete <- run(full, "complete", 0, "-")
rows <- list(cbind(complete$row, gap.sd = NA, cpu.ratio = 1))
show <- function(r) { print(r, row.names = FALSE); utils::flush.console() }  # as they come
show(rows[[1]])
for (pattern in opt$pattern) for (share in opt$share) {
  miss <- missing_cells(share, pattern)
  # the missing cells as absent rows (as NA rows they are the same cells,
  # and calibrate() adds its model of where runs fail, whose cost is not
  # the algebra's)
  sim <- full[-miss, ]
  kr <- run(sim, "kronecker", share, pattern)
  gap <- NA
  if (opt$dense) {
    de <- run(sim, "dense reference", share, pattern, algebra = "dense")
    gap <- max(abs(kr$q - de$q) / rep(de$sd, each = 3))
    rows[[length(rows) + 1]] <- cbind(de$row, gap.sd = NA, cpu.ratio = de$row$cpu.s / complete$row$cpu.s)
  }
  rows[[length(rows) + 1]] <- cbind(kr$row, gap.sd = round(gap, 3),
                                    cpu.ratio = round(kr$row$cpu.s / complete$row$cpu.s, 2))
  show(rows[[length(rows)]])
  if (opt$drop) {
    keep <- !g$j %in% unique(g$j[miss])  # every run setting with a missing cell dropped
    if (length(unique(g$j[keep])) >= 4L) {
      dr <- run(full[keep, ], "drop incomplete runs", share, pattern)
      rows[[length(rows) + 1]] <- cbind(dr$row, gap.sd = NA,
                                        cpu.ratio = round(dr$row$cpu.s / complete$row$cpu.s, 2))
    }
  }
}
cat("\n")
print(do.call(rbind, rows), row.names = FALSE)
