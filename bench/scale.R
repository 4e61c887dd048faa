# Scale benchmark: functional output through the Kronecker
# algebra, and large unstructured designs through the dense one.
#
# Run after installing FBC, choosing the parts by argument:
#   Rscript bench/run.R scale --part=sweep        # ms/sweep of all three cases (minutes)
#   Rscript bench/run.R scale --part=functional       # the functional converged runs (defaults,
#                                               #   alphaS = 2, kernelS = "gaussian" and
#                                               #   "matern52"; or functional-alpha2,
#                                               #   functional-gaussian, functional-matern52 alone)
#   Rscript bench/run.R scale --part=kernels          # ms/sweep of every correlation family on the
#                                               #   ball data, the functional problem and m = 1000
#   Rscript bench/run.R scale --part=m1000            # converged run at m = 1000 (hours
#   Rscript bench/run.R scale --part=m2000            #   on the reference BLAS)
#   Rscript bench/run.R scale --part=m1000-gaussian   # the same with kernelS = "gaussian", as
#   Rscript bench/run.R scale --part=m2000-gaussian   #   print() advises when alphaS piles at 2
#   Rscript bench/run.R scale --part=sweep,functional,m1000,m2000   # everything
# Add --quick for a smoke test (few sweeps, short converged runs). Each part
# runs in a fresh R process (callr), so its peak memory is its own.
#
# Cases:
#   functional  decaySim/decayField: 80 runs x 50 times, m = 4000, p = 1,
#               q = 2, n = 30; y = t1 exp(-t2 x), field at (2, 0.7) + noise
#               (a product design: the Kronecker algebra); its converged
#               run is repeated with alphaS fixed at 2, as print() advises
#               when the smoothness piles up at that bound, and with the
#               smooth simulator families kernelS = "gaussian" and "matern52"
#   ball        ballSim/ballField (m = 100, n = 63; the dense algebra with
#               cached per-dimension matrices), in the kernels part only
#   m1000/m2000 p = q = 2, n = 60, m = 1000 or 2000 runs of a smooth
#               simulator at a Latin hypercube, field at (0.3, 0.7) with a
#               small bias and noise (the dense algebra)
# For each it reports:
#   ms/sweep    CPU ms of one default sweep (calibrate()'s sampler, proposals
#               adapted for `nAdapt` sweeps, then frozen), median over chunks
#   chol ms     CPU ms of R's chol() of an (n + m) x (n + m) SPD matrix,
#               measured between the chunks (same BLAS); ratio = ms/sweep / chol
#   peak MB     VmHWM of the part's fresh R process (R + FBC alone: ~70 MB)
#   converged   calibrate() with the defaults (4 chains, sequential plan), then
#               update(fit, nMCMC = 2000) until every R-hat < 1.01 and every
#               bulk ESS >= 400 (at most 40000 sweeps per chain): sweeps per chain, CPU s (all chains), the
#               first calibrate() call's CPU s, and the 90% intervals of kappa
#               against the truth
suppressPackageStartupMessages(library(FBC))
source("bench/options.R")
opt <- bench_options(list(part = "sweep"))
quick <- opt$quick
parts <- opt$part
known <- c("sweep", "kernels", "functional", "functional-alpha2", "functional-gaussian",
           "functional-matern52", "m1000", "m2000", "m1000-gaussian", "m2000-gaussian")
if (length(bad <- setdiff(parts, known))) {
  stop("unknown part(s): ", paste(bad, collapse = ", "), "; use ", paste(known, collapse = ", "))
}

