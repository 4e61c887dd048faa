# kappa's jump move (a default move): default fits with and
# without it on a multimodal kappa posterior, and its cost a sweep.
#
# 1. Tuo and Wu's (2015) problem, eta(x, u) = exp(x/10) sin(x) -
#    sqrt(u^2 - u + 1) (sin(ux) + cos(ux)) on [0, 2 pi] x [-1, 1], field
#    exp(x/10) sin(x) at 8 inputs x 2 with noise sd 0.2, discrepancy
#    "none", maximin designs of 12, 18 and 24 runs (2 seeds each): a default
#    calibrate() (4 chains, until R-hat < 1.01 and bulk ESS >= 400) with the
#    jump and without it (the model's moves$jump dropped). CPU s, draws,
#    whether the rule was met, the largest R-hat, and the share of kappa's
#    draws below 0 overall and per chain.
# 2. The cost a sweep: the sinusoid sin(10 u x) with m = 40, 300 and 1000
#    random runs, fixed-length single-chain runs, ms a sweep with and
#    without the jump (2 repeats each).
# 3. Default runs to convergence on a unimodal posterior: the same
#    sinusoid, m = 40, 300 and 1000 random runs (design and chains from seed
#    s), a default calibrate() with and without the jump, paired by seed:
#    CPU s, sweeps a chain, checks, the parameters with the largest R-hat and
#    the smallest bulk ESS at the stop, and the jump's acceptance. Does the
#    jump lengthen the stop rule's runs? (Seeds 1-20 at m = 40, 1-10 at 300
#    and 1000: about 40 CPU minutes.)
#
#   Rscript bench/run.R jump [--part=modes,cost,default] [--m=40,300,1000]
#                             [--seeds=10]
suppressPackageStartupMessages(library(FBC))
cpu <- function(expr) {
  t <- proc.time()
  force(expr)
  d <- proc.time() - t
  d[["user.self"]] + d[["sys.self"]]
}
model_fit <- function(model, jump, ...) {
  if (!jump) model$moves$jump <- NULL
  suppressWarnings(calibrate(model, ...))
}
source("bench/options.R")
opt <- bench_options(list(part = c("modes", "cost", "default"), m = c(40L, 300L, 1000L),
                          seeds = NA_integer_))
parts <- opt$part
sinusoid <- function(m) {
  X <- cbind(runif(m), runif(m))
  sim <- data.frame(y = sin(10 * X[, 2] * X[, 1]), x = X[, 1], u = X[, 2])
  xs <- rep(seq(0.1, 0.9, length.out = 5), 2)
  fld <- data.frame(y = sin(10 * pi / 5 * xs) + rnorm(10, 0, 0.1), x = xs)
  suppressWarnings(calibrate(sim, fld, discrepancy = "none", showProgress = FALSE, fit = FALSE))
}

if ("modes" %in% parts) {
eta <- function(x, u) exp(x / 10) * sin(x) - sqrt(u^2 - u + 1) * (sin(u * x) + cos(u * x))
xf <- rep(seq(0.2, 2 * pi - 0.2, length.out = 8), 2)
set.seed(1001)
field <- data.frame(y = exp(xf / 10) * sin(xf) + rnorm(16, 0, 0.2), x = xf)
cat("Tuo and Wu's problem, default fits (4 chains, until converged)\n\n")
cat("| runs | seed | jump | CPU s | draws | rule met | max R-hat | P(kappa < 0) | per chain |\n|---|---|---|---|---|---|---|---|---|\n")
for (n in c(12, 18, 24)) for (s in 1:2) for (jump in c(FALSE, TRUE)) {
  set.seed(100 * n + s)
  U <- lhs::maximinLHS(n, 2)
  sim <- data.frame(y = eta(2 * pi * U[, 1], -1 + 2 * U[, 2]), x = 2 * pi * U[, 1], u1 = -1 + 2 * U[, 2])
  set.seed(s)
  m <- suppressWarnings(calibrate(sim, field, discrepancy = "none", showProgress = FALSE, fit = FALSE))
  t <- cpu(fit <- model_fit(m, jump))
  k <- fit$Phi[, "kappa1"]
  cat(sprintf("| %d | %d | %s | %.1f | %d | %s | %.3f | %.3f | %s |\n", n, s, if (jump) "yes" else "no", t,
              length(k), fit$settings$converge$converged, max(fit$estimates$rhat, na.rm = TRUE),
              mean(k < 0), paste(sprintf("%.2f", tapply(k < 0, fit$chain, mean)), collapse = " ")))
}
}

