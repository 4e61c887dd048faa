# Where the default stopping rule stops: the check schedule that predicts
# where the rule will be met (the package's) beside the geometric one of
# earlier versions (each check after half as many retained sweeps again:
# 500, 750, 1150, 1750, 2650, ...), on the same seeds in the same process.
#
#   Rscript bench/run.R check-schedule [--problem=ball] [--m=1000] [--seeds=1,2,3,4,5] [--reps=2]
#
# problem = "ball": calibrate(ballSim, ballField) with every argument at its
# default; "scattered": scattered_problem(m) (bench/problems.R), the same.
# Each seed runs twice, the geometric schedule first on odd seeds and
# second on even ones (the machine's load drifts); the geometric schedule is
# the package's run with next_check() replaced by the geometric step. The
# draws do not depend on when the rule checks (each chain continues its own
# random stream), so the two runs of a seed share their draws up to the
# shorter one's end (checked), and the first length that meets the rule
# (every R-hat < 1.01, bulk ESS >= 400) is found by checking the longer
# run's prefixes every 50 retained sweeps a chain. Prints one row per seed:
# retained sweeps a chain at the stop (sweeps after warm-up), the first
# length that meets the rule, the overshoot, the checks, CPU seconds (user
# + system of this process; the least of `reps` runs, which make the same
# draws: the machine is shared) and the warm-up's share of each chain's
# sweeps.
# Run from the package root.
suppressPackageStartupMessages(library(FBC))
source("bench/options.R")
opt <- bench_options(list(problem = "ball", m = 1000L, seeds = 1:5, reps = 2L))
if (opt$quick) opt[c("seeds", "reps")] <- list(1L, 1L)
if (opt$problem == "ball") {
  sim <- FBC::ballSim
  field <- FBC::ballField
  label <- "ball drop (ballSim, ballField)"
} else {
  source("bench/problems.R")
  pr <- scattered_problem(opt$m)
  sim <- pr$sim
  field <- pr$field
  label <- sprintf("scattered, m = %d", opt$m)
}

geometric <- function(post, rule, check = NULL) {
  if (!is.null(rule$every)) return(as.integer(post + rule$every))
  as.integer(ceiling(1.5 * post / 50) * 50)
}
predicting <- get("next_check", envir = asNamespace("FBC"))

# One default run under a schedule: the fit's draws and what the table needs.
run <- function(seed, schedule) {
  utils::assignInNamespace("next_check", schedule, "FBC")
  on.exit(utils::assignInNamespace("next_check", predicting, "FBC"))
  cpu <- Inf
  for (i in seq_len(opt$reps)) {
    set.seed(seed)
    t0 <- proc.time()
    again <- calibrate(sim, field, showProgress = FALSE)
    cpu <- min(cpu, sum((proc.time() - t0)[1:2]))
    if (i > 1L) stopifnot(identical(again$Phi, fit$Phi))
    fit <- again
  }
  warm <- fit$settings$warmup
  post <- fit$settings$converge$sweeps - max(warm)  # the same for every chain
  list(Phi = fit$Phi, chain = fit$chain, thinning = fit$settings$thinning, warm = warm,
       post = post, checks = fit$settings$converge$checks,
       converged = fit$settings$converge$converged, cpu = cpu)
}

# The first retained sweeps a chain (a multiple of 50) whose draws meet the
# rule, from the prefixes of a run's chains.
first_met <- function(r) {
  idx <- split(seq_along(r$chain), r$chain)
  for (post in seq(50, r$post, by = 50)) {
    n <- post / r$thinning
    est <- FBC:::chain_diagnostics(r$Phi[unlist(lapply(idx, utils::head, n)), , drop = FALSE],
                                   rep(seq_along(idx), each = n))
    o <- !is.na(est$rhat) & !is.na(est$ess)
    if (all(est$rhat[o] < 1.01) && all(est$ess[o] >= 400)) return(post)
  }
  NA_integer_
}

# Do two runs of a seed share their draws up to the shorter one's end?
same_prefix <- function(a, b) {
  n <- min(a$post, b$post) / a$thinning
  cut <- function(r) r$Phi[unlist(lapply(split(seq_along(r$chain), r$chain), utils::head, n)), ]
  identical(unname(cut(a)), unname(cut(b)))
}

cat(sprintf("Check schedules of the default stopping rule, %s, %s\n", label,
            format(Sys.time(), "%Y-%m-%d %H:%M")))
cat(sprintf("%s; %d cores; BLAS: %s\n\n", R.version.string, parallel::detectCores(),
            basename(extSoftVersion()[["BLAS"]])))
rows <- list()
for (seed in opt$seeds) {
  if (seed %% 2L == 1L) {
    old <- run(seed, geometric)
    new <- run(seed, predicting)
  } else {
    new <- run(seed, predicting)
    old <- run(seed, geometric)
  }
  first <- first_met(if (old$post >= new$post) old else new)
  share <- mean(new$warm / (new$warm + new$post))
  rows[[length(rows) + 1L]] <- data.frame(
    seed = seed, warmup = paste(range(new$warm), collapse = "-"), first = first,
    old.stop = old$post, old.over = round(100 * (old$post / first - 1)), old.checks = old$checks,
    old.cpu = round(old$cpu, 1),
    new.stop = new$post, new.over = round(100 * (new$post / first - 1)), new.checks = new$checks,
    new.cpu = round(new$cpu, 1),
    warm.share = round(100 * share), same.draws = same_prefix(old, new),
    converged = old$converged && new$converged
  )
  print(rows[[length(rows)]], row.names = FALSE)
}
tab <- do.call(rbind, rows)
cat("\nseed: set.seed(); warmup: warm-up sweeps (range over chains); first: the first retained\n",
    "sweeps a chain (multiple of 50) that meet the rule; stop: retained sweeps a chain at the\n",
    "stop; over: % past first; cpu: CPU s of the run; warm.share: warm-up's % of a chain's\n",
    "sweeps (mean over chains); same.draws: the two runs' draws agree up to the shorter end\n\n",
    sep = "")
print(tab, row.names = FALSE)
cat("\n| seed | warm-up | first met | geometric: stop | over | checks | CPU s | predicting: stop | over | checks | CPU s | warm-up share |\n")
cat("|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|\n")
with(tab, cat(sprintf("| %d | %s | %d | %d | %d%% | %d | %.1f | %d | %d%% | %d | %.1f | %d%% |\n", seed,
                      warmup, first, old.stop, old.over, old.checks, old.cpu, new.stop, new.over,
                      new.checks, new.cpu, warm.share), sep = ""))
cat(sprintf("\nover %%: geometric median %.0f (max %.0f), predicting median %.0f (max %.0f)\n",
            median(tab$old.over), max(tab$old.over), median(tab$new.over), max(tab$new.over)))
cat(sprintf("retained sweeps a chain, all seeds: geometric %d, predicting %d (%.2fx)\n",
            sum(tab$old.stop), sum(tab$new.stop), sum(tab$new.stop) / sum(tab$old.stop)))
cat(sprintf("CPU s, all seeds: geometric %.1f, predicting %.1f (%.2fx)\n",
            sum(tab$old.cpu), sum(tab$new.cpu), sum(tab$new.cpu) / sum(tab$old.cpu)))
