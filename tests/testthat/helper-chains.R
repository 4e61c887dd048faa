# Helpers for the chain, SBC and recovery tests.

# A random Latin hypercube on [0, 1]^k with m points.
lhs_like <- function(m, k) {
  vapply(seq_len(k), function(j) (sample(m) - stats::runif(m)) / m, numeric(m))
}

# FBC 0.1.0's defaults, for tests whose references (fixtures, draws, plain-R
# formulas) were made with them: the power exponential for both GPs and the
# inverse gamma (1.5, 1.5) noise prior.
defaults_010 <- list(kernelS = "powexp", kernelB = "powexp",
                     hypers = set_hyperPriors(sigma2EDist = "inversegamma", sigma2EP1 = 1.5,
                                              sigma2EP2 = 1.5))

# A sampler that imitates Ctrl-C: the first `calls` calls stop after `stopAt`
# iterations and return what the compiled sampler returns when interrupted
# (interrupted = TRUE, the state where it stopped). Install with
# options(FBC.sampler = ...).
fake_interrupt_sampler <- function(stopAt, calls = 1L) {
  n <- 0L
  # (`...`: the model description, kernels and algebra, passed on as given)
  function(Xf, yf, Xs, ys, prior, moves, state, nIter, nBurn, thinning, nugget, progress, ...) {
    n <<- n + 1L
    if (n > calls) {
      return(FBC:::.fbc_sample(Xf, yf, Xs, ys, prior, moves, state, nIter, nBurn, thinning,
                               nugget, progress, ...))
    }
    res <- FBC:::.fbc_sample(Xf, yf, Xs, ys, prior, moves, state, stopAt, nBurn, thinning,
                             nugget, progress, ...)
    res$interrupted <- TRUE
    res
  }
}

# The compiled sampler on scaled data `dat` with priors `sp` (build_priors())
# from the priors' initial values: `sampler` "single" or "blocks".
run_sampler <- function(dat, sp, sampler, nIter, nBurn, thinning, state = NULL) {
  moves <- FBC:::sampler_moves(sampler, sp)
  state <- state %||% FBC:::initial_state(sp$init, sp)
  res <- FBC:::.fbc_sample(dat$Xf, dat$yf, dat$Xs, dat$ys, as.list(sp$table), moves, state,
                           nIter, nBurn, thinning, 1e-6, NULL, model = sp$model)
  # each parameter's acceptance, from the moves' counts (the sampler's only)
  d <- length(state$phi)
  vars <- if (length(moves$params) == d) moves$params else paste0("phi", seq_len(d))
  acc <- FBC:::move_acceptance(res$state$moves, vars)
  res$acceptance <- unname(c(acc))
  res$scaleAcceptance <- attr(acc, "scale")
  res
}
`%||%` <- function(x, y) if (is.null(x)) y else x

# A small, quick calibration of the ball data.
small_fit <- function(nChains = 2, seed = 1, ...) {
  set.seed(seed)
  calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, thinning = 2, nChains = nChains, ...)
}

