# Helpers for the chain, SBC and recovery tests.

# A random Latin hypercube on [0, 1]^k with m points.
lhs_like <- function(m, k) {
  vapply(seq_len(k), function(j) (sample(m) - stats::runif(m)) / m, numeric(m))
}

# A sampler that imitates Ctrl-C: the first `calls` calls stop after `stopAt`
# iterations and return what the compiled sampler returns when interrupted
# (draws matrix of the full size, rows after `kept` unused; interrupted =
# TRUE). Install with withr-free options(FBC.sampler = ...).
fake_interrupt_sampler <- function(stopAt, calls = 1L) {
  n <- 0L
  function(Xf, yf, Xs, ys, prior, init, logsd, nIter, nBurn, thinning, adapt, batch,
           nugget, progress) {
    n <<- n + 1L
    if (n > calls) {
      return(FBC:::.fbc_sample(Xf, yf, Xs, ys, prior, init, logsd, nIter, nBurn, thinning,
                               adapt, batch, nugget, progress))
    }
    res <- FBC:::.fbc_sample(Xf, yf, Xs, ys, prior, init, logsd, stopAt, min(nBurn, stopAt - 1L),
                             thinning, adapt, batch, nugget, progress)
    full <- matrix(0, (nIter - nBurn) %/% thinning, ncol(res$draws))
    full[seq_len(res$kept), ] <- res$draws[seq_len(res$kept), ]
    pad <- function(v) c(v[seq_len(res$kept)], numeric(nrow(full) - res$kept))
    res$draws <- full
    res$logPost <- pad(res$logPost)
    res$logLik <- pad(res$logLik)
    res$interrupted <- TRUE
    res
  }
}

# A small, quick calibration of the ball data.
small_fit <- function(nChains = 2, seed = 1, ...) {
  set.seed(seed)
  calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, thinning = 2, nChains = nChains, ...)
}
