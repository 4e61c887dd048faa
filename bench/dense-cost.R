# The projected cost of a dense sweep (R/algebra.R, dense_sweep_cost())
# against measured sweeps of the compiled sampler, over a grid of m runs,
# p experimental and q calibration inputs (n = 30 field rows, the default
# schedule of each size: the large-problem schedule from m = 500).
#
#   Rscript bench/dense-cost.R [--quick] [--constants]
#
# Each size: a scattered design (random Latin hypercube on [0, 1]^(p + q)),
# a smooth response, the model of calibrate(algebra = "dense") and its
# default moves; CPU seconds of `sweeps` sweeps of one chain from the
# initial values (warm-up sweeps, whose moves cost what retained ones do),
# the best of 3. Columns: m, p, q, n, measured and projected seconds a
# sweep, their ratio (projected / measured), and the old projection
# 1.5e-10 (m + n)^3 with its ratio.
#
# --constants: the measurements the constants of dense_sweep_cost() come
# from: sweeps on a training grid apart from the checking one (m = 150,
# 250, 400, 650; p, q = 1, 2, 4), each sweep's features (per move of the
# simulator block m^3, d m^2, n m^2; per kappa move n m^2, d n m; per move
# n^3, with the moves of its default schedule) and the five constants that
# minimise the squared log ratio of projected to measured.
# --quick: a smaller grid.
library(FBC)
args <- commandArgs(trailingOnly = TRUE)
quick <- "--quick" %in% args
cpu <- function() sum(proc.time()[c("user.self", "sys.self")])

problem <- function(m, p, q, n = 30, seed = 1) {
  set.seed(seed)
  d <- p + q
  X <- vapply(seq_len(d), function(j) (sample(m) - stats::runif(m)) / m, numeric(m))
  f <- function(X) sin(2 * rowSums(X)) + X[, 1]^2
  colnames(X) <- c(paste0("x", seq_len(p)), paste0("t", seq_len(q)))
  xf <- matrix(stats::runif(n * p), n, p, dimnames = list(NULL, colnames(X)[seq_len(p)]))
  yf <- f(cbind(xf, matrix(0.5, n, q))) + stats::rnorm(n, 0, 0.05)
  list(sim = data.frame(y = f(X), X), field = data.frame(y = yf, xf))
}

model_of <- function(pr) {
  suppressWarnings(suppressMessages(
    calibrate(pr$sim, pr$field, algebra = "dense", fit = FALSE)))
}

# CPU seconds a sweep: `sweeps` sweeps of one chain after 100 sweeps from
# the initial values (untimed: the proposals first adapt away from their
# starting scales, whose rejected-out-of-support proposals cost nothing),
# best of `reps`
time_sweeps <- function(model, sweeps, moves = model$moves, reps = 3) {
  st <- FBC:::initial_state(model$spec$init, model$spec)
  set.seed(1)
  st <- FBC:::sample_chain(model$data, model$spec, st, moves, 100L, 10000L, 1L, FALSE)$state
  best <- Inf
  for (r in seq_len(reps)) {
    set.seed(r)
    t0 <- cpu()
    FBC:::sample_chain(model$data, model$spec, st, moves, sweeps, 10000L, 1L, FALSE)
    best <- min(best, cpu() - t0)
  }
  best / sweeps
}

sweeps_for <- function(m) if (m <= 200) 60L else if (m <= 500) 30L else 10L

# the features of a sweep (R/algebra.R): per move of the simulator block
# m^3, d m^2, n m^2; per kappa move n m^2, d n m; per move n^3
features <- function(m, n, p, q) {
  mv <- FBC:::dense_sweep_moves(q, m >= FBC:::fbc_large_m)
  d <- p + q
  c(A = mv[["sim"]] * m^3, B = mv[["sim"]] * d * m^2,
    C = (mv[["sim"]] + mv[["kappa"]]) * n * m^2, D = mv[["kappa"]] * d * n * m,
    E = sum(mv) * n^3)
}

if ("--constants" %in% args) {
  # a training grid apart from the checking grid below; the constants
  # minimise the squared log ratio of projected to measured sweeps
  grid <- expand.grid(m = c(150, 250, 400, 650), p = c(1, 2, 4), q = c(1, 2, 4))
  rows <- list()
  for (i in seq_len(nrow(grid))) {
    g <- grid[i, ]
    model <- model_of(problem(g$m, g$p, g$q))
    rows[[i]] <- data.frame(g, n = 30, measured = time_sweeps(model, sweeps_for(g$m)))
    print(rows[[i]], digits = 3, row.names = FALSE)
  }
  tab <- do.call(rbind, rows)
  Fm <- t(vapply(seq_len(nrow(tab)), function(i) features(tab$m[i], tab$n[i], tab$p[i], tab$q[i]),
                 numeric(5)))
  loss <- function(lk) sum((log(drop(Fm %*% exp(lk))) - log(tab$measured))^2)
  start <- log(c(3e-10, 1e-9, 1e-9, 1e-8, 1e-9))
  fitc <- stats::optim(start, loss, method = "BFGS", control = list(maxit = 1000))
  k <- stats::setNames(exp(fitc$par), c("A", "B", "C", "D", "E"))
  print(signif(k, 3))
  r <- drop(Fm %*% k) / tab$measured
  cat(sprintf("training grid: projected / measured %.2f to %.2f\n", min(r), max(r)))
  quit(save = "no")
}

grid <- if (quick) expand.grid(m = c(100, 400), p = c(1, 3), q = c(1, 3)) else
  expand.grid(m = c(100, 300, 500, 780), p = c(1, 3), q = c(1, 3))
rows <- list()
for (i in seq_len(nrow(grid))) {
  g <- grid[i, ]
  model <- model_of(problem(g$m, g$p, g$q))
  measured <- time_sweeps(model, sweeps_for(g$m))
  projected <- FBC:::dense_sweep_cost(g$m, 30, g$p, g$q)
  old <- 1.5e-10 * (g$m + 30)^3
  rows[[i]] <- data.frame(g, n = 30, measured = measured, projected = projected,
                          ratio = projected / measured, old = old, oldRatio = old / measured)
  print(rows[[i]], digits = 3, row.names = FALSE)
}
tab <- do.call(rbind, rows)
cat("\n")
print(tab, digits = 3, row.names = FALSE)
cat(sprintf("\nprojected / measured: %.2f to %.2f (old: %.2f to %.2f)\n", min(tab$ratio), max(tab$ratio),
            min(tab$oldRatio), max(tab$oldRatio)))
