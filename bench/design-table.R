# Summarises bench/design.R's per-replicate results (design-*.rds in
# the directory given, default the working directory), per problem, batch
# size and number of starting runs (files without it: 10, the runs before
# design.R's --init option):
# - runs to reach Hellinger <= 0.1 to the reference per method (median and
#   quartiles over replicates; a replicate that does not reach it within
#   the budget is censored: "> max"), and the goals' ratios (each method's
#   median over ours, or without it over the default's, "plugin"; a
#   censored median gives a lower bound);
# - the curves: Hellinger, kappa1's sd, the posterior sd of log thetaS
#   (largest over the inputs; where recorded), coverage and the RMSE of the
#   calibrated field mean at chosen run counts (median [quartiles]);
# - the design step's CPU s against the fit it follows (same runs, same
#   process).
#
# - with design.R --fresh=1: the warm refit against a fresh fit on the same
#   runs, per range of runs (warm / fresh CPU and sweeps, warm-ups, draws,
#   convergence, Hellinger between the two).
#
# --threshold=0.1,0.2 adds the runs to other Hellinger thresholds (a
# reference from a large fit has a Monte Carlo floor near 0.1; Tuo and
# Wu's misspecified problem comes down slowly) with the paired counts
# against the plug-in (earlier / same / later) and a two-sided sign test.
#
#   Rscript bench/run.R design-table [--dir=.] [--threshold=0.1,0.2]
source("bench/options.R")
opt <- bench_options(list(dir = ".", threshold = numeric()))
dir <- opt$dir
thresholds <- opt$threshold
files <- list.files(dir, "^design-.*-b[0-9]+(-i[0-9]+)?-r[0-9]+(-[A-Za-z0-9]+)?\\.rds$", full.names = TRUE)
fresh_cols <- c(outer(c("warm", "fresh"), c("Cpu", "Sweeps", "Warmup", "Draws", "Rhat", "Ess", "Converged"),
                     paste0), "warmFresh")
