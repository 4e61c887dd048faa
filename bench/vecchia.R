# Scale benchmark of the nearest-neighbour (Vecchia) algebra.
#
#   Rscript bench/run.R vecchia --part=sweep              # ms/sweep and peak MB, m = 1000 ... 100,000
#   Rscript bench/run.R vecchia --part=converged-1000     # time to a converged posterior (also -5000,
#                                                   #   -20000)
#   Rscript bench/run.R vecchia --part=exact-1000         # the same with the exact (dense) algebra
#   Rscript bench/run.R vecchia --part=accuracy-500       # long runs of both algebras (also -1000,
#                                                   #   -2000): kappa quantiles, predictions
#   Rscript bench/run.R vecchia --part=peer               # RobustCalibration at m = 1000 (if installed)
#   ... --k=10 --nburn=4000                       # neighbours and burn-in of converged/accuracy
#   --part=sweep --sizes=1000:20,5000:10,20000:10     # the sweep part at these m:k only
# Add --quick for a smoke test. Each part runs in a fresh R process (callr),
# so its peak memory (VmHWM) is its own; CPU seconds are user + system of
# that process and its children. Run under the BLAS you want to measure
# (OpenBLAS per process: R_LD_LIBRARY_PATH=<dir of its libblas.so.3>
# OPENBLAS_NUM_THREADS=1); each row says which BLAS ran.
#
# Problems: scattered Latin hypercube designs of a smooth simulator, field
# data at a known kappa with a small bias and noise:
#   m1000:  p = q = 2, n = 60 (bench/scale.R's problem)
#   m5000, m20000, m100000: p = 2, q = 3, n = 100
# Converged: calibrate(converge = until_converged()) with 4 chains on the
# sequential plan, Matérn 5/2 for both GPs, checks every 500 sweeps after a
# first stretch of nburn + 1000 sweeps (nburn of them burn-in, default 3000):
# every R-hat < 1.01 and bulk ESS >= 400.
suppressPackageStartupMessages(library(FBC))
source("bench/options.R")
# --nburn=<sweeps>: the burn-in of the converged and accuracy parts (default
# 3000: the simulator block's joint proposal learns its shape there; with
# 1000 the m = 1000 problem needed 21,000 sweeps a chain, see RESULTS-vecchia.md)
# --k=<neighbours>: the converged and accuracy parts' neighbours (default 20)
# --sizes=<m>:<k>,...: the sweep part's problems (default 1000:20, 5000:20,
# 20000:20, 20000:30, 100000:20; e.g. --sizes=1000:20,5000:10,20000:10 for
# the sizes and neighbours the default rule picks)
opt <- bench_options(list(part = "sweep", nburn = 3000L, k = 20L,
                          sizes = c("1000:20", "5000:20", "20000:20", "20000:30", "100000:20")))
quick <- opt$quick
nBurnLong <- opt$nburn
kNeighbours <- opt$k
sweepSizes <- lapply(strsplit(opt$sizes, ":"), as.numeric)
parts <- opt$part

helpers <- function() {
  peak_mb <- function() {
    s <- readLines("/proc/self/status")
    as.numeric(gsub("[^0-9]", "", grep("^VmHWM", s, value = TRUE))) / 1024
  }
  cpu <- function() sum(proc.time()[c(1, 2, 4, 5)], na.rm = TRUE)
  blas <- function() if (grepl("openblas", extSoftVersion()[["BLAS"]], ignore.case = TRUE) ||
                         grepl("openblas", La_library(), ignore.case = TRUE)) "OpenBLAS" else "reference"
  # scattered_problem() as `problem` (the working directory is the package
  # root here and in the callr children)
  source("bench/problems.R", local = TRUE)
  problem <- scattered_problem
  fit_args <- list(kernelS = "matern52", kernelB = "matern52")
  environment()
}

# Runs `f(h, a)` (h: the helpers' environment; a: the list `a`) in a fresh
# R process with this library path and BLAS; returns its value. (callr
# drops the functions' environments: everything they use comes through `a`.)
in_child <- function(f, a) {
  callr::r(function(f, helpers, a) {
    suppressPackageStartupMessages(library(FBC))
    f(helpers(), a)
  }, args = list(f = f, helpers = helpers, a = a), libpath = .libPaths(), show = FALSE,
  env = c(callr::rcmd_safe_env(), R_LD_LIBRARY_PATH = Sys.getenv("R_LD_LIBRARY_PATH"),
          OPENBLAS_NUM_THREADS = "1"))
}

