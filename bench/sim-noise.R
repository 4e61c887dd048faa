# Stochastic simulators: replicate runs and the simulator's own noise.
#
# A simulator whose output law is known: eta(x, t) = 5 exp(-t x) on x in
# [0, 3], t in [0.5, 3], run noise sd(x) = 0.1 + 0.1 x (0.1 to 0.4); the
# field one realization at t = 1.7 (the same noise) plus measurement error
# sd 0.05 at 10 inputs. The exact posterior of t with infinitely many
# replicates (eta and the noise known) follows by quadrature on a grid of t:
# prior (calibrate()'s Beta(1.1, 1.1) over the design's range of t) times
# prod_j N(yf_j; eta(x_j, t), sd(x_j)^2 + 0.05^2).
#
# For unique inputs x replicates (a Latin hypercube of the unique inputs per
# data set), `calibrate()` with the defaults (the default discrepancy too),
# until converged:
#   auto      simNoise = "auto" (the default: "constant" when replicates differ)
#   auto-nobias  the same with discrepancy = "none" (the field model without
#             the bias GP, which the data's truth has none of)
#   bound     oracle: eta known, the field's noise one unknown variance, t by quadrature
#   exact     oracle: eta and the noise sd(x) known (the exact posterior itself)
#   constant  simNoise = "constant" (one noise variance)
#   input     simNoise = "input" (log-variance a GP over the inputs)
#   hetgp     the plug-in: hetGP's fitted mean and noise as a fixed emulator
#             (where hetGP is installed; not a dependency), t by quadrature
#   none      simNoise = "none" (the runs as if deterministic; up to
#             --maxNone runs, its cost grows with the rows)
#   mean      the cost reference: one deterministic run of the mean eta at
#             each unique input (no replicates, no noise), the defaults
# Reported per cell: Hellinger distance of t's posterior (a kernel density
# of the draws) to the exact one, beside the bound (Hbound: eta known, the
# field's noise one unknown variance as in FBC's model), the share of data
# sets whose 90% interval covers 1.7, the noise sd's error (the mean over
# the unique inputs of |posterior median sd - true sd| / true sd; the truth
# varies from 0.1 to 0.4: a constant sd is the model's average), CPU
# seconds and retained draws per chain.
#
# Coverage over many data sets: --bound=FALSE skips the bound's quadrature
# (Hbound NA), --noneSets=k runs "none" on the first k data sets only, and
# --save=file keeps every data set's row as it comes (an RDS), so a long run
# that is stopped still has its rows; a line per fit shows how far it got.
#
# Rscript bench/run.R sim-noise [--quick] [--unique=50,200] [--reps=20] [--sets=2] [--maxNone=0]
#   [--models=constant,input] [--bound=TRUE] [--noneSets=0] [--save=file] [--first=1]
# (--first: the first data set's seed, to continue a stopped run)
source("bench/options.R")
opt <- bench_options(list(unique = c(50L, 200L), reps = 20L, sets = 2L,
                          maxNone = 0L, models = c("constant", "input"), bound = TRUE,
                          noneSets = 0L, save = "", first = 1L))
if (opt$quick) { opt$unique <- 25L; opt$reps <- 5L; opt$sets <- 1L; opt$maxNone <- 0L }
suppressPackageStartupMessages(library(FBC))

eta <- function(x, t) 5 * exp(-t * x)
sdRun <- function(x) 0.1 + 0.1 * x
xf <- seq(0.15, 2.85, length.out = 10)

# One data set: a Latin hypercube of k unique inputs, r replicates each.
data_set <- function(k, r, seed) {
  set.seed(seed)
  x <- (sample(k) - stats::runif(k)) / k * 3
  t <- 0.5 + (sample(k) - stats::runif(k)) / k * 2.5
  X <- cbind(x = rep(x, r), t = rep(t, r))
  sim <- cbind(y = eta(X[, "x"], X[, "t"]) + stats::rnorm(nrow(X), 0, sdRun(X[, "x"])), X)
  field <- cbind(y = eta(xf, 1.7) + stats::rnorm(10, 0, sqrt(sdRun(xf)^2 + 0.05^2)), x = xf)
  list(sim = sim, field = field)
}

# The exact posterior of t on a grid over the design's range.
exact_posterior <- function(d) {
  lo <- min(d$sim[, "t"]); hi <- max(d$sim[, "t"])
  g <- seq(lo, hi, length.out = 2001)
  v <- sdRun(xf)^2 + 0.05^2
  lp <- vapply(g, function(t) sum(stats::dnorm(d$field[, "y"], eta(xf, t), sqrt(v), log = TRUE)),
               numeric(1)) + stats::dbeta((g - lo) / (hi - lo), 1.1, 1.1, log = TRUE)
  w <- exp(lp - max(lp))
  list(t = g, dens = w / sum(w) / diff(g[1:2]))
}

