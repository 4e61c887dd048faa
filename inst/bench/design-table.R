# Summarises inst/bench/design.R's per-replicate results (design-*.rds in
# the working directory): runs to reach Hellinger <= 0.1 to the reference
# per method and problem (median and quartiles over replicates; a
# replicate that does not reach it within the budget counts as beyond it,
# "> max"), Hellinger, kappa1's sd and coverage at chosen run counts, and
# the design step's CPU s against the fit's.
#
#   Rscript inst/bench/design-table.R
files <- list.files(".", "^design-.*-r[0-9]+\\.rds$")
res <- do.call(rbind, lapply(files, readRDS))
res$setting <- paste0(res$problem, ", batches of ", res$batch)
q3 <- function(v, fmt = "%.0f") {
  s <- function(x) if (is.infinite(x)) paste0(">", max(res$runs)) else sprintf(fmt, x)
  sprintf("%s [%s, %s]", s(median(v)), s(quantile(v, 0.25, type = 1)), s(quantile(v, 0.75, type = 1)))
}
for (st in unique(res$setting)) {
  r <- res[res$setting == st, ]
  cat(sprintf("\n### %s (%d paired replicates)\n\n", st, length(unique(r$rep))))
  cat("| method | runs to Hellinger <= 0.1, median [quartiles] | replicates reaching it |\n|---|---|---|\n")
  for (m in c("ours", "plugin", "lhs", "random")) {
    s <- r[r$method == m, ]
    reach <- vapply(split(s, s$rep), function(x) {
      h <- x$runs[x$hellinger <= 0.1]
      if (length(h)) min(h) else Inf
    }, 0)
    cat(sprintf("| %s | %s | %d/%d |\n", m, q3(reach), sum(is.finite(reach)), length(reach)))
  }
  steps <- intersect(c(10, 15, 20, 30, 50), r$runs)
  cat("\n| method | runs | Hellinger | kappa1 sd | covers | design CPU s | fit CPU s |\n|---|---|---|---|---|---|---|\n")
  for (m in c("ours", "plugin", "lhs", "random")) for (n in steps) {
    s <- r[r$method == m & r$runs == n, ]
    rng <- function(v) if (all(is.na(v))) "-" else sprintf("%.3f-%.3f", min(v, na.rm = TRUE), max(v, na.rm = TRUE))
    cat(sprintf("| %s | %d | %s | %s | %d/%d | %s | %s |\n", m, n, q3(s$hellinger, "%.3f"),
                q3(s$sd, "%.4f"), sum(s$covers), nrow(s), rng(s$designCpu), rng(s$fitCpu)))
  }
  for (m in c("ours", "plugin")) {
    s <- r[r$method == m & !is.na(r$designCpu) & r$runs > 10, ]
    # the design step against the warm-started fit it follows (the fit on
    # the same runs, the row's fitCpu)
    ratio <- s$designCpu / s$fitCpu
    cat(sprintf("\n%s: design step / the fit it follows: median %.2f, range %.2f-%.2f (%d steps)\n",
                m, median(ratio), min(ratio), max(ratio), length(ratio)))
  }
  up <- r[r$runs > 10, ]
  cat(sprintf("warm-started fits (update(fit, sim =)): CPU s median %.2f, range %.2f-%.2f; fresh fits on the 10 starting runs: median %.2f, range %.2f-%.2f\n",
              median(up$fitCpu), min(up$fitCpu), max(up$fitCpu),
              median(r$fitCpu[r$runs == 10]), min(r$fitCpu[r$runs == 10]), max(r$fitCpu[r$runs == 10])))
}
