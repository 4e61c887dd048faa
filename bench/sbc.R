# Simulation-based calibration (Talts et al. 2018) of FBC's sampler, larger
# run: every one of the 11 parameters of a p = 1, q = 1 Kennedy-O'Hagan
# model sampled, each under a proper prior. For each replication: draw phi
# from the prior (R's r* functions, independent of FBC's prior code), draw
# data from the model's Gaussian distribution (covariance built here in
# plain R), run FBC's sampler, record the rank of the true value among 99
# thinned posterior draws. Under a correct sampler the ranks are uniform on
# 0..99; we test with a chi-square on 10 bins per parameter.
#
# Run from the package root after installing FBC:
#   Rscript bench/run.R sbc [--L=1000] [--out=bench/RESULTS-sbc.md] > /dev/null
# It writes bench/RESULTS-sbc.md. L = 1000 (the default) takes 2-3
# minutes.

library(FBC)
source("bench/options.R")
opt <- bench_options(list(L = 1000L, out = file.path("bench", "RESULTS-sbc.md")))
L <- opt$L
out_file <- opt$out
nDraws <- 99L; thin <- 20L; nBurn <- 1000L
n <- 8L; m <- 20L; p <- 1L; q <- 1L
set.seed(20240601)

corr <- function(X, Y, theta, alpha) {
  out <- matrix(1, nrow(X), nrow(Y))
  for (k in seq_len(ncol(X))) out <- out * exp(-theta[k] * abs(outer(X[, k], Y[, k], "-"))^alpha[k])
  out
}
# phi = (kappa, thetaS[2], alphaS[2], thetaB, alphaB, sigma2S, sigma2B, sigma2E, muB)
model_cov <- function(Xf, Xs, phi, nugget = 1e-6) {
  Xk <- cbind(Xf, phi[1])
  X <- rbind(Xk, Xs)
  C <- phi[8] * corr(X, X, phi[2:3], phi[4:5])
  f <- seq_len(nrow(Xf)); s <- nrow(Xf) + seq_len(nrow(Xs))
  C[s, s] <- C[s, s] + phi[8] * nugget * diag(nrow(Xs))
  C[f, f] <- C[f, f] + phi[9] * corr(Xf, Xf, phi[6], phi[7]) + phi[10] * diag(nrow(Xf))
  C
}

priors <- list(
  kappa = list("beta", 2, 2, function() rbeta(1, 2, 2)),
  thetaS1 = list("gamma", 4, 1, function() rgamma(1, 4, 1)),
  thetaS2 = list("gamma", 4, 1, function() rgamma(1, 4, 1)),
  alphaS1 = list("betashift", 5, 2, function() 1 + rbeta(1, 5, 2)),
  alphaS2 = list("betashift", 5, 2, function() 1 + rbeta(1, 5, 2)),
  thetaB1 = list("gamma", 4, 2, function() rgamma(1, 4, 2)),
  alphaB1 = list("betashift", 5, 2, function() 1 + rbeta(1, 5, 2)),
  sigma2S = list("inversegamma", 4, 3, function() 1 / rgamma(1, 4, rate = 3)),
  sigma2B = list("inversegamma", 4, 0.3, function() 1 / rgamma(1, 4, rate = 0.3)),
  sigma2E = list("inversegamma", 4, 0.15, function() 1 / rgamma(1, 4, rate = 0.15)),
  muB = list("gaussian", 0, 0.5, function() rnorm(1, 0, 0.5))
)
hyp <- set_hyperPriors(
  thetaSDist = "gamma", thetaSInit = 4, thetaSP1 = 4, thetaSP2 = 1,
  alphaSDist = "betashift", alphaSInit = 1.7, alphaSP1 = 5, alphaSP2 = 2,
  thetaBDist = "gamma", thetaBInit = 2, thetaBP1 = 4, thetaBP2 = 2,
  alphaBDist = "betashift", alphaBInit = 1.7, alphaBP1 = 5, alphaBP2 = 2,
  sigma2SDist = "inversegamma", sigma2SInit = 1, sigma2SP1 = 4, sigma2SP2 = 3,
  sigma2BDist = "inversegamma", sigma2BInit = 0.1, sigma2BP1 = 4, sigma2BP2 = 0.3,
  sigma2EDist = "inversegamma", sigma2EInit = 0.05, sigma2EP1 = 4, sigma2EP2 = 0.15,
  muBDist = "gaussian", muBInit = 0, muBP1 = 0, muBP2 = 0.5
)
# The data are given on FBC's scaled space directly (inputs in [0, 1], no
# response standardisation), so the sampler is run through FBC's internals
# rather than calibrate(), which would rescale the data.
scale <- list(xmin = c(0, 0), xmax = c(1, 1), ymean = 0, ysd = 1, p = p, q = q,
              names = list(response = "y", inputs = "x", calibration = "t"))
