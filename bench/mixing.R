# Mixing benchmark: time to a converged posterior, FBC's samplers
# against Stan's NUTS on the same model and priors, measured in one run.
#
# Run after installing FBC (sequential plan, one core):
#   Rscript bench/run.R mixing           # FBC samplers and, if rstan is
#                                          # installed, Stan NUTS
#   Rscript bench/run.R mixing --nostan  # FBC only (--seed=1,2,3: seeds)
# Stan's part needs rstan (Debian: apt-get install r-cran-rstan; CRAN:
# install.packages("rstan")); it is skipped when rstan is missing. rstan is
# not a dependency of FBC. Debian's r-cran-bh ships no include/ folder, so
# rstan reports "Boost not found"; link the system's Boost headers there:
#   mkdir -p /usr/lib/R/site-library/BH/include
#   ln -s /usr/include/boost /usr/lib/R/site-library/BH/include/boost
# The whole run takes about 15 minutes on an idle 2-core machine (Stan's
# four ball chains most of it).
#
# Problems: the ball data (n 63, m 100, p = q = 1) and a q = 2 decay problem
# (n 20, m 60, p = 1): y = t1 exp(-t2 x) on x in [0, 3], t1 in [1, 3],
# t2 in [0.2, 1.5], field at t = (2, 0.7) plus a smooth bias 0.1 x and noise
# sd 0.03.
#
# For each problem and sampler it prints: CPU s of the whole run (4 chains,
# warm-up/burn-in included, sequential), the worst parameter (smallest bulk
# ESS) and its ESS, min ESS per CPU s, the smallest kappa ESS per CPU s, and
# the largest R-hat (rank-normalised split R-hat, posterior package, the same
# for FBC and Stan). FBC runs calibrate()'s defaults; Stan runs 4 chains x
# (1000 warm-up + 1000 sampling), adapt_delta = 0.9, one core. Before
# timing Stan, its log density (rstan::log_prob, constants kept, no Jacobian)
# is compared with FBC's log posterior at FBC's draws.
suppressPackageStartupMessages({
  library(FBC)
  library(posterior)
})
source("bench/options.R")
opt <- bench_options(list(nostan = FALSE, seed = 2024L))
useStan <- !opt$nostan && requireNamespace("rstan", quietly = TRUE)
seeds <- opt$seed
cpu <- function() sum(proc.time()[c(1, 2, 4, 5)], na.rm = TRUE)

decay_problem <- function() {
  set.seed(7)
  m <- 60; n <- 20
  u <- vapply(1:3, function(j) (sample(m) - runif(m)) / m, numeric(m))
  x <- 3 * u[, 1]; t1 <- 1 + 2 * u[, 2]; t2 <- 0.2 + 1.3 * u[, 3]
  sim <- data.frame(y = t1 * exp(-t2 * x), x = x, t1 = t1, t2 = t2)
  xf <- seq(0, 3, length.out = n)
  field <- data.frame(y = 2 * exp(-0.7 * xf) + 0.1 * xf + rnorm(n, 0, 0.03), x = xf)
  list(sim = sim, field = field)
}
problems <- list(ball = list(sim = ballSim, field = ballField), decay = decay_problem())

summarise_fit <- function(draws, cpuSec, kappaNames) {
  s <- posterior::summarise_draws(draws, "rhat", "ess_bulk")
  w <- which.min(s$ess_bulk)
  k <- s$variable %in% kappaNames
  data.frame(cpu_s = cpuSec, worst = s$variable[w], worst_ess = s$ess_bulk[w],
             min_ess_per_s = s$ess_bulk[w] / cpuSec,
             kappa_ess_per_s = min(s$ess_bulk[k]) / cpuSec,
             max_rhat = max(s$rhat))
}

# (max_rhat is printed with 4 decimals: the goal is every R-hat < 1.01)
fbc_row <- function(pr, sampler, seed) {
  set.seed(seed)
  t0 <- cpu()
  fit <- calibrate(pr$sim, pr$field, sampler = sampler)
  cpuSec <- cpu() - t0
  list(fit = fit, row = summarise_fit(posterior::as_draws_array(posterior::as_draws(fit)), cpuSec,
                                      grep("^kappa", fit$vars, value = TRUE)))
}

stan_data <- function(fit) {
  d <- fit$model$data; sc <- fit$model$scale
  cal <- sc$p + seq_len(sc$q)
  list(n = length(d$yf), m = length(d$ys), p = sc$p, q = sc$q, Xf = d$Xf, yf = d$yf,
       Xs = d$Xs, ys = d$ys, nugget = fit$settings$nugget,
       kappaLogRange = array(log(sc$xmax[cal] - sc$xmin[cal])),
       kappaP1 = 1.1, kappaP2 = 1.1, thetaP1 = 1.1, thetaP2 = 0.1, alphaP1 = 5, alphaP2 = 2,
       sigmaP1 = 1.5, sigmaP2 = 1.5, muP1 = 0, muP2 = 1)
}