# The bound: t's posterior with eta known but the field's noise FBC's model
# of it, one unknown variance (calibrate()'s half-Cauchy prior on its sd,
# scale the runs' sd), by quadrature over (t, sd); its Hellinger distance to
# the exact posterior is what no emulator can remove.
bound_posterior <- function(d, ex) {
  s <- exp(seq(log(0.01), log(3), length.out = 400))
  ysd <- stats::sd(d$sim[, "y"])
  ls <- outer(ex$t, s, Vectorize(function(t, sd) {
    sum(stats::dnorm(d$field[, "y"], eta(xf, t), sd, log = TRUE))
  })) + rep(stats::dcauchy(s, 0, ysd, log = TRUE) + log(s), each = length(ex$t))
  lo <- min(ex$t); hi <- max(ex$t)
  ls <- ls + stats::dbeta((ex$t - lo) / (hi - lo), 1.1, 1.1, log = TRUE)
  w <- rowSums(exp(ls - max(ls)))
  w / sum(w) / diff(ex$t[1:2])
}
grid_hellinger <- function(p, q, dt) sqrt(max(0, 1 - sum(sqrt(p * q)) * dt))

hellinger <- function(draws, ex) {
  k <- stats::density(draws, from = min(ex$t), to = max(ex$t), n = length(ex$t))
  q <- k$y / sum(k$y) / diff(ex$t[1:2])
  dt <- diff(ex$t[1:2])
  sqrt(max(0, 1 - sum(sqrt(q * ex$dens)) * dt))
}

# The plug-in: hetGP's mleHetGP (Matern 5/2) fitted to the runs, its mean
# and emulator variance (sd2) at (x_j, t) a fixed emulator, the field
# N(yf_j; mean, sd2 + s^2) with s the field's noise sd (the model's
# half-Cauchy prior, scale the runs' sd) and t's prior as calibrate()'s;
# t's posterior by quadrature over (t, s).
plugin_posterior <- function(d, ex) {
  lo <- min(d$sim[, "t"]); hi <- max(d$sim[, "t"])
  het <- hetGP::mleHetGP(d$sim[, c("x", "t")], d$sim[, "y"], covtype = "Matern5_2")
  pr <- predict(het, cbind(rep(xf, length(ex$t)), rep(ex$t, each = length(xf))))
  mu <- matrix(pr$mean, length(xf)); v <- matrix(pr$sd2, length(xf))
  s <- exp(seq(log(0.01), log(3), length.out = 200))
  ysd <- stats::sd(d$sim[, "y"])
  ls <- vapply(s, function(sd) colSums(stats::dnorm(d$field[, "y"], mu, sqrt(v + sd^2), log = TRUE)),
               numeric(length(ex$t))) +
    rep(stats::dcauchy(s, 0, ysd, log = TRUE) + log(s), each = length(ex$t))
  ls <- ls + stats::dbeta((ex$t - lo) / (hi - lo), 1.1, 1.1, log = TRUE)
  w <- rowSums(exp(ls - max(ls)))
  w / sum(w) / diff(ex$t[1:2])
}

# A row of the table for the plug-in (its quantiles from the grid).
one_plugin <- function(k, r, seed) {
  d <- data_set(k, r, seed)
  ex <- exact_posterior(d)
  tm <- cpu(dens <- plugin_posterior(d, ex))
  cdf <- cumsum(dens) * diff(ex$t[1:2])
  ci <- stats::approx(cdf, ex$t, c(0.05, 0.95), ties = "ordered", rule = 2)$y
  data.frame(unique = k, reps = r, set = seed, model = "hetGP plug-in",
             H = grid_hellinger(dens, ex$dens, diff(ex$t[1:2])), Hbound = NA_real_,
             covers = ci[1] < 1.7 && 1.7 < ci[2], width90 = diff(ci), sdErr = NA_real_, cpu = tm,
             draws = NA_real_)
}

# The oracles, by quadrature on every 5th point of the exact posterior's
# grid: "bound" (eta known, the field's noise one unknown variance: FBC's
# field model) and "exact" (eta and the noise sd(x) known).
one_oracle <- function(k, r, seed, which) {
  d <- data_set(k, r, seed)
  ex <- exact_posterior(d)
  keep <- seq(1, length(ex$t), by = 5)
  ex <- list(t = ex$t[keep], dens = ex$dens[keep] / sum(ex$dens[keep]) / diff(ex$t[keep][1:2]))
  dens <- if (which == "bound") bound_posterior(d, ex) else ex$dens
  cdf <- cumsum(dens) * diff(ex$t[1:2])
  ci <- stats::approx(cdf, ex$t, c(0.05, 0.95), ties = "ordered", rule = 2)$y
  data.frame(unique = k, reps = r, set = seed, model = which,
             H = grid_hellinger(dens, ex$dens, diff(ex$t[1:2])), Hbound = NA_real_,
             covers = ci[1] < 1.7 && 1.7 < ci[2], width90 = diff(ci), sdErr = NA_real_,
             cpu = NA_real_, draws = NA_real_)
}