res <- do.call(rbind, lapply(files, function(f) {
  x <- readRDS(f)
  if (is.null(x$rmse)) x$rmse <- NA_real_
  if (is.null(x$init)) x$init <- 10L
  if (is.null(x$thetaSd)) x$thetaSd <- NA_real_
  for (f in fresh_cols) if (is.null(x[[f]])) x[[f]] <- NA
  # (how update(fit, sim =) drew the step: files before it could reweight
  # refitted every step)
  if (is.null(x$reweighted)) x$reweighted <- FALSE
  if (is.null(x$topUp)) x$topUp <- NA_integer_
  if (is.null(x$until)) x$until <- 0  # (design.R --until)
  x[c("problem", "batch", "init", "rep", "method", "runs", "hellinger", "sd", "thetaSd",
      "covers", "rmse", "fitCpu", "designCpu", fresh_cols, "reweighted", "topUp", "until")]
}))
q3 <- function(v, fmt = "%.0f", budget = Inf) {
  # (run counts as integers, but a median between two as x.5; NA dropped:
  # a reweighted step has no sweeps of its own)
  v <- v[!is.na(v)]
  if (!length(v)) return("-")
  s <- function(x) if (is.infinite(x)) paste0(">", budget) else if (fmt == "%.0f") format(x) else sprintf(fmt, x)
  sprintf("%s [%s, %s]", s(median(v)), s(quantile(v, 0.25, type = 1)), s(quantile(v, 0.75, type = 1)))
}
reach_runs <- function(s, threshold = 0.1) {
  vapply(split(s, s$rep), function(x) {
    h <- x$runs[x$hellinger <= threshold]
    if (length(h)) min(h) else Inf
  }, 0)
}
key <- paste(res$problem, res$batch, res$init)
for (st in unique(key)) {
  r <- res[key == st, ]
  init <- r$init[1]
  budget <- max(r$runs)
  # each method's own budget (files of runs with other --added may be
  # merged: a method censored at its budget is "> its budget")
  bud <- tapply(r$runs, r$method, max)
  methods <- intersect(c("ours", "plugin", "imspe", "lhs", "random", "oracle", "known"), unique(r$method))
  variants <- sort(grep("^ours[0-9]+$", unique(r$method), value = TRUE))  # ours with N draws
  rv <- r
  # only replicates every method finished (paired)
  # (or ended on reaching design.R's --until distance)
  done <- Reduce(intersect, lapply(methods, function(m) {
    unique(r$rep[r$method == m & (r$runs == bud[[m]] | r$hellinger <= r$until)])
  }))
  r <- r[r$rep %in% done, ]
  if (!nrow(r)) next
  cat(sprintf("\n### %s, batches of %d, %d starting runs (%d paired replicates)\n\n",
              r$problem[1], r$batch[1], init, length(done)))
  cat("| method | runs to Hellinger <= 0.1, median [quartiles] | replicates reaching it |\n|---|---|---|\n")
  reach <- lapply(stats::setNames(methods, methods), function(m) reach_runs(r[r$method == m, ]))
  for (m in methods) {
    cat(sprintf("| %s | %s | %d/%d |\n", m, q3(reach[[m]], budget = bud[[m]]),
                sum(is.finite(reach[[m]])), length(reach[[m]])))
  }
  # the ratios against ours (the joint criterion), or without it the
  # default (the plug-in)
  base <- intersect(c("ours", "plugin"), methods)[1]
  if (!is.na(base)) {
    mo <- median(reach[[base]])
    for (m in setdiff(intersect(c("lhs", "plugin", "imspe", "oracle", "known"), methods), base)) {
      mm <- median(reach[[m]])
      txt <- if (is.infinite(mo)) sprintf("%s censored: no ratio", base) else if (is.infinite(mm))
        sprintf(">= %.2f (%s censored at %d)", bud[[m]] / mo, m, bud[[m]]) else sprintf("%.2f", mm / mo)
      # paired: replicates where the base reached it no later than the other method
      cat(sprintf("\n%s / %s, median runs: %s; %s no later in %d/%d replicates",
                  m, base, txt, base, sum(reach[[base]] <= reach[[m]]), length(done)))
    }
    cat("\n")
  }
  # other thresholds, with the paired comparison against the plug-in
  # (a replicate that never reaches it counts as later than one that does)
  for (th in thresholds) {
    rt <- lapply(stats::setNames(methods, methods), function(m) reach_runs(r[r$method == m, ], th))
    cat(sprintf("\nHellinger <= %g: %s", th, paste(vapply(methods, function(m) {
      sprintf("%s %s (%d/%d)", m, q3(rt[[m]], budget = bud[[m]]), sum(is.finite(rt[[m]])), length(rt[[m]]))
    }, ""), collapse = "; ")))
    if (all(c("ours", "plugin") %in% methods)) {
      a <- rt$ours; b <- rt$plugin
      e <- sum(a < b); l <- sum(a > b)
      p <- if (e + l) stats::binom.test(e, e + l)$p.value else 1
      cat(sprintf("; ours against the plug-in: earlier / same / later %d / %d / %d (sign test p %.2f)",
                  e, sum(a == b), l, p))
    }
    cat("\n")
  }
  steps <- intersect(init + c(0, 1, 2, 5, 10, 15, 20, 25, 30, 40), r$runs)
  if (any(r$until > 0)) {
    cat(sprintf("\n(Loops ended within Hellinger %g of the reference, design.R --until: past a replicate's end the rows below leave it out; their count is the covers column's.)\n",
                max(r$until)))
  }
  cat("\n| method | runs | Hellinger | kappa1 sd | log thetaS sd | covers | RMSE field mean |\n|---|---|---|---|---|---|---|\n")
  for (m in methods) for (n in steps) {
    s <- r[r$method == m & r$runs == n, ]
    cat(sprintf("| %s | %d | %s | %s | %s | %d/%d | %s |\n", m, n, q3(s$hellinger, "%.3f"),
                q3(s$sd, "%.4f"), if (all(is.na(s$thetaSd))) "-" else q3(s$thetaSd, "%.2f"),
                sum(s$covers), nrow(s),
                if (all(is.na(s$rmse))) "-" else q3(s$rmse, "%.4f")))
  }
  th0 <- r$thetaSd[r$runs == init & r$method == methods[1]]
  if (!all(is.na(th0))) {
    cat(sprintf("\nPosterior sd of log thetaS (largest over the inputs) at the fit on the %d starting runs, per replicate: %s\n",
                init, paste(sprintf("%.2f", th0), collapse = ", ")))
  }
  # paired, per step: replicates where method a is closer to the reference
  # than b (finer than the runs-to-threshold, which moves in whole runs)
  closer <- function(r, a, b) {
    cmp <- vapply(steps[-1], function(n) {
      o <- r[r$method == a & r$runs == n, ]
      p <- r[r$method == b & r$runs == n, ]
      o <- o[o$rep %in% p$rep, ]  # (both still running: design.R --until)
      p <- p[match(o$rep, p$rep), ]
      sprintf("%d: %d/%d (%+.3f)", n, sum(o$hellinger < p$hellinger), nrow(o),
              median(p$hellinger - o$hellinger))
    }, "")
    cat(sprintf("\n%s closer to the reference than %s (paired replicates; median %s minus %s Hellinger), at runs %s\n",
                a, b, b, a, paste(cmp, collapse = "; ")))
  }
  if (all(c("ours", "plugin") %in% methods)) closer(r, "ours", "plugin")
  # ours with more draws, on the replicates where it ran
  for (v in variants) {
    vr <- unique(rv$rep[rv$method == v & rv$runs == budget])
    s <- rv[rv$rep %in% intersect(vr, done) & rv$method %in% c("ours", "plugin", v), ]
    if (!nrow(s)) next
    cat(sprintf("\n%s (ours with %s draws) on %d of these replicates: runs to Hellinger <= 0.1 %s",
                v, sub("ours", "", v), length(unique(s$rep)),
                paste(vapply(c("ours", "plugin", v), function(m) {
                  sprintf("%s %s", m, q3(reach_runs(s[s$method == m, ]), budget = budget))
                }, ""), collapse = ", ")))
    dv <- s[s$method == v & !is.na(s$designCpu), ]
    cat(sprintf("; its design step %.3f CPU s (median), design / fit median %.3f [%.3f, %.3f]\n",
                median(dv$designCpu), median(dv$designCpu / dv$fitCpu),
                quantile(dv$designCpu / dv$fitCpu, 0.25), quantile(dv$designCpu / dv$fitCpu, 0.75)))
    closer(s, v, "ours")
    closer(s, v, "plugin")
  }
  cat("\n| method | design CPU s, median [range] | fit it follows, CPU s | design / fit, median [quartiles] (range) | steps |\n|---|---|---|---|---|\n")
  for (m in methods) {
    s <- r[r$method == m & !is.na(r$designCpu), ]
    ratio <- s$designCpu / s$fitCpu
    cat(sprintf("| %s | %.3f [%.3f, %.3f] | %.2f [%.2f, %.2f] | %.3f [%.3f, %.3f] (%.3f-%.3f) | %d |\n", m,
                median(s$designCpu), min(s$designCpu), max(s$designCpu),
                median(s$fitCpu), min(s$fitCpu), max(s$fitCpu),
                median(ratio), quantile(ratio, 0.25), quantile(ratio, 0.75), min(ratio), max(ratio),
                nrow(s)))
  }
  up <- r[r$runs > init & r$method %in% methods, ]
  f0 <- r$fitCpu[r$runs == init & r$method %in% methods]
  cat(sprintf("\nWarm-started fits (update(fit, sim =)): CPU s median %.2f, range %.2f-%.2f; the fresh fit on the %d starting runs: median %.2f, range %.2f-%.2f\n",
              median(up$fitCpu), min(up$fitCpu), max(up$fitCpu), init,
              median(f0), min(f0), max(f0)))
  wf <- r[!is.na(r$warmCpu) & !is.na(r$freshCpu), ]
  if (nrow(wf)) {
    cat("\nWarm refit (update(fit, sim =)) against a fresh default fit on the same runs (each step's pair; median [quartiles]):\n")
    cat("\n| runs | pairs | warm / fresh CPU | warm / fresh sweeps | warm-up, warm | warm-up, fresh | sweeps, warm | sweeps, fresh | draws warm / fresh | converged (warm, fresh) | Hellinger warm-fresh |\n|---|---|---|---|---|---|---|---|---|---|---|\n")
    bins <- list(c(init, 10), c(10, 20), c(20, 35))
    for (b in bins) {
      s <- wf[wf$runs > b[1] & wf$runs <= b[2], ]
      if (!nrow(s)) next
      ok <- function(pre) sum(s[[paste0(pre, "Converged")]] & s[[paste0(pre, "Rhat")]] < 1.01 &
                              s[[paste0(pre, "Ess")]] >= 400)
      cat(sprintf("| %d-%d | %d | %s | %s | %s | %s | %s | %s | %s | %d, %d | %s |\n", b[1] + 1, b[2], nrow(s),
                  q3(s$warmCpu / s$freshCpu, "%.2f"), q3(s$warmSweeps / s$freshSweeps, "%.2f"),
                  q3(s$warmWarmup), q3(s$freshWarmup), q3(s$warmSweeps), q3(s$freshSweeps),
                  q3(s$warmDraws / s$freshDraws, "%.2f"), ok("warm"), ok("fresh"),
                  q3(s$warmFresh, "%.3f")))
    }
    cat(sprintf("\nAll pairs: warm / fresh CPU %s; warm cheaper in %d of %d; CPU s warm %s, fresh %s; sum of warm over sum of fresh %.2f\n",
                q3(wf$warmCpu / wf$freshCpu, "%.2f"), sum(wf$warmCpu < wf$freshCpu), nrow(wf),
                q3(wf$warmCpu, "%.2f"), q3(wf$freshCpu, "%.2f"), sum(wf$warmCpu) / sum(wf$freshCpu)))
    # by how update(fit, sim =) drew the step
    kind <- ifelse(!wf$reweighted, "refit", ifelse(is.na(wf$topUp) | wf$topUp == 0, "reweighted", "reweighted and continued"))
    if (any(wf$reweighted)) {
      cat("\n| step drawn by | pairs | warm / fresh CPU | warm CPU s | sweeps a chain added | Hellinger warm-fresh |\n|---|---|---|---|---|---|\n")
      for (k in c("reweighted", "reweighted and continued", "refit")) {
        s <- wf[kind == k, ]
        if (!nrow(s)) next
        cat(sprintf("| %s | %d | %s | %s | %s | %s |\n", k, nrow(s), q3(s$warmCpu / s$freshCpu, "%.2f"),
                    q3(s$warmCpu, "%.3f"), if (k == "reweighted and continued") q3(s$topUp) else "-",
                    q3(s$warmFresh, "%.3f")))
      }
    }
  }
}
