# Global sensitivity with known answers: how often the 90% intervals of
# sensitivity() cover the true Sobol indices, how wide they are as the runs
# grow, and what sensitivity() costs.
#
#   Rscript bench/run.R sensitivity [--m=50,100,200] [--designs=20,20,10]
#                                   [--problems=ishigami,gfun] [--out=sensitivity-study.rds]
#                                   [--paths=128]
#
# Problems (simulator runs on a maximin Latin hypercube, the best of 50
# random Latin hypercubes by smallest distance, one per design seed):
#   ishigami  f = sin x1 + 7 sin^2 x2 + 0.1 x3^4 sin x1 on U(-pi, pi)^3;
#             x1, x2 experimental, x3 the calibration input. Field: 10
#             points (x1, x2) of a maximin Latin hypercube at the true
#             x3 = 1, noise sd 0.05. True S = (0.3139, 0.4424, 0),
#             ST = (0.5576, 0.4424, 0.2437).
#   gfun      Sobol's g-function prod_i (|4 x_i - 2| + a_i) / (1 + a_i) on
#             U(0, 1)^6, a = (0, 1, 4.5, 9, 99, 99); x1, x3, x4, x5
#             experimental, x2 and x6 the calibration inputs. Field: 20
#             points at the true (x2, x6) = (0.3, 0.6), noise sd 0.02.
#             True indices from V_i = 1 / (3 (1 + a_i)^2).
#   gpath     a well-specified problem: one draw of a Matern 5/2 GP on
#             U(0, 1)^3 (length-scales 0.35, 0.5, 0.45), the interpolant of
#             its values at 300 fixed points; x1, x2 experimental, x3 the
#             calibration input. Field: 10 points at x3 = 0.5, noise sd
#             0.05. True indices by quadrature in plain R.
# Each design: calibrate() with the default kernels (kernelS = "matern52",
# a GP discrepancy) and its default run length (four chains run until they
# have converged; --nMCMC, --nBurn, --nChains > 0 fix them instead),
# then sensitivity(fit, prediction = FALSE) with its defaults (200 draws,
# each with a conditional sample path through 128 support points; method
# "FBC") and with paths = 0 (the indices of the emulator's mean; "FBC
# (mean)"), the measure the problem's box (inputs = the true ranges).
# Columns per method, problem and m:
# designs run; coverage of the true first-order (S) and total (ST) indices
# by the 90% intervals, over designs and inputs, with its binomial standard
# error sqrt(c (1 - c) / pairs) (se_*; pairs of one design are not
# independent, so it is a lower bound) (cover_S_nz: over the
# inputs whose true S is not zero, which no interval of a positive index
# holds); mean interval widths; the
# largest |median - truth|'s mean over designs; CPU seconds of
# calibrate() and of sensitivity(fit, prediction = FALSE) (median and range
# over designs), and of sensitivity(fit) with every default on the first
# design of each m.
# sensitivity::sobolGP (plug-in kriging, hyperparameters fixed, fitted by
# DiceKriging::km with the Matern 5/2 kernel; 100 conditional simulations
# on two Monte Carlo samples of --peer_n points) is run on the same runs
# where the sensitivity and DiceKriging packages are installed. Results accumulate in --out, one row per design, so an
# interrupted study resumes.
library(FBC)
source("bench/options.R")
opt <- bench_options(list(m = c(50L, 100L, 200L), designs = c(20L, 20L, 10L),
                          problems = c("ishigami", "gfun"), nMCMC = 0L, nBurn = 0L,
                          nChains = 0L, peer_n = 300L, paths = 128L,
                          out = "sensitivity-study.rds"))
if (opt$quick) {
  opt$m <- 50L
  opt$designs <- 2L
  opt$nMCMC <- 600L
  opt$nBurn <- 300L
}
opt$designs <- rep(opt$designs, length.out = length(opt$m))
cpu <- function() sum(proc.time()[c("user.self", "sys.self")])

maximin_lhs <- function(n, d, tries = 50L) {
  best <- NULL
  bestd <- -Inf
  for (i in seq_len(tries)) {
    X <- sapply(seq_len(d), function(k) (sample(n) - stats::runif(n)) / n)
    dm <- min(stats::dist(X))
    if (dm > bestd) {
      best <- X
      bestd <- dm
    }
  }
  best
}

