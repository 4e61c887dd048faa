# Defaults that converge: every row with the arguments a new user
# leaves alone, `calibrate(sim, field, converge = TRUE)`, 4 chains on the
# sequential plan.
#
#   Rscript bench/run.R defaults --part=precise     # precise field data (noise prior)
#   Rscript bench/run.R defaults --part=ball        # the ball drop (+ RobustCalibration)
#   Rscript bench/run.R defaults --part=m1000,m5000,m20000,functional
#   Rscript bench/run.R defaults --part=priors      # the noise-prior study behind ?set_hyperPriors
#   Rscript bench/run.R defaults --part=all         # every row but priors
#   ... --quick                                     # a smoke test (short runs)
#   ... --nopeer                                    # without RobustCalibration
#   ... --trace                                     # each convergence check's R-hat and
#                                                   # bulk ESS per parameter, the warm-ups
#   ... --calibrate=neighbours=10                   # an argument added to every
#                                                   # calibrate() call (an experiment,
#                                                   # not the default; the header says so)
#
# Each row: CPU s (user + system of this process, proc.time()), sweeps a
# chain, warm-up sweeps, max R-hat, min bulk ESS over every parameter,
# whether every 90% interval of kappa covers the truth, and
# RobustCalibration's CPU s on the same data in the same process when it is
# installed (never a dependency). Run under the BLAS you want to measure;
# the header says which ran.
#
# Problems:
#   precise     eta(x, t) = exp(-t x) + x / 2, 40 runs (maximin LHS, x in [0, 1],
#               t in [0.5, 2.5]), n = 10 or 30 field points at t = 1.5 with
#               noise sd 0.01 and no bias, discrepancy "gp" and "none"; also
#               the noise sd's 90% interval and kappa's interval width
#               against a fit with sigma2E fixed at the truth
#   ball        ballSim / ballField (m = 100, n = 63; g = 9.81)
#   m1000       scattered LHS, p = q = 2, n = 60 (bench/vecchia.R's problem)
#   m5000       scattered LHS, p = 2, q = 3, n = 100 (the same)
#   m20000      the same with m = 20,000
#   functional  decaySim / decayField, 80 x 50 product design (m = 4000)
suppressPackageStartupMessages(library(FBC))
source("bench/options.R")
# --ess, --forget, --growth: experiments on the package's own constants (not
# arguments): the warm-up's effective draws per block parameter
# (fbc_warmup$ess), the weight of each earlier epoch in a block's estimate
# (fbc_warmup$forget), the stopping checks' growth factor (fbc_check_growth).
# --calibrate=name=value[,name=value]: arguments added to every calibrate()
# call (an experiment, not the default; the header says so). --seed: the
# seed of the scattered rows' fits, for repeats. --nopeer: without
# RobustCalibration (a diagnosis run).
opt <- bench_options(list(part = c("precise", "ball"), trace = FALSE, nopeer = FALSE,
                          seed = 1L, ess = NA_real_, forget = NA_real_, growth = NA_real_,
                          calibrate = character()))
quick <- opt$quick
trace <- opt$trace
nopeer <- opt$nopeer
fitSeed <- opt$seed
internal <- character()
for (key in c("ess", "forget", "growth")) {
  v <- opt[[key]]
  if (is.na(v)) next
  internal <- c(internal, paste0(key, "=", v))
  ns <- asNamespace("FBC")
  nm <- if (key == "growth") "fbc_check_growth" else "fbc_warmup"
  val <- get(nm, ns)
  if (nm == "fbc_warmup") val[[key]] <- v else val <- v
  unlockBinding(nm, ns)
  assign(nm, val, envir = ns)
}
extra <- opt$calibrate
extraArgs <- lapply(sub("^[^=]*=", "", extra), function(v) eval(str2lang(v)))
names(extraArgs) <- sub("=.*$", "", extra)
parts <- opt$part
known <- c("precise", "ball", "m1000", "m5000", "m20000", "functional", "priors")
if ("all" %in% parts) parts <- setdiff(known, "priors")
if (length(bad <- setdiff(parts, known))) stop("unknown part(s): ", paste(bad, collapse = ", "))

