# Benchmark of emulator_cv(): CPU seconds of MAP
# validation through the compiled algebra (.fbc_heldout(): the Kronecker
# eigendecompositions on a product design, the dense Cholesky factor
# otherwise), against the former R-side computation, kept here as
# old_heldout() for the comparison only (one m x m correlation matrix,
# chol() and chol2inv() per draw, then one chol2inv() per fold).
#
# Run after installing FBC:  Rscript bench/run.R validate
# Cases (MAP draw of a short calibrate() run, default folds):
#   decay     decaySim/decayField: m = 4000, a 50 x 80 product design
#             (Kronecker algebra), 10 folds (m > 2000)
#   m1000     p = q = 2, n = 60, m = 1000 runs of a smooth simulator at a
#             Latin hypercube (dense algebra), leave-one-out
# Columns: CPU s of emulator_cv(fit, method = "MAP") (new), of the
# R-side computation at the same draw (old), and the largest difference of
# their held-out means and sds relative to the response's sd.
#
# RESULTS (2026-11-23, reference BLAS, 2 shared cores; short runs of
# calibrate(): nMCMC 200 / 20, one chain):
#   case    m   algebra folds new_cpu_s old_cpu_s max_rel_diff
#  decay 4000 Kronecker    10      0.52     32.99      5.4e-12
#  m1000 1000     dense  1000      0.30      0.42      5.9e-13
# Leave-one-out on decaySim (folds = 4000) takes 0.01 CPU s: a fold of one
# run needs only the diagonal of Ds^-1.
suppressPackageStartupMessages(library(FBC))
cpu <- function() sum(proc.time()[c(1, 2, 4, 5)], na.rm = TRUE)
cpu_of <- function(expr) {
  t0 <- cpu()
  expr
  cpu() - t0
}

# The former R-side held-out predictive at one draw (validate.R before the
# algebra took it over): scaled space, list(mean, sd).
old_heldout <- function(fit, phi) {
  idx <- FBC:::param_indices(fit$model$scale$p, fit$model$scale$q)
  Xs <- fit$model$data$Xs
  y <- fit$model$data$ys
  K <- FBC:::.corr_matrix(Xs, Xs, phi[idx$thetaS], phi[idx$alphaS],
                          FBC:::model_codes(fit$model$spec)$kernS)
  diag(K) <- diag(K) + fit$settings$nugget
  Q <- chol2inv(chol(K))
  a <- drop(Q %*% y)
  fold <- FBC:::emulator_folds(NULL, length(y))
  if (is.null(fold)) {
    d <- diag(Q)
    return(list(mean = y - a / d, sd = sqrt(phi[idx$sigma2S] / d)))
  }
  mean <- var <- numeric(length(y))
  for (k in unique(fold)) {
    B <- which(fold == k)
    S <- chol2inv(chol(Q[B, B, drop = FALSE]))
    mean[B] <- y[B] - drop(S %*% a[B])
    var[B] <- diag(S)
  }
  list(mean = mean, sd = sqrt(phi[idx$sigma2S] * var))
}

# A smooth simulator at a Latin hypercube (as bench/scale.R's m1000).
synthetic_problem <- function(n, m, seed = 1) {
  set.seed(seed)
  eta <- function(x1, x2, t1, t2) sin(2 * pi * x1) * (1 + t1) + exp(-x2) * t2 + x1 * x2 * t1 * t2
  D <- apply(matrix(0, m, 4), 2, function(z) (sample(m) - runif(m)) / m)
  sim <- data.frame(y = eta(D[, 1], D[, 2], D[, 3], D[, 4]), x1 = D[, 1], x2 = D[, 2],
                    t1 = D[, 3], t2 = D[, 4])
  xf <- matrix(runif(2 * n), n)
  field <- data.frame(y = eta(xf[, 1], xf[, 2], 0.3, 0.7) + 0.1 * xf[, 1] + rnorm(n, 0, 0.05),
                      x1 = xf[, 1], x2 = xf[, 2])
  list(sim = sim, field = field)
}

bench <- function(name, sim, field, nMCMC, nBurn) {
  set.seed(1)
  fit <- suppressWarnings(calibrate(sim, field, nMCMC = nMCMC, nBurn = nBurn, nChains = 1))
  new_s <- cpu_of(v <- emulator_cv(fit, method = "MAP"))
  phi <- FBC:::sampler_draws(fit, which.max(fit$logPost))[1, ]
  old_s <- cpu_of(o <- old_heldout(fit, phi))
  sc <- fit$model$scale
  diff <- max(abs(v$runs$mean - (sc$ymean + sc$ysd * o$mean)), abs(v$runs$sd - sc$ysd * o$sd)) / sc$ysd
  data.frame(case = name, m = nrow(fit$model$data$Xs), algebra = fit$model$algebra$name,
             folds = v$nFolds, new_cpu_s = round(new_s, 2), old_cpu_s = round(old_s, 2),
             max_rel_diff = signif(diff, 2))
}

m1000 <- synthetic_problem(60, 1000)
res <- rbind(bench("decay", decaySim, decayField, nMCMC = 200, nBurn = 100),
             bench("m1000", m1000$sim, m1000$field, nMCMC = 20, nBurn = 10))
print(res, row.names = FALSE)