gfun_a <- c(0, 1, 4.5, 9, 99, 99)
gfun <- function(X) apply(X, 1, function(x) prod((abs(4 * x - 2) + gfun_a) / (1 + gfun_a)))
gfun_truth <- local({
  Vi <- 1 / (3 * (1 + gfun_a)^2)
  V <- prod(1 + Vi) - 1
  list(S = Vi / V, ST = Vi * sapply(seq_along(Vi), function(i) prod(1 + Vi[-i])) / V)
})

# Gauss-Legendre nodes and weights of 8 points on [0, 1/400] (Golub-Welsch).
statmod_free_gl8 <- function() {
  i <- 1:7
  b <- i / sqrt(4 * i^2 - 1)
  J <- matrix(0, 8, 8)
  J[cbind(i, i + 1)] <- b
  J[cbind(i + 1, i)] <- b
  e <- eigen(J, symmetric = TRUE)
  list(x = (e$values + 1) / 2 / 400, w = e$vectors[1, ]^2 / 400)
}
# A well-specified problem: a function the emulator's own family describes,
# the interpolant of one draw of a zero-mean Matern 5/2 GP (unit variance,
# length-scales gp_len on [0, 1]^3) at 300 fixed quasi-random points, a
# kernel expansion f(z) = sum_j a_j prod_k r_k(z_k - c_jk) whose indices
# follow in plain R from one-dimensional integrals on a fine composite
# Gauss-Legendre rule (the formulas of Oakley and O'Hagan 2004).
gp_len <- c(0.35, 0.5, 0.45)
matern52 <- function(d, l) {
  u <- sqrt(5) * abs(d) / l
  (1 + u + u^2 / 3) * exp(-u)
}
gpath <- local({
  set.seed(2026)
  C <- matrix(stats::runif(300 * 3), 300, 3)
  K <- Reduce(`*`, lapply(1:3, function(k) matern52(outer(C[, k], C[, k], "-"), gp_len[k])))
  L <- chol(K + 1e-8 * diag(300))
  a <- backsolve(L, forwardsolve(t(L), drop(crossprod(L, stats::rnorm(300)))))
  f <- function(X) {
    R <- Reduce(`*`, lapply(1:3, function(k) matern52(outer(X[, k], C[, k], "-"), gp_len[k])))
    drop(R %*% a)
  }
  # 1-D integrals against U(0, 1): 400 panels of 8 Gauss-Legendre nodes
  g <- statmod_free_gl8()
  t <- as.vector(outer(g$x, (0:399) / 400, "+")) ; w <- rep(g$w, 400)
  I1 <- sapply(1:3, function(k) colSums(w * matern52(outer(t, C[, k], "-"), gp_len[k])))
  I2 <- lapply(1:3, function(k) {
    R <- matern52(outer(t, C[, k], "-"), gp_len[k])
    crossprod(R * w, R)
  })
  f0 <- sum(a * apply(I1, 1, prod))
  V <- drop(t(a) %*% Reduce(`*`, I2) %*% a) - f0^2
  S <- ST <- numeric(3)
  for (k in 1:3) {
    ak <- a * apply(I1[, -k, drop = FALSE], 1, prod)
    S[k] <- (drop(t(ak) %*% I2[[k]] %*% ak) - f0^2) / V
    ai <- a * I1[, k]
    ST[k] <- 1 - (drop(t(ai) %*% Reduce(`*`, I2[-k]) %*% ai) - f0^2) / V
  }
  list(f = f, S = S, ST = ST)
})
problems <- list(
  ishigami = list(
    d = 3L, exp = 1:2, cal = 3L, lower = rep(-pi, 3), upper = rep(pi, 3),
    f = function(X) sin(X[, 1]) + 7 * sin(X[, 2])^2 + 0.1 * X[, 3]^4 * sin(X[, 1]),
    nf = 10L, kappa = 1, sd = 0.05,
    S = c(0.3139, 0.4424, 0), ST = c(0.5576, 0.4424, 0.2437)
  ),
  gfun = list(
    d = 6L, exp = c(1L, 3L, 4L, 5L), cal = c(2L, 6L), lower = rep(0, 6), upper = rep(1, 6),
    f = gfun, nf = 20L, kappa = c(0.3, 0.6), sd = 0.02,
    S = gfun_truth$S, ST = gfun_truth$ST
  ),
  gpath = list(
    d = 3L, exp = 1:2, cal = 3L, lower = rep(0, 3), upper = rep(1, 3),
    f = gpath$f, nf = 10L, kappa = 0.5, sd = 0.05, S = gpath$S, ST = gpath$ST
  )
)