if ("cost" %in% parts) {
cat("\nCost a sweep (one chain, fixed length; ms a sweep)\n\n")
cat("| m | repeat | without | with |\n|---|---|---|---|\n")
set.seed(1)
for (m in c(40, 300, 1000)) {
  model <- sinusoid(m)
  n <- if (m == 1000) 150 else 1000
  for (r in 1:2) {
    ms <- vapply(c(FALSE, TRUE), function(jump) {
      set.seed(r)
      1000 * cpu(model_fit(model, jump, nMCMC = n, nBurn = 100, nChains = 1)) / n
    }, numeric(1))
    cat(sprintf("| %d | %d | %.2f | %.2f |\n", m, r, ms[1], ms[2]))
  }
}
}

if ("default" %in% parts) {
cat("\nDefault runs to convergence (4 chains, R-hat < 1.01 and bulk ESS >= 400), paired by seed\n\n")
cat("| m | seed | jump | CPU s | sweeps | checks | met | largest R-hat | smallest ESS | jump accepted |\n|---|---|---|---|---|---|---|---|---|---|\n")
res <- NULL
for (m in opt$m) {
  nseeds <- if (is.na(opt$seeds)) if (m <= 100) 20L else 10L else opt$seeds
  for (s in seq_len(nseeds)) {
    set.seed(s)
    model <- sinusoid(m)
    for (jump in c(FALSE, TRUE)) {
      set.seed(s)
      t <- cpu(fit <- model_fit(model, jump, showProgress = FALSE))
      e <- fit$estimates
      rep <- FBC:::move_report(fit)
      acc <- if (jump) sprintf("%.3f", rep$acceptance[rep$kind == "jump"]) else "-"
      cv <- fit$settings$converge
      cat(sprintf("| %d | %d | %s | %.1f | %d | %d | %s | %s %.3f | %s %.0f | %s |\n", m, s, if (jump) "yes" else "no",
                  t, cv$sweeps, cv$checks, cv$converged, rownames(e)[which.max(e$rhat)], max(e$rhat),
                  rownames(e)[which.min(e$ess)], min(e$ess), acc))
      res <- rbind(res, data.frame(m = m, seed = s, jump = jump, cpu = t, sweeps = cv$sweeps))
    }
  }
}
cat("\nPer m: median [range] CPU s and sweeps, and in how many seeds the run with the jump kept more sweeps\n\n")
cat("| m | seeds | CPU s without | CPU s with | sweeps without | sweeps with | with longer / shorter / same | ratio of CPU s (with / without), median [range] |\n|---|---|---|---|---|---|---|---|\n")
for (m in unique(res$m)) {
  a <- res[res$m == m & !res$jump, ]; b <- res[res$m == m & res$jump, ]
  r <- b$cpu / a$cpu
  f <- function(v, d = 1) sprintf(paste0("%.", d, "f [%.", d, "f, %.", d, "f]"), median(v), min(v), max(v))
  cat(sprintf("| %d | %d | %s | %s | %s | %s | %d / %d / %d | %s |\n", m, nrow(a), f(a$cpu), f(b$cpu),
              f(a$sweeps, 0), f(b$sweeps, 0), sum(b$sweeps > a$sweeps), sum(b$sweeps < a$sweeps),
              sum(b$sweeps == a$sweeps), f(r, 2)))
}
}
