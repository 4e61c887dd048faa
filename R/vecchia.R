# The nearest-neighbour (Vecchia) algebra's design: which runs each run and
# each field latent condition on (src/vecchia.cpp). Made once per fit,
# before sampling, the same for every chain, and kept in the model
# description (spec$model$vecchia), so a run, its checkpoints, update(),
# predict() and emulator_cv() all use the same approximation.
#
# The distances are those of the inputs scaled by w_k = theta_k^(1 / alpha)
# (sqrt(theta_k) for the families without a smoothness), with theta a pilot
# estimate: the maximum of the simulator GP's likelihood alone (sigma2S
# profiled out), exact on at most `fbc_vecchia_pilot` runs spread over the
# design (Katzfuss, Guinness and Lawrence 2022 scale the inputs the same
# way). The runs are put in a maximin order of the scaled inputs (Guinness
# 2018) and each conditions on its k nearest earlier runs.

# Runs above which calibrate(algebra = "auto") used this algebra on a design
# that is not a product design before choose_algebra() (R/algebra.R) chose by
# projected cost: print() of such a fit says so.
fbc_vecchia_m <- 3000L
# Runs the pilot estimate of the scaling uses (at most).
fbc_vecchia_pilot <- 400L

# The design for simulator inputs Xs (scaled) and responses ys, correlation
# family code kern, k neighbours among the runs and kf among the field
# latents.
vecchia_design <- function(Xs, ys, kern, k, kf) {
  w <- vecchia_scaling(Xs, ys, kern)
  ord <- .vecchia_order(Xs, w)
  list(k = as.integer(k), kf = as.integer(kf), order = ord,
       neighbours = .vecchia_neighbours(Xs, ord, w, as.integer(k)), scaling = w)
}

# The pilot scaling w of the inputs (see the top). The smoothness of the
# power exponential is held at 1.9 (its default start).
vecchia_scaling <- function(Xs, ys, kern) {
  m <- nrow(Xs)
  K <- ncol(Xs)
  rows <- unique(as.integer(round(seq(1, m, length.out = min(m, fbc_vecchia_pilot)))))
  X <- Xs[rows, , drop = FALSE]
  y <- ys[rows]
  alpha <- rep(1.9, K)
  nll <- function(lt) {
    R <- .corr_matrix(X, X, exp(lt), alpha, kern)
    diag(R) <- diag(R) + fbc_nugget
    L <- tryCatch(chol(R), error = function(e) NULL)
    if (is.null(L)) return(1e10)
    z <- backsolve(L, y, transpose = TRUE)
    0.5 * (length(y) * log(sum(z^2) / length(y)) + 2 * sum(log(diag(L))))
  }
  opt <- stats::optim(rep(0, K), nll, method = "L-BFGS-B", lower = rep(-4, K),
                      upper = rep(8, K))
  theta <- exp(opt$par)
  theta^(1 / if (kern == kernel_codes[["powexp"]]) 1.9 else 2)
}

# Checks `neighbours`: a whole number, at least 1.
check_neighbours <- function(neighbours, call = parent.frame()) {
  check_count(neighbours, "neighbours", min = 1, call = call)
}