# One design of problem pr with m runs (seed): the fit's data in FBC's
# column order (experimental inputs, then calibration inputs).
make_data <- function(pr, m, seed) {
  set.seed(seed)
  U <- maximin_lhs(m, pr$d)
  X <- sweep(sweep(U, 2, pr$upper - pr$lower, "*"), 2, pr$lower, "+")
  ord <- c(pr$exp, pr$cal)
  nmx <- paste0("x", ord)
  sim <- cbind(y = pr$f(X), X[, ord])
  colnames(sim) <- c("y", nmx)
  Uf <- maximin_lhs(pr$nf, length(pr$exp))
  Xf <- matrix(0, pr$nf, pr$d)
  Xf[, pr$exp] <- sweep(sweep(Uf, 2, pr$upper[pr$exp] - pr$lower[pr$exp], "*"), 2,
                        pr$lower[pr$exp], "+")
  Xf[, pr$cal] <- matrix(pr$kappa, pr$nf, length(pr$cal), byrow = TRUE)
  field <- cbind(y = pr$f(Xf) + stats::rnorm(pr$nf, 0, pr$sd), Xf[, pr$exp])
  colnames(field) <- c("y", paste0("x", pr$exp))
  list(sim = sim, field = field, X = X, y = pr$f(X), ord = ord, names = nmx)
}

have_sobolgp <- requireNamespace("sensitivity", quietly = TRUE) &&
  requireNamespace("DiceKriging", quietly = TRUE)

one_design <- function(pname, m, seed) {
  pr <- problems[[pname]]
  dat <- make_data(pr, m, seed)
  inputs <- lapply(dat$ord, function(k) c(pr$lower[k], pr$upper[k]))
  names(inputs) <- dat$names
  t0 <- cpu()
  run <- list(nMCMC = opt$nMCMC, nBurn = opt$nBurn, nChains = opt$nChains)
  run <- run[vapply(run, function(v) v > 0L, logical(1))]  # 0: calibrate()'s default
  fit <- suppressWarnings(do.call(calibrate, c(list(dat$sim, dat$field), run)))
  t_fit <- cpu() - t0
  t0 <- cpu()
  # (--paths: the support points of each draw's sample path; 128 is the
  # default)
  s <- sensitivity(fit, inputs = inputs, paths = opt$paths, prediction = FALSE)
  t_sens <- cpu() - t0
  # the default call (with the prediction's part) on each m's first design
  t_default <- NA_real_
  if (seed == 1L) {
    t0 <- cpu()
    sensitivity(fit, inputs = inputs)
    t_default <- cpu() - t0
  }
  # the indices of the emulator's mean alone (paths = 0), for comparison
  t0 <- cpu()
  s0 <- sensitivity(fit, inputs = inputs, paths = 0, prediction = FALSE)
  t_mean <- cpu() - t0
  truth <- c(pr$S[dat$ord], pr$ST[dat$ord])
  rows <- function(tab, t, peer) {
    data.frame(problem = pname, m = m, seed = seed, input = tab$input, index = tab$index,
               truth = truth, median = tab$median, lower = tab$lower, upper = tab$upper,
               cpu_fit = t_fit, cpu_sens = t, cpu_default = t_default, peer = peer,
               stringsAsFactors = FALSE)
  }
  row <- rbind(rows(s$simulator, t_sens, "FBC"), rows(s0$simulator, t_mean, "FBC (mean)"))
  if (have_sobolgp) {
    # plug-in kriging on the same runs (all inputs as one space)
    t0 <- cpu()
    km <- DiceKriging::km(design = as.data.frame(dat$X), response = dat$y,
                          covtype = "matern5_2", control = list(trace = FALSE))
    nx <- opt$peer_n
    sg <- sensitivity::sobolGP(km, type = "SK", MCmethod = "sobol", X1 = as.data.frame(
      matrix(stats::runif(nx * pr$d, pr$lower, pr$upper), nx, pr$d, byrow = TRUE)),
      X2 = as.data.frame(matrix(stats::runif(nx * pr$d, pr$lower, pr$upper), nx, pr$d,
                                byrow = TRUE)), nsim = 100, nboot = 1)
    t_peer <- cpu() - t0
    ci <- function(x) x$ci
    peer <- data.frame(problem = pname, m = m, seed = seed, input = paste0("x", seq_len(pr$d)),
                       index = rep(c("first", "total"), each = pr$d),
                       truth = c(pr$S, pr$ST),
                       median = c(sg$S$mean, sg$T$mean),
                       lower = c(sg$S$ci[1, ], sg$T$ci[1, ]), upper = c(sg$S$ci[2, ], sg$T$ci[2, ]),
                       cpu_fit = NA_real_, cpu_sens = t_peer, cpu_default = NA_real_,
                       peer = "sobolGP",
                       stringsAsFactors = FALSE)
    row <- rbind(row, peer)
  }
  row
}