# ---- helpers (also used inside the callr processes) ------------------------
helpers <- function() {
  peak_mb <- function(field = "VmHWM") {
    s <- tryCatch(readLines("/proc/self/status"), error = function(e) character())
    v <- grep(paste0("^", field), s, value = TRUE)
    if (length(v)) as.numeric(gsub("[^0-9]", "", v)) / 1024 else NA_real_
  }
  cpu <- function() sum(proc.time()[c(1, 2, 4, 5)], na.rm = TRUE)
  # median CPU ms of chol() on a k x k SPD matrix
  t_chol <- function(k, budget = 1) {
    set.seed(k)
    X <- matrix(rnorm(k * k), k)
    A <- crossprod(X) / k + diag(k)
    times <- numeric(0)
    t_end <- cpu() + budget
    repeat {
      t0 <- cpu(); chol(A)
      times <- c(times, cpu() - t0)
      if (cpu() > t_end && length(times) >= 3) break
    }
    1000 * stats::median(times)
  }
  synthetic_problem <- function(n, m, seed = 1) {
    set.seed(seed)
    eta <- function(x1, x2, t1, t2) sin(2 * pi * x1) * (1 + t1) + exp(-x2) * t2 + x1 * x2 * t1 * t2
    D <- lhs::randomLHS(m, 4)
    sim <- data.frame(y = eta(D[, 1], D[, 2], D[, 3], D[, 4]), x1 = D[, 1], x2 = D[, 2],
                      t1 = D[, 3], t2 = D[, 4])
    xf <- matrix(runif(2 * n), n)
    field <- data.frame(y = eta(xf[, 1], xf[, 2], 0.3, 0.7) + 0.1 * xf[, 1] + rnorm(n, 0, 0.05),
                        x1 = xf[, 1], x2 = xf[, 2])
    list(sim = sim, field = field, truth = c(0.3, 0.7))
  }
  # `kernel`: the correlation family of both GPs (the kernels part)
  problem <- function(name, kernel = NULL) {
    decay <- list(sim = FBC::decaySim, field = FBC::decayField, truth = c(2, 0.7))
    pr <- switch(name,
      ball = list(sim = FBC::ballSim, field = FBC::ballField, truth = 9.81),
      functional = decay,
      # as print() advises when alphaS piles up at its bound 2
      `functional-alpha2` = c(decay, list(hypers = set_hyperPriors(alphaSDist = "fixed",
                                                                   alphaSInit = 2))),
      `functional-gaussian` = c(decay, list(kernelS = "gaussian")),
      `functional-matern52` = c(decay, list(kernelS = "matern52")),
      m1000 = synthetic_problem(60, 1000),
      m2000 = synthetic_problem(60, 2000),
      # as print() advises when alphaS piles up at 2 (it does for this smooth simulator)
      `m1000-gaussian` = c(synthetic_problem(60, 1000), list(kernelS = "gaussian")),
      `m2000-gaussian` = c(synthetic_problem(60, 2000), list(kernelS = "gaussian")))
    if (!is.null(kernel)) pr$kernelS <- pr$kernelB <- kernel
    pr
  }
  fit_args <- function(pr) {
    list(pr$sim, pr$field, hypers = pr$hypers %||% set_hyperPriors(),
         kernelS = pr$kernelS %||% "powexp", kernelB = pr$kernelB %||% "powexp")
  }
  # ms per default sweep after nAdapt adapting sweeps, in chunks with
  # chol(n + m) timed in between
  sweep_cost <- function(name, nAdapt, nSweep, chunks, kernel = NULL) {
    pr <- problem(name, kernel)
    n <- nrow(pr$field); m <- nrow(pr$sim)
    set.seed(2)
    fit <- suppressMessages(do.call(calibrate, c(fit_args(pr), list(
      nMCMC = nAdapt + 2, nBurn = nAdapt, thinning = 1, nChains = 1))))
    state <- fit$state$chains[[1]]$sampler
    per <- max(1, ceiling(nSweep / chunks))
    ms <- ch <- numeric(chunks)
    for (i in seq_len(chunks)) {
      t0 <- cpu()
      res <- FBC:::sample_chain(fit$model$data, fit$model$spec, state, fit$model$moves, per, 0L, 1L, FALSE)
      ms[i] <- 1000 * (cpu() - t0) / per
      state <- res$state
      ch[i] <- t_chol(n + m, budget = 0.5)
    }
    data.frame(case = name, kernel = kernel %||% "powexp", n = n, m = m,
               algebra = fit$model$algebra$name,
               sweeps = per * chunks, `ms/sweep` = stats::median(ms),
               `chol ms` = stats::median(ch), ratio = stats::median(ms / ch),
               `peak MB` = peak_mb(), blas = FBC:::blas_kind(), check.names = FALSE)
  }
  `%||%` <- function(x, y) if (is.null(x)) y else x
  converged <- function(name, step = 2000, maxSweeps = 40000, quick = FALSE) {
    pr <- problem(name)
    set.seed(2024)
    t0 <- cpu()
    fit <- suppressMessages(if (quick) {
      do.call(calibrate, c(fit_args(pr), list(nMCMC = 400, nBurn = 200)))
    } else {
      do.call(calibrate, fit_args(pr))
    })
    first <- cpu() - t0
    firstFit <- fit
    # (fixed parameters have no R-hat or ESS)
    ok <- function(f) all(f$estimates$rhat < 1.01, na.rm = TRUE) &&
      all(f$estimates$ess >= 400, na.rm = TRUE)
    say <- function(f) {
      message(sprintf("[%s] %s: %d sweeps/chain, %.0f CPU s, max R-hat %.4f, min ESS %.0f",
                      format(Sys.time(), "%H:%M"), name, f$settings$nMCMC, cpu() - t0,
                      max(f$estimates$rhat, na.rm = TRUE), min(f$estimates$ess, na.rm = TRUE)))
    }
    say(fit)
    while (!ok(fit) && fit$settings$nMCMC < maxSweeps && !quick) {
      fit <- update(fit, nMCMC = step)
      say(fit)
    }
    total <- cpu() - t0
    ci <- function(f) {
      k <- grep("^kappa", colnames(f$Phi))
      t(apply(f$Phi[, k, drop = FALSE], 2, stats::quantile, c(0.05, 0.95)))
    }
    cover <- function(f) {
      iv <- ci(f)
      paste(sprintf("[%.3g, %.3g]%s", iv[, 1], iv[, 2],
                    ifelse(iv[, 1] <= pr$truth & pr$truth <= iv[, 2], "", "(miss)")), collapse = " ")
    }
    est <- fit$estimates
    worst <- rownames(est)[which(est$rhat >= 1.01 | est$ess < 400)]
    if (length(worst)) message(name, ": not converged: ", paste(worst, collapse = ", "))
    data.frame(case = name, `first CPU s` = first, `first 90% kappa` = cover(firstFit),
               converged = ok(fit), `sweeps/chain` = fit$settings$nMCMC,
               `CPU s` = total, `max rhat` = max(est$rhat, na.rm = TRUE),
               `min ess` = min(est$ess, na.rm = TRUE),
               `90% kappa` = cover(fit), truth = paste(pr$truth, collapse = ", "),
               `peak MB` = peak_mb(), blas = FBC:::blas_kind(), check.names = FALSE)
  }
  environment()
}

