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
# Rscript bench/run.R failed-runs [--quick] [--reps=10] [--budget=12]
source("bench/options.R")
opt <- bench_options(list(reps = 10L, budget = 12L, seeds = 1L))
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
cat("\n1. Spot weld, default calibrate(), seed", opt$seeds, "\n\n")
tab <- rbind(cbind(data = "raw sw_sim.txt (17 NA rows)", run_sw(sim)),
             cbind(data = "hand-cleaned (35 runs)", run_sw(sim[!is.na(sim$diameter), ])))
rownames(tab) <- NULL
print(knitr::kable(tab, digits = 3))

# ---- 2. a known failure region
inside <- function(x, u) (x - 0.75)^2 + (u - 0.55)^2 < 0.2^2
f_sin <- function(x, kappa) {
  if (inside(x$x, kappa[["u"]])) stop("the solver diverged")
  sin(10 * kappa[["u"]] * x$x)
}
run_loop <- function(seed, weighted) {
  ns <- asNamespace("FBC")
  if (!weighted) {
    keep <- ns$run_success
    unlockBinding("run_success", ns)
    assign("run_success", function(...) numeric(), envir = ns)
    on.exit({assign("run_success", keep, envir = ns); lockBinding("run_success", ns)})
  }
  set.seed(seed)
  xf <- rep(seq(0.1, 0.9, length.out = 5), 2)
  fld <- data.frame(y = sin(10 * pi / 5 * xf) + stats::rnorm(10, 0, 0.1), x = xf)
  t <- cpu(out <- suppressWarnings(suppressMessages(
    design_loop(f_sin, fld, lower = c(x = 0, u = 0), upper = c(x = 1, u = 1), n0 = 10,
                batch = 1, budget = opt$budget, discrepancy = "none", nChains = 2))))
  picks <- out$sim[-(1:10), ]
  w <- diff(stats::quantile(out$fit$Phi[, 1], c(0.05, 0.95)))
  data.frame(seed = seed, weighted = weighted, picks = nrow(picks),
             failed = sum(inside(picks$x, picks$u)), width = w, cpu = t)
}
cat("\n2. Runs failing inside a disc; design_loop() from 10 runs, budget", opt$budget, "\n\n")
res <- do.call(rbind, lapply(seq_len(opt$reps), function(r) {
  rbind(run_loop(r, TRUE), run_loop(r, FALSE))
}))
summ <- do.call(rbind, lapply(split(res, res$weighted), function(d) {
  data.frame(failure_model = d$weighted[1], replicates = nrow(d),
             failed_share = sum(d$failed) / sum(d$picks),
             failed_per_loop = paste(range(d$failed), collapse = "-"),
             u_width_median = stats::median(d$width), cpu_median = stats::median(d$cpu))
}))
rownames(summ) <- NULL
print(knitr::kable(summ[order(!summ$failure_model), ], digits = 3))
d <- split(res, res$weighted)
cat(sprintf("\nPaired difference of failed picks per loop (with - without): mean %.2f, se %.2f\n",
            mean(d[["TRUE"]]$failed - d[["FALSE"]]$failed),
            stats::sd(d[["TRUE"]]$failed - d[["FALSE"]]$failed) / sqrt(opt$reps)))
cat(sprintf("\n%s, R %s, BLAS %s, commit %s\n", format(Sys.time(), "%Y-%m-%d"),
            getRversion(), basename(La_library()),
            tryCatch(system("git rev-parse --short HEAD", intern = TRUE), error = function(e) "?")))
