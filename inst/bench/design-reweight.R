# Could a loop step reuse the old draws instead of refitting? (issue 30,
# "a loop step costs far less than a fresh fit"). A script, not a timed test:
#
#   Rscript inst/bench/design-reweight.R [reps] [added]
#
# The sinusoid of design.R (eta = sin(10 u x), field at u = pi / 5, 5
# inputs x 2 replicates, sd 0.1, discrepancy "none"), 5 maximin starting
# runs, batches of 1 chosen by propose_runs() (defaults, 100 d uniform
# candidates), each step refitted by update(fit, sim = new) as design.R
# does. At each step the old fit's draws are reweighted to the posterior
# with the new run: the GP marginal likelihood factorises, so
# p(phi | D, y*) is p(phi | D) N(y*; mu_s, v_s) with (mu_s, v_s) the new
# run's conditional given draw s and the old data (.design_systems(), the
# look-ahead's per-draw systems; exact for the model on the old scaling,
# while the refit's model is rescaled to all runs). Per step: the weights'
# Kish ESS as a share of the draws, the reweighted draws' effective count
# (the old fit's smallest bulk ESS times that share) against the stop
# rule's 400, the Hellinger distance of the reweighted kappa posterior to
# the refit's (weighted kernel density; the noise level between two fits
# is design.R --fresh's warm-fresh distance), and CPU s of the reweighting
# against the refit.
suppressPackageStartupMessages(library(FBC))
args <- commandArgs(TRUE)
reps <- if (length(args) >= 1) as.integer(args[1]) else 5L
added <- if (length(args) >= 2) as.integer(args[2]) else 20L
eta <- function(X) sin(10 * X[, 2] * X[, 1])
xf <- rep(seq(0.1, 0.9, length.out = 5), 2)
d <- 2
cpu <- function(expr) {
  t0 <- proc.time()
  force(expr)
  sum((proc.time() - t0)[1:2])
}
runs_at <- function(X) {
  X <- matrix(X, ncol = d)
  data.frame(y = eta(X), x = X[, 1], u1 = X[, 2])
}
grid <- (seq_len(1000) - 0.5) / 1000
dens <- function(v, w = NULL) {
  k <- density(v, weights = w, from = 0, to = 1, n = 1000, bw = bw.SJ(v))$y
  k / sum(k / 1000)
}
hell <- function(a, b) sqrt(max(0, 1 - sum(sqrt(a * b)) / 1000))
# the old fit's draws reweighted by the new runs' predictive density
reweight <- function(fit, new) {
  model <- fit$model
  dat <- model$data
  sc <- model$scale
  phis <- FBC:::sampler_draws(fit)
  U <- FBC:::scale_inputs(as.matrix(new[c("x", "u1")]), sc, seq_len(d))
  sys <- FBC:::.design_systems(dat$Xf, dat$yf, dat$Xs, dat$ys, phis, U, matrix(0, 0, 1),
                               FBC:::fbc_nugget, model$spec$model)
  ystar <- (new$y - sc$ymean[1]) / sc$ysd[1]
  lw <- stats::dnorm(ystar, sys$mu[1, ], sqrt(sys$v[1, ]), log = TRUE)
  w <- exp(lw - max(lw))
  w / sum(w)
}
rows <- list()
for (r in seq_len(reps)) {
  set.seed(1000 + r)
  field <- data.frame(y = eta(cbind(xf, pi / 5)) + rnorm(length(xf), 0, 0.1), x = xf)
  start <- lhs::maximinLHS(5, d)
  set.seed(2000 + r)
  sim <- runs_at(start)
  fit <- suppressWarnings(calibrate(sim, field, discrepancy = "none", showProgress = FALSE))
  for (k in seq_len(added)) {
    cand <- stats::setNames(as.data.frame(matrix(runif(100 * d * d), ncol = d)), c("x", "u1"))
    new <- runs_at(as.matrix(suppressMessages(propose_runs(fit, n = 1, candidates = cand))[c("x", "u1")]))
    tW <- cpu(w <- reweight(fit, new))
    kish <- 1 / sum(w^2) / length(w)
    essOld <- min(fit$estimates$ess, na.rm = TRUE)
    K0 <- fit$Phi[, "kappa1"]
    old <- fit
    sim <- rbind(sim, new)
    tR <- cpu(fit <- suppressWarnings(update(fit, sim = new)))
    rows[[length(rows) + 1]] <- data.frame(
      rep = r, runs = nrow(sim), draws = length(w), kish = kish, effective = essOld * kish,
      hellRe = hell(dens(K0, w), dens(fit$Phi[, "kappa1"])),
      hellOld = hell(dens(K0), dens(fit$Phi[, "kappa1"])),
      cpuReweight = tW, cpuRefit = tR)
  }
  cat(sprintf("rep %d done\n", r))
}
res <- do.call(rbind, rows)
saveRDS(res, "design-reweight.rds")
q3 <- function(v, f = "%.2f") sprintf(paste0(f, " [", f, ", ", f, "]"), median(v),
                                         quantile(v, 0.25), quantile(v, 0.75))
cat(sprintf("FBC %s, %d replicates, steps from 6 to %d runs\n\n", packageVersion("FBC"), reps, 5 + added))
cat("| runs | steps | Kish ESS / draws | reweighted effective draws | >= 400 | Hellinger reweighted-refit | Hellinger old-refit | CPU s reweight / refit |\n|---|---|---|---|---|---|---|---|\n")
for (b in list(c(5, 10), c(10, 15), c(15, 25))) {
  s <- res[res$runs > b[1] & res$runs <= b[2], ]
  if (!nrow(s)) next
  cat(sprintf("| %d-%d | %d | %s | %s | %d | %s | %s | %s |\n", b[1] + 1, b[2], nrow(s), q3(s$kish),
              q3(s$effective, "%.0f"), sum(s$effective >= 400), q3(s$hellRe, "%.3f"),
              q3(s$hellOld, "%.3f"), q3(s$cpuReweight / s$cpuRefit, "%.3f")))
}