in_fresh_process <- function(fun, ...) {
  if (requireNamespace("callr", quietly = TRUE)) {
    callr::r(function(fun, helpers, ...) {
      suppressPackageStartupMessages(library(FBC))
      h <- helpers()
      environment(fun) <- h
      fun(...)
    }, args = list(fun = fun, helpers = helpers, ...), stderr = "",
    env = c(callr::rcmd_safe_env(), R_LIBS = Sys.getenv("R_LIBS")))
  } else {
    h <- helpers()
    environment(fun) <- h
    fun(...)
  }
}

# ---- run ---------------------------------------------------------------------
cat(sprintf("FBC %s scale benchmark, %s\n", utils::packageVersion("FBC"),
            format(Sys.time(), "%Y-%m-%d %H:%M")))
si <- utils::sessionInfo()
cat(sprintf("%s; %s; %d cores; BLAS: %s (%s); load average %s\n", R.version.string, si$running,
            as.integer(parallelly::availableCores()), basename(si$BLAS), FBC:::blas_kind(),
            tryCatch(paste(strsplit(readLines("/proc/loadavg"), " ")[[1]][1:3], collapse = " "),
                     error = function(e) "?")))
t_start <- proc.time()[[3]]
show <- function(tab) {
  num <- vapply(tab, is.numeric, TRUE)
  tab[num] <- lapply(tab[num], function(x) signif(x, 3))
  print(tab, row.names = FALSE)
  cat("\n")
}

if ("sweep" %in% parts) {
  cat("\n== Cost of one default sweep (proposals adapted, then frozen) ==\n")
  spec <- list(functional = c(nAdapt = 500, nSweep = 2000, chunks = 4),
               m1000 = c(nAdapt = 60, nSweep = 40, chunks = 4),
               m2000 = c(nAdapt = 20, nSweep = 12, chunks = 3))
  if (quick) spec <- lapply(spec, function(s) stats::setNames(pmax(2, round(s / c(10, 10, 2))), names(s)))
  rows <- lapply(names(spec), function(nm) {
    s <- spec[[nm]]
    in_fresh_process(function(nm, s) sweep_cost(nm, s[["nAdapt"]], s[["nSweep"]], s[["chunks"]]),
                     nm = nm, s = s)
  })
  show(do.call(rbind, rows))
}

if ("kernels" %in% parts) {
  cat("\n== Cost of one default sweep per correlation family (both GPs) ==\n")
  spec <- list(ball = c(nAdapt = 500, nSweep = 2000, chunks = 4),
               functional = c(nAdapt = 500, nSweep = 2000, chunks = 4),
               m1000 = c(nAdapt = 60, nSweep = 40, chunks = 4))
  if (quick) spec <- lapply(spec, function(s) stats::setNames(pmax(2, round(s / c(10, 10, 2))), names(s)))
  rows <- list()
  for (nm in names(spec)) for (k in c("powexp", "gaussian", "matern32", "matern52")) {
    s <- spec[[nm]]
    rows[[length(rows) + 1L]] <- in_fresh_process(
      function(nm, s, k) sweep_cost(nm, s[["nAdapt"]], s[["nSweep"]], s[["chunks"]], kernel = k),
      nm = nm, s = s, k = k)
  }
  show(do.call(rbind, rows))
}

runs <- c(if ("functional" %in% parts) c("functional", "functional-alpha2", "functional-gaussian",
                                         "functional-matern52"),
          intersect(c("functional-alpha2", "functional-gaussian", "functional-matern52",
                      "m1000", "m2000", "m1000-gaussian", "m2000-gaussian"), parts))
runs <- unique(runs)
for (nm in runs) {
  cat(sprintf("\n== Time to a converged posterior: %s ==\n", nm))
  show(in_fresh_process(function(nm, quick) converged(nm, quick = quick), nm = nm, quick = quick))
}
cat(sprintf("Total benchmark time: %.0f s (wall)\n", proc.time()[[3]] - t_start))