# Simulation-based calibration (Talts et al. 2018) of the compiled sampler on
# a tiny KOH problem (p = 1, q = 1) given directly on the sampler's scale.
# `free` names the sampled parameters, each with a proper prior; the others
# are fixed at `fixedAt`. Each replication draws phi from the prior (with
# R's own r* functions, independently of the package's prior code), data
# from the model (dense_cov), runs one chain and records the rank of the
# true value among `nDraws` thinned posterior draws. Returns a replications
# x parameters matrix of ranks in 0..nDraws. `sigma2EFactor` != 1 generates
# the data with a wrong noise variance (a sampler targeting the wrong
# posterior, seen from the other side), to show the check has power.
# `joint = TRUE` also samples thetaS (Gamma(4, 2)) and sigma2B
# (InvGamma(4, 0.3)), so that the default sampler's joint moves all act: the
# (thetaS, sigma2S) block, the variance scale move and the exact muB draw.
sbc_ranks <- function(L, n = 5, m = 12, nDraws = 99, thin = 10, nBurn = 500, seed = 1,
                      sigma2EFactor = 1, sampler = "blocks", joint = FALSE) {
  set.seed(seed)
  p <- 1; q <- 1
  Xf <- matrix(seq(0.05, 0.95, length.out = n), n, 1)
  Xs <- lhs_like(m, 2)
  hyp <- set_hyperPriors(
    thetaSDist = "fixed", thetaSInit = c(3, 2), alphaSDist = "fixed", alphaSInit = 1.9,
    thetaBDist = "fixed", thetaBInit = 2, alphaBDist = "fixed", alphaBInit = 1.9,
    sigma2SDist = "inversegamma", sigma2SInit = 1, sigma2SP1 = 4, sigma2SP2 = 3,
    sigma2BDist = "fixed", sigma2BInit = 0.05,
    sigma2EDist = "inversegamma", sigma2EInit = 0.05, sigma2EP1 = 4, sigma2EP2 = 0.15,
    muBDist = "gaussian", muBInit = 0, muBP1 = 0, muBP2 = 0.5
  )
  if (joint) {
    hyp$thetaS <- list(dist = "gamma", init = 2, p1 = 4, p2 = 2)
    hyp$sigma2B <- list(dist = "inversegamma", init = 0.1, p1 = 4, p2 = 0.3)
  }
  scale <- list(xmin = c(0, 0), xmax = c(1, 1), ymean = 0, ysd = 1, p = p, q = q,
                names = list(response = "y", inputs = "x", calibration = "t"))
  kappaSpec <- check_class_spec(list(dist = "beta", init = NA, p1 = 2, p2 = 2), "kappa", q)
  spec <- build_priors(kappaSpec, hyp, scale, p, q)
  spec$model <- compiled_model(p, q)
  free <- c("kappa1", "sigma2S", "sigma2E", "muB", if (joint) c("thetaS1", "thetaS2", "sigma2B"))
  draw_prior <- function() {
    phi <- spec$init
    phi[match(free, spec$vars)] <- c(
      stats::rbeta(1, 2, 2), 1 / stats::rgamma(1, 4, rate = 3),
      1 / stats::rgamma(1, 4, rate = 0.15), stats::rnorm(1, 0, 0.5),
      if (joint) c(stats::rgamma(2, 4, 2), 1 / stats::rgamma(1, 4, rate = 0.3))
    )
    phi
  }
  nMCMC <- nBurn + nDraws * thin
  t(vapply(seq_len(L), function(l) {
    truth <- draw_prior()
    gen <- truth
    gen[match("sigma2E", spec$vars)] <- sigma2EFactor * gen[match("sigma2E", spec$vars)]
    C <- dense_cov(Xf, Xs, gen, fbc_nugget)
    y <- drop(t(chol(C)) %*% stats::rnorm(n + m)) + c(rep(truth[length(truth)], n), rep(0, m))
    dat <- list(Xf = Xf, yf = y[seq_len(n)], Xs = Xs, ys = y[n + seq_len(m)])
    res <- sample_chain(dat, spec, initial_state(spec$init, spec), sampler_moves(sampler, spec),
                        nMCMC, nBurn, thin, showProgress = FALSE)
    j <- match(free, spec$vars)
    colSums(res$draws[, j, drop = FALSE] < matrix(truth[j], nDraws, length(j), byrow = TRUE))
  }, numeric(length(free))))
}

# Chi-square test of uniform ranks in `bins` equal bins (ranks 0..nDraws).
rank_chisq <- function(ranks, nDraws = 99, bins = 10) {
  apply(ranks, 2, function(r) {
    counts <- tabulate(floor(r * bins / (nDraws + 1)) + 1, bins)
    stats::chisq.test(counts)$p.value
  })
}