one <- function(k, r, seed, simNoise) {
  if (simNoise == "hetgp") return(one_plugin(k, r, seed))
  if (simNoise %in% c("bound", "exact")) return(one_oracle(k, r, seed, simNoise))
  d <- data_set(k, r, seed)
  if (simNoise == "mean") {
    d$sim <- d$sim[seq_len(k), , drop = FALSE]
    d$sim[, "y"] <- eta(d$sim[, "x"], d$sim[, "t"])
  }
  ex <- exact_posterior(d)
  set.seed(seed)
  nobias <- simNoise == "auto-nobias"
  tm <- cpu(fit <- suppressMessages(suppressWarnings(
    calibrate(d$sim, d$field, simNoise = if (nobias || simNoise == "mean") "auto" else simNoise,
              discrepancy = if (nobias) "none" else "gp", showProgress = FALSE,
              converge = if (opt$quick) until_converged(maxMCMC = 2000)))))
  tt <- fit$Phi[, fit$indices$kappa]
  ci <- stats::quantile(tt, c(0.05, 0.95), names = FALSE)
  # the noise sd at the unique inputs against the truth
  ysd <- fit$model$scale$ysd
  xu <- fit$model$scale$xmin[1] + fit$model$data$Xs[, 1] *
    (fit$model$scale$xmax[1] - fit$model$scale$xmin[1])
  sdU <- if ("sigma2R" %in% colnames(fit$Phi)) {
    rep(stats::median(sqrt(fit$Phi[, "sigma2R"])) * ysd, length(xu))
  } else if ("gR1" %in% colnames(fit$Phi)) {
    apply(exp(fit$Phi[, startsWith(colnames(fit$Phi), "gR"), drop = FALSE] / 2), 2,
          stats::median) * ysd
  }
  sdErr <- if (is.null(sdU)) NA_real_ else mean(abs(sdU - sdRun(xu)) / sdRun(xu))
  bound <- if (opt$bound) grid_hellinger(bound_posterior(d, ex), ex$dens, diff(ex$t[1:2])) else NA_real_
  data.frame(unique = k, reps = r, set = seed, model = simNoise, H = hellinger(tt, ex),
             Hbound = bound,
             covers = ci[1] < 1.7 && 1.7 < ci[2], width90 = diff(ci), sdErr = sdErr, cpu = tm,
             draws = nrow(fit$Phi) / length(unique(fit$chain)))
}

res <- list()
for (k in opt$unique) for (r in opt$reps) for (s in opt$first - 1L + seq_len(opt$sets)) {
  runs <- c(opt$models, if (k * r <= opt$maxNone && (opt$noneSets == 0L || s <= opt$noneSets)) "none")
  for (mode in runs) {
    res[[length(res) + 1L]] <- row <- one(k, r, s, mode)
    cat(sprintf("%d x %d set %d %s: t 90%% %s, %.1f CPU s\n", k, r, s, mode,
                if (row$covers) "covers" else "misses", row$cpu))
    if (nzchar(opt$save)) saveRDS(do.call(rbind, res), opt$save)
  }
}
res <- do.call(rbind, res)
cell <- do.call(rbind, lapply(split(res, list(res$model, res$reps, res$unique), drop = TRUE),
                              function(d) {
  data.frame(unique = d$unique[1], reps = d$reps[1], runs = d$unique[1] * d$reps[1],
             model = d$model[1], sets = nrow(d),
             H = sprintf("%.3f (%.3f-%.3f)", stats::median(d$H), min(d$H), max(d$H)),
             Hbound = round(stats::median(d$Hbound), 3),
             covers90 = sprintf("%d/%d", sum(d$covers), nrow(d)),
             # the binomial standard error of the share
             coverSE = round(sqrt(mean(d$covers) * (1 - mean(d$covers)) / nrow(d)), 3),
             width90 = round(stats::median(d$width90), 3),
             sdErr = round(stats::median(d$sdErr), 3),
             cpu = sprintf("%.1f (%.1f-%.1f)", stats::median(d$cpu), min(d$cpu), max(d$cpu)))
}))
cell <- cell[order(cell$unique, cell$reps, cell$model), ]
rownames(cell) <- NULL
cat("\nt's posterior against the exact one (median and range over the data sets)\n\n")
print(knitr::kable(cell))
cat("\nEvery data set:\n\n")
print(knitr::kable(res, digits = 3))
cat(sprintf("\n%s, R %s, BLAS %s, commit %s\n", format(Sys.time(), "%Y-%m-%d"),
            getRversion(), basename(La_library()),
            tryCatch(system("git rev-parse --short HEAD", intern = TRUE), error = function(e) "?")))