`%||%` <- function(a, b) if (is.null(a)) b else a
cpu <- function() sum(proc.time()[c(1, 2, 4, 5)], na.rm = TRUE)
timed <- function(expr) {
  t0 <- cpu()
  value <- expr
  list(value = value, cpu = cpu() - t0)
}
covers <- function(x, truth) {
  ci <- stats::quantile(x, c(0.05, 0.95), names = FALSE)
  ci[1] <= truth && truth <= ci[2]
}
# the default run: converge = TRUE and nothing else (quick: a short fixed run)
default_fit <- function(sim, field, ...) {
  if (quick) return(do.call(calibrate, c(list(sim, field, nMCMC = 600, nBurn = 200, ...), extraArgs)))
  do.call(calibrate, c(list(sim, field, converge = TRUE, ...), extraArgs))
}
# trace: each check of the rule prints the sweeps, every chain's warm-up and
# each parameter's R-hat and bulk ESS (the lagging ones first)
if (trace) {
  ns <- asNamespace("FBC")
  rule_met0 <- get("rule_met", ns)
  traced <- function(results, rule, cols) {
    out <- rule_met0(results, rule, cols)
    draws <- lapply(results, function(r) r$draws[seq_len(r$kept), cols, drop = FALSE])
    chain <- rep(seq_along(draws), vapply(draws, nrow, integer(1)))
    est <- FBC:::chain_diagnostics(do.call(rbind, draws), chain)
    warm <- vapply(results, function(r) as.numeric(r$state$warmup %||% NA), numeric(1))
    cat(sprintf("check at %s sweeps (warm-up %s; kept %s a chain), cpu %.1f s: max R-hat %.4f, min ESS %.0f\n",
                paste(unique(vapply(results, function(r) r$state$iter, numeric(1))), collapse = "/"),
                paste(warm, collapse = "/"), paste(unique(vapply(draws, nrow, integer(1))), collapse = "/"),
                cpu(), out$rhat, out$ess))
    tab <- data.frame(param = colnames(results[[1]]$draws)[cols] %||% cols,
                      rhat = round(est$rhat, 4), ess = round(est$ess))
    tab <- tab[order(-tab$rhat), ]
    print(utils::head(tab[!is.na(tab$rhat), ], 8), row.names = FALSE)
    out
  }
  unlockBinding("rule_met", ns)
  assign("rule_met", traced, envir = ns)
}
# one row of the table from a fit
row_of <- function(problem, fit, cpu, truth, peer = NA_real_) {
  s <- fit$settings
  est <- fit$estimates
  kap <- grep("^kappa", colnames(fit$Phi))
  data.frame(problem = problem, cpu.s = round(cpu, 1),
             sweeps = s$converge$sweeps %||% s$nMCMC,
             # each chain's warm-up, as a range (one row per problem)
             warmup = paste(unique(range(s$warmup %||% s$nBurn)), collapse = "-"),
             max.rhat = round(max(est$rhat, na.rm = TRUE), 3),
             min.ess = round(min(est$ess, na.rm = TRUE)),
             covers = all(mapply(function(j, t) covers(fit$Phi[, j], t), kap, truth)),
             algebra = fit$model$algebra$name,
             robustcal.s = round(peer, 1))
}
# ---------------------------------------------------------------- problems --
precise_problem <- function(n, seed = 1) {
  set.seed(seed)
  eta <- function(x, t) exp(-t * x) + 0.5 * x
  D <- lhs::maximinLHS(40, 2)
  sim <- data.frame(y = eta(D[, 1], 0.5 + 2 * D[, 2]), x = D[, 1], t = 0.5 + 2 * D[, 2])
  xf <- (seq_len(n) - 0.5) / n
  e <- stats::rnorm(n, 0, 0.01)
  # realized: the root mean square of the noise drawn (the data's own noise level)
  list(sim = sim, field = data.frame(y = eta(xf, 1.5) + e, x = xf),
       truth = 1.5, noise = 0.01, realized = sqrt(mean(e^2)))
}
# scattered_problem(): the problems shared with bench/vecchia.R
source("bench/problems.R")

# RobustCalibration's default run (S-GaSP, its 10,000 sweeps), CPU s
peer_cpu <- function(sim, field, p) {
  if (nopeer || !requireNamespace("RobustCalibration", quietly = TRUE)) return(NA_real_)
  sim <- as.matrix(sim)
  field <- as.matrix(field)
  q <- ncol(sim) - 1L - p
  rng <- apply(sim[, -seq_len(p + 1L), drop = FALSE], 2, range)
  timed(RobustCalibration::rcalibration(
    design = field[, -1, drop = FALSE], observations = field[, 1], p_theta = q,
    simul_type = 0, input_simul = sim[, -1, drop = FALSE], output_simul = sim[, 1],
    theta_range = t(rng), discrepancy_type = "S-GaSP",
    S = if (quick) 500 else 10000, S_0 = if (quick) 100 else 2000))$cpu
}

# ------------------------------------------------------------------- parts --
precise_part <- function() {
  rows <- list()
  for (n in c(10, 30)) for (disc in c("gp", "none")) {
    pr <- precise_problem(n)
    r <- timed(default_fit(pr$sim, pr$field, discrepancy = disc))
    fit <- r$value
    ysd <- stats::sd(pr$sim$y)
    sdE <- sqrt(fit$Phi[, "sigma2E"]) * ysd
    known <- default_fit(pr$sim, pr$field, discrepancy = disc,
                         hypers = set_hyperPriors(sigma2EDist = "fixed",
                                                  sigma2EInit = (pr$noise / ysd)^2))
    width <- function(f) diff(stats::quantile(f$Phi[, "kappa1"], c(0.05, 0.95), names = FALSE))
    ci <- stats::quantile(sdE, c(0.05, 0.5, 0.95), names = FALSE)
    rows[[length(rows) + 1L]] <- cbind(
      row_of(sprintf("precise n=%d %s", n, disc), fit, r$cpu, pr$truth),
      noise.sd = sprintf("%.4f [%.4f, %.4f]", ci[2], ci[1], ci[3]),
      noise.covers = ci[1] <= pr$noise && pr$noise <= ci[3],
      realized = round(pr$realized, 4),
      kappa.width.ratio = round(width(fit) / width(known), 2))
  }
  do.call(rbind, rows)
}

