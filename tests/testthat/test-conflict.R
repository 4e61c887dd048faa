# References: the priors' CDFs against numerical integrals of the package's
# own log densities; the conflict rule on real short runs (small noise: the
# truth is known; ball data: the rule must stay silent) and on draws built by
# hand so that the message is reproducible to the digit.

# Free fall t = sqrt(2 h / g) on a 12 x 8 grid, field data at g = 9.81 with
# noise sd `frac` times the simulator response's sd (sigma2E = frac^2 on the
# standardised scale), no discrepancy.
small_noise_data <- function(frac = 0.1, seed = 10) {
  set.seed(seed)
  h <- seq(5, 30, length.out = 20)
  grid <- expand.grid(h = seq(4, 31, length.out = 12), g = seq(6, 14, length.out = 8))
  sim <- cbind(t = sqrt(2 * grid$h / grid$g), h = grid$h, g = grid$g)
  field <- cbind(t = sqrt(2 * h / 9.81) + rnorm(length(h), 0, frac * sd(sim[, "t"])), h = h)
  list(sim = sim, field = field)
}

# A fit of the small-noise data with 400 draws built by hand: every
# parameter at `base` (with `at` replacing some values) except `vary`,
# log-normal around its value (sd 0.25 on the log scale); 4 chains of 100,
# the MAP row the middle one.
hand_base <- c(kappa1 = 9.8, thetaS1 = 3, thetaS2 = 0.4, alphaS1 = 1.95, alphaS2 = 1.95,
               thetaB1 = 1, alphaB1 = 1.8, sigma2S = 1, sigma2B = 0.05, sigma2E = 0.16, muB = 0)
# The vignette's inverse gamma on sigma2E (the default before the half-Cauchy
# on the sd): the prior these checks flag.
vignette_noise <- set_hyperPriors(sigma2EDist = "inversegamma", sigma2EP1 = 1.5, sigma2EP2 = 1.5)
hand_built_fit <- function(vary, at = NULL) {
  d <- small_noise_data(frac = 0.1)
  set.seed(1)
  # the power exponential: the draws include the smoothness parameters
  fit <- calibrate(d$sim, d$field, nMCMC = 60, nBurn = 20, nChains = 1, hypers = vignette_noise,
                   kernelS = "powexp", kernelB = "powexp")
  base <- hand_base
  base[names(at)] <- at
  Phi <- matrix(base, 400, length(base), byrow = TRUE, dimnames = list(NULL, names(base)))
  Phi[, vary] <- exp(qnorm(ppoints(400), log(base[[vary]]), 0.25))
  fit$chain <- rep(1:4, each = 100)
  fit$logPost <- -abs(seq_len(400) - 200.5)
  with_draws(fit, Phi)
}
# The fit with draws `Phi` (same chains) and their estimates.
with_draws <- function(fit, Phi) {
  fit <- fit_with_draws(fit, Phi, fit$chain, fit$logPost)
  fit$estimates <- FBC:::estimate_table(Phi, fit$chain)
  fit
}

test_that("prior CDFs integrate the prior densities", {
  cases <- list(list("uniform", -1, 2, 0.5), list("gaussian", 1, 2, 0.3), list("gamma", 1.1, 0.1, 3),
                list("beta", 2, 5, 0.2), list("lognormal", 0, 1, 2), list("logistic", 1, 0.5, 0.2),
                list("betashift", 5, 2, 1.6), list("exponential", 2, NA, 0.4),
                list("inversegamma", 1.5, 1.5, 0.3))
  for (cs in cases) {
    f <- prior_builder(cs[[1]], cs[[2]], cs[[3]])
    lo <- switch(cs[[1]], uniform = -1, betashift = 1, gaussian = , logistic = -Inf, 0)
    ref <- integrate(function(x) exp(f(x)), lo, cs[[4]], rel.tol = 1e-10)$value
    expect_equal(FBC:::prior_cdf(cs[[4]], cs[[1]], cs[[2]], cs[[3]]), ref, tolerance = 1e-7,
                 label = cs[[1]])
  }
  expect_true(is.na(FBC:::prior_cdf(1, "jeffreys", NA, NA)))
  # the vignette's sigma2E prior has almost no mass below 0.1
  expect_lt(FBC:::prior_cdf(0.1, "inversegamma", 1.5, 1.5), 1e-5)
})