# Largest |Stan log density - FBC log posterior| over 20 of FBC's draws.
check_stan_density <- function(model, sdata, fit) {
  sf <- rstan::sampling(model, data = sdata, chains = 1, iter = 1, refresh = 0,
                        algorithm = "Fixed_param", init = "0")
  rows <- round(seq(1, nrow(fit$Phi), length.out = 20))
  sc <- fit$model$scale; q <- sc$q; cal <- sc$p + seq_len(q)
  err <- vapply(rows, function(i) {
    phi <- fit$Phi[i, ]
    u <- (phi[seq_len(q)] - sc$xmin[cal]) / (sc$xmax[cal] - sc$xmin[cal])
    ix <- fit$indices
    pars <- list(kappa = array(u), thetaS = array(phi[ix$thetaS]), alphaS = array(phi[ix$alphaS]),
                 thetaB = array(phi[ix$thetaB]), alphaB = array(phi[ix$alphaB]),
                 sigma2S = phi[[ix$sigma2S]], sigma2B = phi[[ix$sigma2B]],
                 sigma2E = phi[[ix$sigma2E]], muB = phi[[ix$muB]])
    lp <- rstan::log_prob(sf, rstan::unconstrain_pars(sf, pars), adjust_transform = FALSE)
    abs(lp - fit$logPost[i])
  }, numeric(1))
  max(err)
}

stan_row <- function(model, sdata, seed, fit) {
  t0 <- cpu()
  sf <- rstan::sampling(model, data = sdata, chains = 4, iter = 2000, warmup = 1000,
                        cores = 1, seed = seed, refresh = 0,
                        control = list(adapt_delta = 0.9))
  cpuSec <- cpu() - t0  # CPU time of this process (chains run in it, one after another)
  dr <- posterior::as_draws_array(sf)
  dr <- posterior::subset_draws(dr, variable = setdiff(posterior::variables(dr), "lp__"))
  summarise_fit(dr, cpuSec, grep("^kappa", posterior::variables(dr), value = TRUE))
}

rows <- list()
model <- NULL
if (useStan) {
  cat("Compiling the Stan model (not timed)...\n")
  stanFile <- if (file.exists("bench/koh.stan")) "bench/koh.stan" else
    system.file("bench", "koh.stan", package = "FBC")
  model <- suppressMessages(rstan::stan_model(stanFile))
}
for (pn in names(problems)) {
  pr <- problems[[pn]]
  for (seed in seeds) {
    ref <- NULL
    for (smp in c("single", "blocks")) {
      r <- fbc_row(pr, smp, seed)
      rows[[length(rows) + 1]] <- cbind(problem = pn, sampler = paste0("FBC ", smp), seed = seed, r$row)
      if (smp == "blocks") ref <- r$fit
      print(tail(rows, 1)[[1]], row.names = FALSE)
    }
    if (useStan) {
      sdata <- stan_data(ref)
      err <- check_stan_density(model, sdata, ref)
      cat(sprintf("%s: max |Stan log density - FBC log posterior| over 20 draws: %.2e\n", pn, err))
      if (err > 1e-6) stop("The Stan model's log density differs from FBC's: fix it before timing.")
      sr <- stan_row(model, sdata, seed, ref)
      rows[[length(rows) + 1]] <- cbind(problem = pn, sampler = "Stan NUTS", seed = seed, sr)
      print(tail(rows, 1)[[1]], row.names = FALSE)
    }
  }
}
tab <- do.call(rbind, rows)
cat("\nMixing table (CPU s include burn-in / warm-up; ESS = bulk ESS)\n")
shown <- tab
shown$max_rhat <- sprintf("%.4f", shown$max_rhat)
num <- vapply(shown, is.numeric, logical(1)) & names(shown) != "seed"
shown[num] <- lapply(shown[num], function(v) signif(v, 3))
print(shown, row.names = FALSE, right = TRUE)
if (useStan) {
  cat("\nRatios FBC blocks / Stan (min ESS per CPU s; kappa ESS per CPU s):\n")
  for (pn in names(problems)) for (seed in seeds) {
    a <- tab[tab$problem == pn & tab$seed == seed & tab$sampler == "FBC blocks", ]
    b <- tab[tab$problem == pn & tab$seed == seed & tab$sampler == "Stan NUTS", ]
    cat(sprintf("  %s seed %d: worst %.1fx, kappa %.1fx\n", pn, seed,
                a$min_ess_per_s / b$min_ess_per_s, a$kappa_ess_per_s / b$kappa_ess_per_s))
  }
}
cat(sprintf("\nR %s, BLAS: %s\n", getRversion(), extSoftVersion()[["BLAS"]]))
