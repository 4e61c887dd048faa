# Calibration inputs that trade off: kappa's joint walk (an adapted
# covariance, beside each kappa's walk and jump) against the schedule
# without it (each kappa walking and jumping alone), in the same process.
#
#   Rscript bench/kappa.R [--quick]
#
# Problems (field data simulated with set.seed(1); kappa uniform priors):
#   ridge-f     a simulator function in which only kappa1 + kappa2 matters:
#               f(x, kappa) = (kappa1 + kappa2) sin(2 pi x) + x, 20 field
#               points on [0, 1], truth kappa1 + kappa2 = 0.9, noise sd 0.05,
#               kappa in [0, 1]^2, the default discrepancy (GP)
#   ridge-e     the same reality through an emulator: m = 60 maximin-ish
#               runs of f on [0, 1]^3 (x, kappa1, kappa2)
#   five-f      five correlated kappas: f(x, kappa) = sum_k kappa_k b_k(x),
#               b_k Gaussian bumps of width 0.35 at 0, 0.25, ..., 1,
#               25 field points, truth all 0.5, noise sd 0.02, kappa in
#               [0, 1]^5, discrepancy = "none"
# Each problem with the default arguments (4 chains, warm-up until settled,
# run until every R-hat < 1.01 and bulk ESS >= 400, at most 50,000 sweeps)
# and seeds 1, 2; "without" is the same call with the schedule before the
# joint walk (kappa's walks 3 times a sweep and its jumps, no joint block).
# Columns: CPU s (user + sys of this process), sweeps a chain (warm-up
# included), whether the stop rule was met, the largest R-hat and smallest
# bulk ESS over kappa, min ESS over kappa per CPU s, and its ratio to
# "without" (same seed). --quick: seed 1, at most 20,000 sweeps a chain.
library(FBC)
quick <- "--quick" %in% commandArgs(trailingOnly = TRUE)
cpu <- function() sum(proc.time()[c("user.self", "sys.self")])
maxMCMC <- if (quick) 20000 else 50000
seeds <- if (quick) 1L else 1:2

ridge_f <- function(x, kappa) (kappa[[1]] + kappa[[2]]) * sin(2 * pi * x$x) + x$x
bumps <- function(x) sapply(seq(0, 1, 0.25), function(c) exp(-(x - c)^2 / (2 * 0.35^2)))
five_f <- function(x, kappa) drop(bumps(x$x) %*% kappa)

problems <- list(
  `ridge-f` = local({
    set.seed(1)
    x <- seq(0, 1, length.out = 20)
    field <- data.frame(y = 0.9 * sin(2 * pi * x) + x + stats::rnorm(20, 0, 0.05), x = x)
    list(sim = ridge_f, field = field, lower = c(0, 0), upper = c(1, 1), disc = "gp")
  }),
  `ridge-e` = local({
    set.seed(1)
    x <- seq(0, 1, length.out = 20)
    field <- data.frame(y = 0.9 * sin(2 * pi * x) + x + stats::rnorm(20, 0, 0.05), x = x)
    m <- 60
    X <- cbind(x = (sample(m) - stats::runif(m)) / m, k1 = (sample(m) - stats::runif(m)) / m,
               k2 = (sample(m) - stats::runif(m)) / m)
    sim <- data.frame(y = (X[, 2] + X[, 3]) * sin(2 * pi * X[, 1]) + X[, 1], X)
    list(sim = sim, field = field, lower = c(0, 0), upper = c(1, 1), disc = "gp")
  }),
  `five-f` = local({
    set.seed(1)
    x <- seq(0, 1, length.out = 25)
    field <- data.frame(y = drop(bumps(x) %*% rep(0.5, 5)) + stats::rnorm(25, 0, 0.02), x = x)
    list(sim = five_f, field = field, lower = rep(0, 5), upper = rep(1, 5), disc = "none")
  })
)

# the schedule without kappa's joint walk: kappa's walks three times a sweep
without_joint <- function(moves) {
  ov <- moves$overlay
  if (!length(ov)) return(moves)
  moves$blocks <- moves$blocks[-ov]
  moves$repeats <- moves$repeats[-ov]
  moves$repeats[names(moves$blocks) %in% moves$params & lengths(moves$blocks) == 1L] <- 3L
  moves$overlay <- integer()
  moves
}

run_one <- function(pr, seed, joint) {
  set.seed(seed)
  model <- calibrate(pr$sim, pr$field, kappaDist = "uniform", kappaP1 = pr$lower,
                     kappaP2 = pr$upper, discrepancy = pr$disc, fit = FALSE)
  if (!joint) model$moves <- without_joint(model$moves)
  t0 <- cpu()
  fit <- FBC:::fit_model(model, FBC:::check_run(NULL, NULL, 2, 4,
                                                until_converged(maxMCMC = maxMCMC),
                                                FALSE, NULL, 60))
  secs <- cpu() - t0
  est <- fit$estimates
  k <- grep("^kappa", rownames(est))
  data.frame(cpu = secs, sweeps = fit$settings$nMCMC,
             converged = isTRUE(fit$settings$converge$converged),
             rhat = max(est$rhat[k]), ess = min(est$ess[k]), essPerSec = min(est$ess[k]) / secs)
}

rows <- list()
for (name in names(problems)) {
  for (seed in seeds) {
    a <- run_one(problems[[name]], seed, TRUE)
    b <- run_one(problems[[name]], seed, FALSE)
    rows[[length(rows) + 1]] <- rbind(cbind(problem = name, seed = seed, schedule = "joint", a,
                                            ratio = a$essPerSec / b$essPerSec),
                                      cbind(problem = name, seed = seed, schedule = "without", b,
                                            ratio = 1))
    print(rows[[length(rows)]], digits = 3, row.names = FALSE)
  }
}
cat("\n")
print(do.call(rbind, rows), digits = 3, row.names = FALSE)