test_that("small field noise: the vignette's sigma2E prior is flagged, and the suggested prior fixes it", {
  d <- small_noise_data(frac = 0.1)  # true sigma2E about 0.01
  set.seed(1)
  fit <- calibrate(d$sim, d$field, nMCMC = 1000, nBurn = 400, nChains = 2, hypers = vignette_noise)
  cf <- FBC:::prior_conflicts(fit)
  expect_equal(cf$var, "sigma2E")
  expect_equal(cf$side, "lower")
  expect_gt(cf$median, 0.1)           # held up by the prior
  expect_lt(cf$dataValue, 0.03)       # the likelihood peaks near the truth
  msg <- convergence_messages(fit)
  expect_match(msg, "^Prior-data conflict for sigma2E: its posterior median", all = FALSE)
  expect_match(capture.output(print(fit)), "Prior-data conflict for sigma2E", all = FALSE)
  # the suggested call, run as given, removes the conflict and finds the noise
  call <- sub(".*`hypers = (.*)`.*", "\\1", grep("^Prior-data conflict", msg, value = TRUE))
  hypers <- eval(parse(text = call))
  expect_equal(hypers$sigma2E$dist, "inversegamma")
  expect_equal(hypers$sigma2E$p1, 1.1)
  set.seed(1)
  fit2 <- calibrate(d$sim, d$field, nMCMC = 1000, nBurn = 400, nChains = 2, hypers = hypers)
  expect_equal(nrow(FBC:::prior_conflicts(fit2)), 0L)
  expect_lt(median(fit2$Phi[, "sigma2E"]), 0.05)
  # the default, a half-Cauchy on the noise sd, lets the data set it: no conflict
  set.seed(1)
  fit3 <- calibrate(d$sim, d$field, nMCMC = 1000, nBurn = 400, nChains = 2)
  expect_equal(nrow(FBC:::prior_conflicts(fit3)), 0L)
  expect_lt(median(fit3$Phi[, "sigma2E"]), 0.05)
})

test_that("no conflict on the ball data with the vignette's priors", {
  skip_if_not_slow()
  set.seed(1)
  fit <- calibrate(ballSim, ballField, nMCMC = 1000, nBurn = 400, nChains = 2, hypers = vignette_noise,
                   kernelS = "powexp", kernelB = "powexp")
  # sigma2E is in the prior's tail (rule 1) but the likelihood peaks within
  # 3 posterior sds of its median (rule 2 fails)
  u <- FBC:::prior_cdf(median(fit$Phi[, "sigma2E"]), "inversegamma", 1.5, 1.5)
  expect_lt(u, 0.01)
  expect_equal(nrow(FBC:::prior_conflicts(fit)), 0L)
  expect_false(any(grepl("Prior-data conflict", convergence_messages(fit))))
})