# ms per sweep after adapting, and the process's peak memory.
sweep_part <- function(m, k, nSweep) {
  in_child(function(h, a) {
    m <- a$m; k <- a$k; nSweep <- a$nSweep
    pr <- h$problem(m)
    t0 <- h$cpu()
    set.seed(2)
    fit <- suppressMessages(do.call(calibrate, c(list(pr$sim, pr$field, nMCMC = 60, nBurn = 50,
      thinning = 1, nChains = 1, algebra = "vecchia", neighbours = k), h$fit_args)))
    setup <- h$cpu() - t0 - fit$settings$time
    t1 <- h$cpu()
    up <- update(fit, nMCMC = nSweep)
    ms <- 1000 * (h$cpu() - t1) / nSweep
    data.frame(m = m, p = ncol(pr$field) - 1, q = ncol(pr$sim) - ncol(pr$field), k = k,
               ms.sweep = ms, setup.s = setup, peak.MB = h$peak_mb(), blas = h$blas())
  }, list(m = m, k = k, nSweep = nSweep))
}

converged_part <- function(m, algebra = "vecchia", k = 20, quick = FALSE, nBurn = nBurnLong) {
  in_child(function(h, a) {
    m <- a$m; algebra <- a$algebra; k <- a$k; quick <- a$quick; nBurn <- a$nBurn
    pr <- h$problem(m)
    set.seed(3)
    t0 <- h$cpu()
    rule <- until_converged(every = if (quick) 100 else 500, maxMCMC = if (quick) 400 else 40000)
    fit <- suppressMessages(do.call(calibrate, c(list(pr$sim, pr$field,
      nMCMC = if (quick) 300 else nBurn + 1000, nBurn = if (quick) 150 else nBurn, algebra = algebra,
      neighbours = k, converge = rule), h$fit_args)))
    cpu <- h$cpu() - t0
    # 1000 new points predicted at the MAP draw
    set.seed(6)
    xn <- matrix(runif(2000), 1000, dimnames = list(NULL, c("x1", "x2")))
    t1 <- h$cpu()
    invisible(predict(fit, xn, method = "MAP"))
    predCpu <- h$cpu() - t1
    q <- length(pr$truth)
    lo <- apply(fit$Phi[, 1:q, drop = FALSE], 2, quantile, 0.05)
    hi <- apply(fit$Phi[, 1:q, drop = FALSE], 2, quantile, 0.95)
    data.frame(m = m, algebra = algebra, k = if (algebra == "vecchia") k else NA,
               nBurn = if (quick) 150 else nBurn, converged = fit$settings$converge$converged, sweeps = fit$settings$nMCMC,
               cpu.s = cpu, max.rhat = max(fit$estimates$rhat, na.rm = TRUE),
               min.ess = min(fit$estimates$ess, na.rm = TRUE),
               covers = all(lo <= pr$truth & pr$truth <= hi),
               intervals = paste(sprintf("[%.3f, %.3f]", lo, hi), collapse = " "),
               predict1000.s = predCpu, peak.MB = h$peak_mb(), blas = h$blas())
  }, list(m = m, algebra = algebra, k = k, quick = quick, nBurn = nBurn))
}

