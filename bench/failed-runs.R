# Failed simulator runs.
#  1. Spot welding from the raw sw_sim.txt as shipped (17 of 52 runs with an
#     NA response) against the hand-cleaned 35 runs, default calibrate():
#     tau's quantiles, CPU seconds, the messages given.
#  2. A known failure region: the sinusoid eta(x, u) = sin(10 u x) whose
#     runs fail inside a disc of the (x, u) box that holds part of the runs
#     most informative about u (around the true u = pi / 5 and large x).
#     design_loop() from 10 runs, one run a step, with and without the
#     failure model's weighting of propose_runs()' gains: the share of the
#     picks that fail, and u's 90% width at the end.
#     --oracle=TRUE adds the weighting by the true failure indicator (the
#     bound of what a failure model can give); --spotweld=FALSE skips part 1.
#     Each step's fit's Hellinger distance to u's posterior with eta known
#     gives the runs each loop needs to reach 0.1 (censored at the budget).
# Rscript bench/run.R failed-runs [--quick] [--reps=10] [--budget=12] [--oracle=FALSE]
#   [--spotweld=TRUE]
source("bench/options.R")
opt <- bench_options(list(reps = 10L, budget = 12L, seeds = 1L, oracle = FALSE, spotweld = TRUE))
if (opt$quick) { opt$reps <- 2L; opt$budget <- 4L }
suppressPackageStartupMessages(library(FBC))

# ---- 1. spot weld
s <- utils::read.table("data-raw/spotweld/sw_sim.txt", header = TRUE)
f <- utils::read.table("data-raw/spotweld/sw_field.txt", header = TRUE)
sim <- data.frame(diameter = s$NuggetDiam, gauge = s$Gauge, load = s$Load, current = s$Current,
                  tau = s$t)
field <- data.frame(diameter = f$Field, gauge = f$Gauge, load = f$Load, current = f$Current)
run_sw <- function(data) {
  msgs <- character()
  set.seed(opt$seeds)
  t <- cpu(fit <- withCallingHandlers(
    calibrate(data, field, showProgress = FALSE,
              converge = if (opt$quick) until_converged(maxMCMC = 2000)),
    message = function(m) {
      msgs <<- c(msgs, conditionMessage(m))
      invokeRestart("muffleMessage")
    }))
  q <- stats::quantile(fit$Phi[, 1], c(0.05, 0.5, 0.95))
  data.frame(m = fit$model$dims$m, q05 = q[1], q50 = q[2], q95 = q[3],
             cpu = t, messages = length(msgs))
}
if (opt$spotweld) {
  cat("\n1. Spot weld, default calibrate(), seed", opt$seeds, "\n\n")
  tab <- rbind(cbind(data = "raw sw_sim.txt (17 NA rows)", run_sw(sim)),
               cbind(data = "hand-cleaned (35 runs)", run_sw(sim[!is.na(sim$diameter), ])))
  rownames(tab) <- NULL
  print(knitr::kable(tab, digits = 3))
}