test_that("the conflict message, on draws built by hand", {
  skip_if_not_slow()
  # every parameter fixed except sigma2E, log-normal around 0.16
  fit <- hand_built_fit("sigma2E")
  Phi <- fit$Phi
  cf <- FBC:::prior_conflicts(fit)
  expect_equal(cf$var, "sigma2E")
  # the peak of the likelihood in sigma2E, the others at the MAP row, by a grid
  map <- FBC:::sampler_scale(Phi, fit$model$scale)[200, ]
  grid <- exp(seq(log(1e-4), log(0.2), length.out = 2000))
  ll <- sapply(grid, function(s) dense_loglik(fit$model$data$Xf, fit$model$data$yf, fit$model$data$Xs, fit$model$data$ys,
                                              replace(map, 10, s)))
  expect_equal(log(cf$dataValue), log(grid[which.max(ll)]), tolerance = 0.05)
  # its suggestion: an inverse gamma with median at that value
  h <- eval(parse(text = FBC:::suggest_prior(fit, 10, cf$priorValue)))
  expect_equal(h$sigma2E$p2 / qgamma(0.5, h$sigma2E$p1), cf$dataValue, tolerance = 0.05)
  expect_snapshot(writeLines(strwrap(FBC:::conflict_messages(fit), 78)))
  # rule 1 alone is not enough: the same draws around 0.5, inside the prior
  Phi[, "sigma2E"] <- exp(qnorm(ppoints(400), log(0.5), 0.25))
  fit$Phi <- Phi
  expect_equal(nrow(FBC:::prior_conflicts(fit)), 0L)
})

test_that("suggestions keep the other members of a class and give the family's centre", {
  fit <- small_fit(nChains = 1, kernelS = "powexp", kernelB = "powexp")  # with smoothness parameters
  j <- match(c("thetaS1", "thetaS2"), fit$vars)
  s <- FBC:::suggest_prior(fit, j[2], 40)
  expect_equal(s, "set_hyperPriors(thetaSDist = c(\"gamma\", \"gamma\"), thetaSP1 = c(1.1, 1.1), thetaSP2 = c(0.1, 0.02), thetaSInit = c(1, 40))")
  h <- eval(parse(text = s))
  expect_equal(qgamma(0.5, 1.1, rate = h$thetaS$p2[2]), 40, tolerance = 0.03) # 2 significant digits
  # two members at once
  s <- FBC:::suggest_prior(fit, j, c(0.01, 40))
  expect_equal(s, "set_hyperPriors(thetaSDist = c(\"gamma\", \"gamma\"), thetaSP1 = c(1.1, 1.1), thetaSP2 = c(79, 0.02), thetaSInit = c(0.01, 40))")
  s <- FBC:::suggest_prior(fit, match("muB", fit$vars), -3)
  expect_equal(s, "set_hyperPriors(muBDist = \"gaussian\", muBP1 = 0, muBP2 = 6, muBInit = -3)")
  s <- FBC:::suggest_prior(fit, match("alphaB1", fit$vars), 1.1)
  expect_equal(s, "set_hyperPriors(alphaBDist = \"uniform\", alphaBP1 = 1, alphaBP2 = 2, alphaBInit = 1.5)")
  # a smoothness the data press to its bound: fix it there
  s <- FBC:::suggest_prior(fit, match("alphaS2", fit$vars), 2, bounds = 2)
  expect_equal(s, "set_hyperPriors(alphaSDist = c(\"betashift\", \"fixed\"), alphaSInit = c(1.9, 2))")
  expect_s3_class(eval(parse(text = s)), "fbc_hypers")
  expect_true(is.na(FBC:::suggest_prior(fit, 1, 0.5)))  # kappa's stretched beta
})

test_that("a smoothness the likelihood pushes to 2 gets the smooth families as advice", {
  fit <- small_fit(nChains = 1, kernelS = "powexp", kernelB = "powexp")
  # a prior_conflicts() row as it comes for alphaS2 at its bound 2
  cf <- data.frame(var = "alphaS2", class = "alphaS", side = "upper", cdf = 0.995,
                   median = 1.99, dataValue = 2, atBound = TRUE, bound = 2, priorValue = 2)
  msg <- FBC:::conflict_messages(fit, cf)
  expect_match(msg, "kernelS = \"matern52\"", fixed = TRUE)
  expect_snapshot(writeLines(strwrap(msg, 78)))
})