res <- if (file.exists(opt$out)) readRDS(opt$out) else NULL
done <- function(p, m, seed) {
  !is.null(res) && any(res$problem == p & res$m == m & res$seed == seed)
}
# designs in rounds (seed 1 of every problem and m, then seed 2, ...), so an
# interrupted study has a balanced count
for (seed in seq_len(max(opt$designs))) {
  for (pname in opt$problems) {
    for (i in seq_along(opt$m)) {
      if (seed > opt$designs[i] || done(pname, opt$m[i], seed)) next
      r <- one_design(pname, opt$m[i], seed)
      res <- rbind(res, r)
      saveRDS(res, opt$out)
      cat(sprintf("%s m = %d design %d: fit %.1f s, sensitivity() %.1f s, peer %.1f s, covered %d/%d\n",
                  pname, opt$m[i], seed, r$cpu_fit[1], r$cpu_sens[1],
                  sum(r$cpu_sens[r$peer == "sobolGP"][1], na.rm = TRUE),
                  sum(r$lower <= r$truth & r$truth <= r$upper & r$peer == "FBC"),
                  sum(r$peer == "FBC")))
    }
  }
}

res <- res[res$problem %in% opt$problems & res$m %in% opt$m, ]
covered <- res$lower <= res$truth & res$truth <= res$upper
res$covered <- covered
res$width <- res$upper - res$lower
res$err <- abs(res$median - res$truth)
summ <- do.call(rbind, lapply(split(res, list(res$peer, res$problem, res$m), drop = TRUE), function(d) {
  per <- function(ix, what) mean(d[[what]][d$index == ix])
  bse <- function(x) sqrt(mean(x) * (1 - mean(x)) / length(x))
  sens <- tapply(d$cpu_sens, d$seed, `[`, 1)
  fitc <- tapply(d$cpu_fit, d$seed, `[`, 1)
  data.frame(method = d$peer[1], problem = d$problem[1], m = d$m[1],
             designs = length(unique(d$seed)),
             cover_S = per("first", "covered"),
             cover_S_nz = mean(d$covered[d$index == "first" & d$truth > 0]),
             se_S_nz = bse(d$covered[d$index == "first" & d$truth > 0]),
             cover_ST = per("total", "covered"),
             se_ST = bse(d$covered[d$index == "total"]),
             width_S = per("first", "width"), width_ST = per("total", "width"),
             max_err = mean(tapply(d$err, d$seed, max)),
             cpu_fit = if (all(is.na(fitc))) NA_character_ else
               sprintf("%.1f [%.1f, %.1f]", stats::median(fitc), min(fitc), max(fitc)),
             cpu_sens = sprintf("%.2f [%.2f, %.2f]", stats::median(sens), min(sens), max(sens)),
             stringsAsFactors = FALSE)
}))
summ <- summ[order(summ$problem, summ$method, summ$m), ]
rownames(summ) <- NULL
cat("\nCoverage of the true indices by the 90% intervals, over designs and inputs;\n",
    "widths: mean 90% interval width; max_err: mean over designs of the largest\n",
    "|median - truth|; CPU s: median [range] over designs.\n", sep = "")
print(format(summ, digits = 3), row.names = FALSE)
cat("\nCPU s of sensitivity(fit) with its defaults (with the prediction's part),\n",
    "first design of each m:\n", sep = "")
dflt <- res[res$peer == "FBC" & !is.na(res$cpu_default), ]
print(unique(dflt[c("problem", "m", "cpu_default")]), row.names = FALSE, digits = 3)
# per input: coverage of each index (FBC)
cat("\nCoverage per input (FBC):\n")
fb <- res[res$peer == "FBC", ]
per_in <- stats::aggregate(covered ~ problem + m + index + input, fb, mean)
print(stats::reshape(per_in, idvar = c("problem", "m", "index"), timevar = "input",
                     direction = "wide"), row.names = FALSE, digits = 2)
if (!have_sobolgp) {
  cat("\nsensitivity::sobolGP: not run (the sensitivity and DiceKriging packages are not installed).\n")
}
