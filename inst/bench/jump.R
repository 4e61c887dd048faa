# kappa's jump move (the default since stop 41): default fits with and
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
#
#   Rscript inst/bench/jump.R
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

cat("\nCost a sweep (one chain, fixed length; ms a sweep)\n\n")
cat("| m | repeat | without | with |\n|---|---|---|---|\n")
set.seed(1)
for (m in c(40, 300, 1000)) {
  X <- cbind(runif(m), runif(m))
  sim <- data.frame(y = sin(10 * X[, 2] * X[, 1]), x = X[, 1], u = X[, 2])
  xs <- rep(seq(0.1, 0.9, length.out = 5), 2)
  fld <- data.frame(y = sin(10 * pi / 5 * xs) + rnorm(10, 0, 0.1), x = xs)
  model <- suppressWarnings(calibrate(sim, fld, discrepancy = "none", showProgress = FALSE, fit = FALSE))
  n <- if (m == 1000) 150 else 1000
  for (r in 1:2) {
    ms <- vapply(c(FALSE, TRUE), function(jump) {
      set.seed(r)
      1000 * cpu(model_fit(model, jump, nMCMC = n, nBurn = 100, nChains = 1)) / n
    }, numeric(1))
    cat(sprintf("| %d | %d | %.2f | %.2f |\n", m, r, ms[1], ms[2]))
  }
}