kappaSpec <- FBC:::check_class_spec(list(dist = "beta", init = NA, p1 = 2, p2 = 2), "kappa", q)
spec <- FBC:::build_priors(kappaSpec, hyp, scale, p, q)
spec$model <- FBC:::compiled_model(p, q)
stopifnot(identical(spec$vars, c("kappa1", names(priors)[-1])))

Xf <- matrix(seq(0.05, 0.95, length.out = n), n, 1)
Xs <- vapply(1:2, function(j) (sample(m) - runif(m)) / m, numeric(m))
nMCMC <- nBurn + nDraws * thin

t0 <- proc.time()[["elapsed"]]
fails <- 0L
ranks <- suppressWarnings(t(vapply(seq_len(L), function(l) {
  for (try in 1:100) {
    truth <- vapply(priors, function(pr) pr[[4]](), numeric(1))
    C <- model_cov(Xf, Xs, truth)
    R <- tryCatch(chol(C), error = function(e) NULL)
    if (!is.null(R)) break
  }
  stopifnot(!is.null(R))
  y <- drop(crossprod(R, rnorm(n + m))) + c(rep(truth[11], n), rep(0, m))
  dat <- list(Xf = Xf, yf = y[seq_len(n)], Xs = Xs, ys = y[n + seq_len(m)])
  res <- FBC:::sample_chain(dat, spec, FBC:::initial_state(spec$init, spec),
                            FBC:::sampler_moves("blocks", spec), nMCMC, nBurn, thin,
                            showProgress = FALSE)
  colSums(res$draws < matrix(truth, nDraws, length(truth), byrow = TRUE))
}, numeric(length(priors)))))
elapsed <- proc.time()[["elapsed"]] - t0
colnames(ranks) <- spec$vars

bins <- 10L
counts <- apply(ranks, 2, function(r) tabulate(floor(r * bins / (nDraws + 1)) + 1, bins))
pv <- apply(counts, 2, function(cn) suppressWarnings(chisq.test(cn))$p.value)

lines <- c(
  "# SBC results (Rscript bench/run.R sbc)", "",
  sprintf("Generated %s with FBC %s, R %s.", format(Sys.time(), "%Y-%m-%d %H:%M"),
          utils::packageVersion("FBC"), getRversion()), "",
  sprintf(paste("Simulation-based calibration (Talts et al. 2018): %d replications of a p = 1,",
                "q = 1 KOH model with n = %d field and m = %d simulator points, all 11",
                "parameters sampled under proper priors; one chain per replication,"), L, n, m),
  sprintf("%d burn-in sweeps (adaptive), then %d draws thinned by %d. Run time %.0f s.",
          nBurn, nDraws, thin, elapsed), "",
  "Ranks of the true value among the 99 draws (0..99), counted in 10 bins",
  sprintf("(expected %.0f per bin), and the chi-square p-value of uniformity (9 df):", L / bins), "",
  paste0("| parameter | prior | ", paste(sprintf("b%d", 1:bins), collapse = " | "), " | p-value |"),
  paste0("|", paste(rep("---", bins + 3), collapse = "|"), "|")
)
for (j in seq_along(priors)) {
  pr <- priors[[j]]
  lines <- c(lines, sprintf("| %s | %s(%g, %g) | %s | %.3f |", spec$vars[j], pr[[1]], pr[[2]], pr[[3]],
                            paste(counts[, j], collapse = " | "), pv[j]))
}
lines <- c(lines, "",
  sprintf("Smallest p-value %.3f over %d parameters (Bonferroni 5%% level: %.4f): %s.",
          min(pv), length(pv), 0.05 / length(pv),
          if (min(pv) > 0.05 / length(pv)) "no evidence against uniform ranks" else "ranks NOT uniform"))
writeLines(lines, out_file)
cat(lines, sep = "\n")