# ---- 2. a known failure region
inside <- function(x, u) (x - 0.75)^2 + (u - 0.55)^2 < 0.2^2
f_sin <- function(x, kappa) {
  if (inside(x$x, kappa[["u"]])) stop("the solver diverged")
  sin(10 * kappa[["u"]] * x$x)
}
# The probability of success that weighs propose_runs()' gains: the failure
# model's ("model"), none ("none": every gain as it is), or the oracle's,
# the true indicator of the disc's complement ("oracle": what any failure
# model could at best give, the bound of the weighting itself).
oracle_success <- function(model, U, K = 1L) {
  sc <- model$scale
  X <- FBC:::unscale_inputs(U[seq(1L, nrow(U), by = K), , drop = FALSE], sc, seq_len(sc$p + sc$q))
  as.numeric(!inside(X[, 1], X[, 2]))
}
# u's posterior with eta known (no emulator), the field noise sd s unknown
# (half-Cauchy, scale the runs' sd, as calibrate()'s prior) and u's prior
# calibrate()'s Beta(1.1, 1.1) on [0, 1]: by quadrature over (u, s). The
# Hellinger distance of a loop's last fit to it says how well its runs
# pinned u down.
ref_posterior <- function(fld, ysd) {
  u <- seq(0, 1, length.out = 1001)
  s <- exp(seq(log(0.01), log(2), length.out = 300))
  ls <- outer(u, s, Vectorize(function(uu, sd) sum(stats::dnorm(fld$y, sin(10 * uu * fld$x), sd, log = TRUE)))) +
    rep(stats::dcauchy(s, 0, ysd, log = TRUE) + log(s), each = length(u))
  ls <- ls + stats::dbeta(u, 1.1, 1.1, log = TRUE)
  w <- rowSums(exp(ls - max(ls)))
  list(u = u, dens = w / sum(w) / diff(u[1:2]))
}
hellinger <- function(draws, ref) {
  k <- stats::density(draws, from = 0, to = 1, n = length(ref$u))
  q <- k$y / sum(k$y) / diff(ref$u[1:2])
  sqrt(max(0, 1 - sum(sqrt(q * ref$dens)) * diff(ref$u[1:2])))
}
run_loop <- function(seed, mode) {
  ns <- asNamespace("FBC")
  if (mode != "model") {
    keep <- ns$run_success
    unlockBinding("run_success", ns)
    assign("run_success", if (mode == "none") function(...) numeric() else oracle_success,
           envir = ns)
    on.exit({assign("run_success", keep, envir = ns); lockBinding("run_success", ns)})
  }
  set.seed(seed)
  xf <- rep(seq(0.1, 0.9, length.out = 5), 2)
  fld <- data.frame(y = sin(10 * pi / 5 * xf) + stats::rnorm(10, 0, 0.1), x = xf)
  # each step's Hellinger distance, from the step's fit (its row of the
  # loop's history is made by loop_row(fit, runs, ...)): u's posterior with
  # eta known under the prior scale that step's runs give
  steps <- new.env()
  steps$H <- numeric()
  trace("loop_row", where = ns, print = FALSE, exit = bquote({
    .s <- .(steps)
    .y <- fit$model$data$ys * fit$model$scale$ysd[1] + fit$model$scale$ymean[1]
    .s$H <- c(.s$H, .(hellinger)(fit$Phi[, 1], .(ref_posterior)(.(fld), stats::sd(.y))))
  }))
  on.exit(untrace("loop_row", where = ns), add = TRUE)
  t <- cpu(out <- suppressWarnings(suppressMessages(
    design_loop(f_sin, fld, lower = c(x = 0, u = 0), upper = c(x = 1, u = 1), n0 = 10,
                batch = 1, budget = opt$budget, discrepancy = "none", nChains = 2))))
  picks <- out$sim[-(1:10), ]
  w <- diff(stats::quantile(out$fit$Phi[, 1], c(0.05, 0.95)))
  ref <- ref_posterior(fld, stats::sd(out$sim$y, na.rm = TRUE))
  # runs after the first 10 until H <= 0.1 (NA: not within the budget)
  hit <- which(steps$H <= 0.1)
  data.frame(seed = seed, weighting = mode, picks = nrow(picks),
             failed = sum(inside(picks$x, picks$u)), width = w,
             H = hellinger(out$fit$Phi[, 1], ref),
             to_H01 = if (length(hit)) out$history$runs[hit[1]] - 10L else NA_integer_, cpu = t)
}
cat("\n2. Runs failing inside a disc; design_loop() from 10 runs, budget", opt$budget, "\n\n")
modes <- c("model", "none", if (opt$oracle) "oracle")
res <- do.call(rbind, lapply(seq_len(opt$reps), function(r) {
  do.call(rbind, lapply(modes, function(m) run_loop(r, m)))
}))
summ <- do.call(rbind, lapply(split(res, res$weighting)[modes], function(d) {
  data.frame(weighting = d$weighting[1], replicates = nrow(d),
             failed_share = sum(d$failed) / sum(d$picks),
             failed_per_loop = paste(range(d$failed), collapse = "-"),
             u_width_median = stats::median(d$width), H_median = stats::median(d$H),
             reached_H01 = sum(!is.na(d$to_H01)),
             # loops that did not reach it count as budget + 1 (censored)
             runs_to_H01_median = stats::median(ifelse(is.na(d$to_H01), opt$budget + 1L, d$to_H01)),
             cpu_median = stats::median(d$cpu))
}))
rownames(summ) <- NULL
print(knitr::kable(summ, digits = 3))
d <- split(res, res$weighting)
for (m in setdiff(modes, "none"))
  cat(sprintf("\nPaired difference of failed picks per loop (%s - none): mean %.2f, se %.2f\n", m,
              mean(d[[m]]$failed - d[["none"]]$failed),
              stats::sd(d[[m]]$failed - d[["none"]]$failed) / sqrt(opt$reps)))
for (m in setdiff(modes, "none")) {
  cens <- function(v) ifelse(is.na(v), opt$budget + 1L, v)
  dd <- cens(d[[m]]$to_H01) - cens(d[["none"]]$to_H01)
  cat(sprintf("Paired difference of the runs to Hellinger 0.1 (%s - none; a loop that did not reach it counted as budget + 1 = %d): mean %.2f, se %.2f, median %.1f\n",
              m, opt$budget + 1L, mean(dd), stats::sd(dd) / sqrt(opt$reps), stats::median(dd)))
}
for (m in setdiff(modes, "none"))
  cat(sprintf("Paired difference of the last fit's Hellinger distance to u's posterior with eta known (%s - none): mean %.3f, se %.3f\n", m,
              mean(d[[m]]$H - d[["none"]]$H), stats::sd(d[[m]]$H - d[["none"]]$H) / sqrt(opt$reps)))
cat(sprintf("\n%s, R %s, BLAS %s, commit %s\n", format(Sys.time(), "%Y-%m-%d"),
            getRversion(), basename(La_library()),
            tryCatch(system("git rev-parse --short HEAD", intern = TRUE), error = function(e) "?")))
