# Are update(fit, sim =)'s reweighted draws as good as their bulk ESS says?
# (a loop step reweights the old draws, ?update_runs). A script,
# not a timed test:
#
#   Rscript bench/run.R design-reweight [--runs=9] [--repeats=40]
#
# The sinusoid of design.R (eta = sin(10 u x), field at u = pi / 5, 5
# inputs x 2 replicates, sd 0.1, discrepancy "none"), `runs` maximin runs
# and one more (fixed: the data are the same in every repeat). Each repeat
# fits the first `runs` runs (own seed), adds the last by update(fit, sim
# =) (reweighted, reweighted and continued, or refitted: counted), and
# fits all runs afresh. Over the repeats, the variance of a draws' mean
# against the posterior variance over the ESS the fit claims,
#   var_r(mean_r) / mean_r(var_r / ESS_r),
# is about 1 when the claimed ESS is honest (above 1: overstated), for
# kappa and log thetaS1, for update()'s fits by how they were drawn and for
# the fresh fits (the reference: the sampler's own ESS estimates). With 40
# repeats the ratio's own sd is about 0.22.
suppressPackageStartupMessages(library(FBC))
source("bench/options.R")
opt <- bench_options(list(runs = 9L, repeats = 40L))
k <- opt$runs
R <- opt$repeats
set.seed(11)
eta <- function(X) sin(10 * X[, 2] * X[, 1])
xf <- rep(seq(0.1, 0.9, length.out = 5), 2)
field <- data.frame(y = eta(cbind(xf, pi / 5)) + rnorm(10, 0, 0.1), x = xf)
X <- lhs::maximinLHS(k + 1, 2)
sim <- data.frame(y = eta(X), x = X[, 1], u1 = X[, 2])
cpu <- function(expr) {
  t0 <- proc.time()
  force(expr)
  sum((proc.time() - t0)[1:2])
}
facts <- function(fit, pre) {
  stats::setNames(data.frame(mean(fit$Phi[, 1]), var(fit$Phi[, 1]), fit$estimates["kappa1", "ess"],
                             mean(log(fit$Phi[, 2])), var(log(fit$Phi[, 2])),
                             fit$estimates["thetaS1", "ess"]),
                  paste0(pre, c("K", "Kv", "Ke", "T", "Tv", "Te")))
}
rows <- lapply(seq_len(R), function(r) {
  set.seed(100 + r)
  fit <- suppressWarnings(calibrate(sim[1:k, ], field, discrepancy = "none", showProgress = FALSE))
  tU <- cpu(up <- update(fit, sim = sim[k + 1, ]))
  tF <- cpu(fresh <- suppressWarnings(calibrate(sim, field, discrepancy = "none", showProgress = FALSE)))
  rw <- up$settings$reweight
  cbind(data.frame(kind = if (!isTRUE(rw$used)) "refitted" else if (rw$topUp > 0)
    "reweighted and continued" else "reweighted", cpu = tU / tF),
    facts(up, "u"), facts(fresh, "f"))
})
x <- do.call(rbind, rows)
cal <- function(m, v, e) var(m) / mean(v / e)
cat(sprintf("FBC %s: %d runs + 1, %d repeats\n\n", packageVersion("FBC"), k, R))
cat("| fits | repeats | CPU / fresh fit, median | claimed kappa1 ESS, median | kappa1 ratio | log thetaS1 ratio |\n|---|---|---|---|---|---|\n")
line <- function(lab, y, pre, cpu = "-") {
  cat(sprintf("| %s | %d | %s | %.0f | %.2f | %.2f |\n", lab, nrow(y), cpu, median(y[[paste0(pre, "Ke")]]),
              cal(y[[paste0(pre, "K")]], y[[paste0(pre, "Kv")]], y[[paste0(pre, "Ke")]]),
              cal(y[[paste0(pre, "T")]], y[[paste0(pre, "Tv")]], y[[paste0(pre, "Te")]])))
}
line("update(), all", x, "u", sprintf("%.2f", median(x$cpu)))
for (kd in c("reweighted", "reweighted and continued", "refitted")) {
  y <- x[x$kind == kd, ]
  if (nrow(y) >= 5) line(paste("update(),", kd), y, "u", sprintf("%.2f", median(y$cpu)))
}
line("fresh calibrate()", x, "f")