test_that("a likelihood rising to a limit (a GP scale going to 0) is reported as such", {
  # every parameter fixed except thetaB1, log-normal around 0.05: in the
  # lower 1% tail of its gamma(1.1, 0.1) prior
  fit <- hand_built_fit("thetaB1", at = c(thetaB1 = 0.05))
  Phi <- fit$Phi
  expect_lt(pgamma(0.05, 1.1, rate = 0.1), 0.01)
  j <- match("thetaB1", fit$model$spec$vars)
  # a likelihood with no peak: -theta / 0.01, whose limit 0 at theta -> 0 it
  # comes within 1 of below theta = 0.01 (5 units above its value at 0.05)
  plateau <- function(fit, phi) -phi[[j]] / 0.01
  cf <- FBC:::prior_conflicts(fit, loglik = plateau)
  expect_equal(cf$var, "thetaB1")
  expect_true(cf$rising)
  expect_equal(cf$dataValue, 0.01, tolerance = 0.01)
  msg <- FBC:::conflict_messages(fit, cf)
  expect_match(msg, "keeps rising towards 0 (it comes within 1 log-likelihood unit of its limit below about 0.01)",
               fixed = TRUE)
  expect_match(msg, "thetaBP2 = 79", fixed = TRUE)  # gamma(1.1) median 0.01: rate qgamma(0.5, 1.1) / 0.01 = 79.03
  # a likelihood that gains less than 2 units beyond the median: no conflict
  creep <- function(fit, phi) -phi[[j]] / 0.05
  expect_equal(nrow(FBC:::prior_conflicts(fit, loglik = creep)), 0L)
  # a likelihood rising to a finite bound (a smoothness to 2) peaks at the
  # bound: it is not reported as rising
  Pb <- Phi
  Pb[, "thetaB1"] <- 0.05
  Pb[, "alphaB1"] <- 1 + plogis(qnorm(ppoints(400), qlogis(0.99), 0.3))
  fitB <- with_draws(fit, Pb)
  ja <- match("alphaB1", fit$model$spec$vars)
  toBound <- function(fit, phi) -500 * (2 - phi[[ja]])
  cf <- FBC:::prior_conflicts(fitB, loglik = toBound)
  expect_equal(cf$var, "alphaB1")
  expect_true(cf$atBound)
  expect_false(cf$rising)
  expect_match(FBC:::conflict_messages(fitB, cf), "peaks at the bound 2", fixed = TRUE)
  # one with a peak (at 0.002) is reported at its peak, not as rising
  peak <- function(fit, phi) -50 * (log(phi[[j]]) - log(0.002))^2
  cf <- FBC:::prior_conflicts(fit, loglik = peak)
  expect_false(cf$rising)
  expect_equal(cf$dataValue, 0.002, tolerance = 0.02)
})

test_that("the conflict check runs once per fit: print(), summary() and convergence_messages() reuse it", {
  d <- small_noise_data(frac = 0.1)
  set.seed(1)
  fit <- calibrate(d$sim, d$field, nMCMC = 400, nBurn = 200, nChains = 2)
  cache <- attr(fit, "cache")
  expect_true(is.environment(cache))
  expect_null(cache$conflictRuns)
  m1 <- convergence_messages(fit)
  capture.output(print(fit), summary(fit), print(fit))
  m2 <- convergence_messages(fit)
  expect_identical(cache$conflictRuns, 1L)
  expect_identical(m1, m2)
  # a copy with other draws is checked afresh (the cache is shared, its key is not)
  fit2 <- with_draws(fit, fit$Phi[rev(seq_len(nrow(fit$Phi))), ])
  convergence_messages(fit2)
  expect_identical(cache$conflictRuns, 2L)
  # the cached rows are prior_conflicts()'s
  expect_identical(FBC:::cached_conflicts(fit2), FBC:::prior_conflicts(fit2))
  # a fit made before the cache (no attribute) still works, checked each time
  old <- fit
  attr(old, "cache") <- NULL
  expect_identical(convergence_messages(old), m1)
})