ball_part <- function() {
  set.seed(1)
  r <- timed(default_fit(ballSim, ballField))
  row_of("ball", r$value, r$cpu, 9.81, peer = peer_cpu(ballSim, ballField, 1))
}

scattered_part <- function(m) {
  pr <- scattered_problem(m)
  set.seed(fitSeed)
  r <- timed(default_fit(pr$sim, pr$field))
  # FBC's row first, in case the peer's run fails or is stopped
  print(row_of(sprintf("m%d scattered", m), r$value, r$cpu, pr$truth), row.names = FALSE)
  row_of(sprintf("m%d scattered", m), r$value, r$cpu, pr$truth,
         peer = if (m <= 1000) peer_cpu(pr$sim, pr$field, 2) else NA_real_)
}

functional_part <- function() {
  set.seed(1)
  r <- timed(default_fit(decaySim, decayField))
  row_of("functional 80 x 50", r$value, r$cpu, c(2, 0.7))
}

# The noise-prior study: each candidate prior for sigma2E (and one for
# sigma2B too) on the precise problem, n = 10 and 30, "gp" and "none", 3
# data sets; 4 chains of 6000 sweeps (2000 warm-up). Columns: the noise sd's
# posterior median and whether its 90% interval covers 0.01, the root mean
# square of the noise drawn (`realized`: with n = 30 a draw of 0.0125, as
# seed 1 gives, is a 3% tail event an honest interval may miss 0.01 on), kappa's 90%
# interval width over that with sigma2E fixed at the truth, and whether
# kappa's interval covers 1.5.
priors_part <- function(seeds = 1:3) {
  cands <- list(
    `inversegamma(1.5, 1.5) (vignette)` = list(sigma2EDist = "inversegamma", sigma2EP1 = 1.5, sigma2EP2 = 1.5),
    `halft_sd(1, 1) (half-Cauchy, default)` = list(),
    `halft_sd(1, 0.5)` = list(sigma2EDist = "halft_sd", sigma2EP1 = 1, sigma2EP2 = 0.5),
    `halft_sd(1, 1), sigma2B halft_sd(1, 1)` = list(sigma2BDist = "halft_sd", sigma2BP1 = 1, sigma2BP2 = 1))
  rows <- list()
  for (n in c(10, 30)) for (disc in c("gp", "none")) for (seed in seeds) {
    pr <- precise_problem(n, seed)
    ysd <- stats::sd(pr$sim$y)
    run <- function(h) {
      set.seed(seed)
      suppressWarnings(calibrate(pr$sim, pr$field, discrepancy = disc, hypers = do.call(set_hyperPriors, h),
                                 nMCMC = if (quick) 1000 else 6000, nBurn = if (quick) 300 else 2000))
    }
    width <- function(f) diff(stats::quantile(f$Phi[, "kappa1"], c(0.05, 0.95), names = FALSE))
    ref <- width(run(list(sigma2EDist = "fixed", sigma2EInit = (pr$noise / ysd)^2)))
    for (nm in names(cands)) {
      if (disc == "none" && grepl("sigma2B", nm)) next
      fit <- run(cands[[nm]])
      sdE <- sqrt(fit$Phi[, "sigma2E"]) * ysd
      ci <- stats::quantile(sdE, c(0.05, 0.5, 0.95), names = FALSE)
      rows[[length(rows) + 1L]] <- data.frame(
        n = n, discrepancy = disc, seed = seed, prior = nm, noise.sd.median = round(ci[2], 4),
        noise.covers = ci[1] <= pr$noise && pr$noise <= ci[3],
        realized = round(pr$realized, 4),
        kappa.width.ratio = round(width(fit) / ref, 2),
        kappa.covers = covers(fit$Phi[, "kappa1"], pr$truth),
        max.rhat = round(max(fit$estimates$rhat, na.rm = TRUE), 3))
    }
  }
  do.call(rbind, rows)
}

cat(sprintf("FBC %s defaults benchmark, %s; %s; BLAS %s (%s); load %s\n",
            utils::packageVersion("FBC"), format(Sys.time(), "%Y-%m-%d %H:%M"), R.version.string,
            basename(extSoftVersion()[["BLAS"]]), FBC:::blas_kind(),
            paste(tryCatch(readLines("/proc/loadavg")[1], error = function(e) "?"))))
if (quick) cat("(quick: short fixed runs, not the default)\n")
if (length(extraArgs) || length(internal)) {
  cat("(not the defaults: every calibrate() call adds", paste(c(extra, internal), collapse = ", "), ")\n")
}
for (part in parts) {
  cat("\n==", part, "==\n")
  res <- switch(part,
    precise = precise_part(),
    ball = ball_part(),
    m1000 = scattered_part(1000),
    m5000 = scattered_part(5000),
    m20000 = scattered_part(20000),
    functional = functional_part(),
    priors = priors_part())
  print(res, row.names = FALSE)
}