# Long runs of the Vecchia and the exact algebra on one problem: kappa's
# 5/50/95% quantiles (difference in posterior sds of the exact run),
# predictive means (RMSE relative to the exact ones' sd over the points)
# and 90% interval widths (mean relative difference) at 200 new inputs.
accuracy_part <- function(m, k = 20, n = 10000, quick = FALSE, nBurn = nBurnLong) {
  in_child(function(h, a) {
    m <- a$m; k <- a$k; n <- a$n; quick <- a$quick; nBurn <- a$nBurn
    pr <- h$problem(m)
    if (quick) { n <- 600; nBurn <- 150 }
    one <- function(algebra) {
      set.seed(4)
      t0 <- h$cpu()
      fit <- suppressMessages(do.call(calibrate, c(list(pr$sim, pr$field, nMCMC = n,
        nBurn = nBurn, algebra = algebra, neighbours = k), h$fit_args)))
      list(fit = fit, cpu = h$cpu() - t0)
    }
    V <- one("vecchia"); D <- one("dense")
    q <- length(pr$truth)
    qs <- function(f) apply(f$Phi[, 1:q, drop = FALSE], 2, quantile, c(0.05, 0.5, 0.95))
    sdD <- apply(D$fit$Phi[, 1:q, drop = FALSE], 2, sd)
    dq <- max(abs(qs(V$fit) - qs(D$fit)) / rep(sdD, each = 3))
    # the Monte Carlo error of that difference (both runs' quantile MCSEs,
    # posterior::mcse_quantile), in the same sd units: the largest over the
    # quantiles, to read the difference against
    mcse <- function(f) {
      vapply(seq_len(q), function(j) {
        x <- do.call(cbind, split(f$Phi[, j], f$chain))  # iterations x chains
        vapply(c(0.05, 0.5, 0.95), function(pr) posterior::mcse_quantile(x, probs = pr), numeric(1))
      }, numeric(3))
    }
    dqMcse <- max(sqrt(mcse(V$fit)^2 + mcse(D$fit)^2) / rep(sdD, each = 3))
    set.seed(5)
    xn <- matrix(runif(400), 200)
    colnames(xn) <- c("x1", "x2")
    pv <- predict(V$fit, xn, level = 0.9, ndraws = 300)
    pd <- predict(D$fit, xn, level = 0.9, ndraws = 300)
    data.frame(m = m, k = k, sweeps = n, kappa.quantile.err.sd = dq, its.mcse.sd = dqMcse,
               pred.rmse.rel = sqrt(mean((pv$pred - pd$pred)^2)) / sd(pd$pred),
               width.rel = mean(abs((pv$upper - pv$lower) / (pd$upper - pd$lower) - 1)),
               cpu.vecchia = V$cpu, cpu.dense = D$cpu,
               rhat.vecchia = max(V$fit$estimates$rhat, na.rm = TRUE),
               rhat.dense = max(D$fit$estimates$rhat, na.rm = TRUE), blas = h$blas())
  }, list(m = m, k = k, n = n, quick = quick, nBurn = nBurn))
}

# RobustCalibration (plug-in: the emulator's hyperparameters estimated once,
# its predictive mean plugged in) on the m = 1000 problem, S-GaSP
# discrepancy, its default 10000 sweeps.
peer_part <- function(quick = FALSE) {
  if (!requireNamespace("RobustCalibration", quietly = TRUE)) return(NULL)
  in_child(function(h, a) {
    quick <- a$quick
    pr <- h$problem(1000)
    t0 <- h$cpu()
    fit <- RobustCalibration::rcalibration(
      design = as.matrix(pr$field[, c("x1", "x2")]), observations = pr$field$y, p_theta = 2,
      simul_type = 0, input_simul = as.matrix(pr$sim[, -1]), output_simul = pr$sim$y,
      theta_range = matrix(c(0, 0, 1, 1), 2), S = if (quick) 500 else 10000,
      S_0 = if (quick) 100 else 2000, discrepancy_type = "S-GaSP")
    cpu <- h$cpu() - t0
    th <- fit@post_sample[, 1:2]
    data.frame(m = 1000, method = "RobustCalibration S-GaSP (plug-in)", cpu.s = cpu,
               intervals = paste(sprintf("[%.3f, %.3f]", apply(th, 2, quantile, 0.05),
                                         apply(th, 2, quantile, 0.95)), collapse = " "),
               peak.MB = h$peak_mb(), blas = h$blas())
  }, list(quick = quick))
}

for (part in parts) {
  cat("\n==", part, "==\n")
  res <- switch(sub("-[0-9]+$", "", part),
    sweep = do.call(rbind, lapply(
      if (quick) list(c(1000, 20)) else sweepSizes,
      function(a) sweep_part(a[1], a[2], if (quick) 20 else if (a[1] >= 1e5) 20 else 100))),
    converged = converged_part(as.integer(sub("^.*-", "", part)), k = kNeighbours, quick = quick),
    exact = converged_part(as.integer(sub("^.*-", "", part)), "dense", quick = quick),
    accuracy = accuracy_part(as.integer(sub("^.*-", "", part)), k = kNeighbours, quick = quick),
    peer = peer_part(quick),
    stop("unknown part ", part))
  print(res, digits = 4, row.names = FALSE)
}
