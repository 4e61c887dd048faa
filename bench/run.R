# The benchmark suite's runner. From the package root, with FBC installed:
#
#   Rscript bench/run.R --list                  # the benchmarks
#   Rscript bench/run.R <name> [--quick] [--key=value ...]
#   Rscript bench/run.R <name> --help           # its options
#
# Each benchmark is bench/<name>.R; its results are in bench/RESULTS-<name>.md
# (the current table, with the date, commit, machine, BLAS and command that
# made it). Option parsing is shared: bench/options.R.
benchmarks <- c(
  speed        = "ms per sweep against the Cholesky floor",
  mixing       = "time to a converged posterior: FBC's samplers and Stan's NUTS",
  defaults     = "the defaults converge: precise data, ball drop, m = 1000 ... 20,000, functional",
  warmup       = "the ball drop with the defaults, beside RobustCalibration",
  applications = "the shipped applications with the defaults",
  scale        = "functional output (Kronecker) and large dense designs",
  vecchia      = "the nearest-neighbour algebra, m = 1000 ... 100,000",
  threads      = "threads inside a chain: the nearest-neighbour sweep with 1 and 2 threads",
  "kronecker-blas" = "the Kronecker sweep under this process's BLAS (threads are the BLAS's)",
  outputs      = "several outputs on a product design",
  "outputs-study" = "several outputs, known truth: pooled against one output",
  discrepancy  = "the discrepancy models against a known L2 projection",
  "function"   = "the simulator as an R function, beside RobustCalibration",
  jump         = "kappa's jump move on a multimodal posterior",
  validate     = "emulator_cv()'s cost",
  "check-schedule" = "where the stopping rule stops under other check schedules",
  design       = "design of new runs: kappa's posterior as runs are added, per method",
  "design-table" = "summary tables of design's saved replicates",
  "design-cost" = "the design step's cost against the fit it follows",
  "design-memory" = "peak memory of the design step with several outputs",
  "design-reweight" = "update(fit, sim =)'s reweighted draws against fresh fits",
  "design-warm" = "warm refits against fresh fits",
  sbc          = "simulation-based calibration of the sampler",
  peers        = "FBC beside RobustCalibration on the same data, same process",
  "failed-runs" = "failed runs: spot weld as shipped; design around a failure region",
  sensitivity  = "Sobol indices against known ones: coverage, widths, CPU s",
  "sensitivity-large" = "Sobol indices by sampling on the nearest-neighbour algebra, beside the closed form",
  "sim-noise"  = "stochastic simulators: replicate runs against the exact posterior",
  "sepia-ball" = "SEPIA's ball drop 1: height x (R, C) on the Kronecker algebra",
  "missing-cells" = "functional output on a product design with missing cells"
)

args <- commandArgs(trailingOnly = TRUE)
# run from the package root whatever the working directory
file_arg <- grep("^--file=", commandArgs(FALSE), value = TRUE)
if (length(file_arg)) {
  root <- dirname(dirname(normalizePath(sub("^--file=", "", file_arg[1]))))
  setwd(root)
}
if (!length(args) || args[1] %in% c("--list", "--help", "-h")) {
  cat("Usage: Rscript bench/run.R <name> [--quick] [--key=value ...]\n\nBenchmarks:\n")
  cat(sprintf("  %-16s %s\n", names(benchmarks), benchmarks), sep = "")
  quit(save = "no", status = if (length(args)) 0 else 1)
}
name <- args[1]
if (!name %in% names(benchmarks)) {
  stop("unknown benchmark '", name, "'; see Rscript bench/run.R --list", call. = FALSE)
}
options(fbc.bench.args = args[-1])
source("bench/options.R")
source(file.path("bench", paste0(name, ".R")), echo = FALSE)
