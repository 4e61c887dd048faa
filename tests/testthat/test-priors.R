# Every family against R's own density functions (the independent reference).
test_that("each prior family matches R's d* function", {
  x <- c(-1.5, -0.2, 0, 0.05, 0.3, 0.5, 0.99, 1, 1.2, 1.7, 2, 3.5, 12)
  ref <- suppressWarnings(list(
    uniform = list(-1, 2.5, dunif(x, -1, 2.5, log = TRUE)),
    gaussian = list(0.4, 1.7, dnorm(x, 0.4, 1.7, log = TRUE)),
    gamma = list(1.1, 0.1, dgamma(x, shape = 1.1, rate = 0.1, log = TRUE)),
    beta = list(2, 5, dbeta(x, 2, 5, log = TRUE)),
    lognormal = list(0.2, 0.8, dlnorm(x, 0.2, 0.8, log = TRUE)),
    logistic = list(1, 0.5, dlogis(x, 1, 0.5, log = TRUE)),
    betashift = list(5, 2, dbeta(x - 1, 5, 2, log = TRUE)),
    exponential = list(1.3, NA, dexp(x, 1.3, log = TRUE)),
    # X ~ InvGamma(a, b)  <=>  1/X ~ Gamma(a, rate = b): f(x) = g(1/x) / x^2
    inversegamma = list(1.5, 1.5, ifelse(x > 0, dgamma(1 / x, 1.5, rate = 1.5, log = TRUE) - 2 * log(x), -Inf)),
    jeffreys = list(NA, NA, ifelse(x > 0, -log(x), -Inf)),
    fixed = list(NA, NA, rep(0, length(x)))
  ))
  for (fam in names(ref)) {
    r <- ref[[fam]]
    f <- prior_builder(fam, r[[1]], r[[2]])
    expect_equal(f(x), r[[3]], tolerance = 1e-12, info = fam)
  }
})

test_that("the vignette's prior_builder examples hold (section 1.9)", {
  pr <- prior_builder(prior = "beta", p1 = 2, p2 = 5)
  expect_equal(round(exp(pr(c(-1, 0, 0.1, 0.5, 0.9, 1, 2))), 3),
               c(0.000, 0.000, 1.968, 0.938, 0.003, 0.000, 0.000))
  pr <- prior_builder(prior = "uniform", p1 = -10, p2 = 10)
  expect_equal(round(exp(pr(c(-11, -5, 0, 4, 10, 12))), 3),
               c(0.00, 0.05, 0.05, 0.05, 0.05, 0.00))
  pr <- prior_builder(prior = "gaussian", p1 = 1, p2 = 2)
  expect_equal(round(exp(pr(c(-9, -5, -3, -1, 1, 3, 5, 7, 11))), 3),
               c(0.000, 0.002, 0.027, 0.121, 0.199, 0.121, 0.027, 0.002, 0.000))
})

test_that("prior_builder refuses unknown families and impossible parameters", {
  expect_snapshot(error = TRUE, prior_builder("cauchy", 0, 1))
  expect_snapshot(error = TRUE, prior_builder("uniform", 2, 1))
  expect_snapshot(error = TRUE, prior_builder("gamma", -1, 1))
  expect_snapshot(error = TRUE, prior_builder("gaussian", 0, 0))
  expect_snapshot(error = TRUE, prior_builder("exponential", 0))
})

test_that("set_hyperPriors() gives the vignette's A.1 defaults", {
  h <- set_hyperPriors()
  expect_s3_class(h, "fbc_hypers")
  expect_equal(h$thetaS[c("dist", "p1", "p2")], list(dist = "gamma", p1 = 1.1, p2 = 0.1))
  expect_equal(h$thetaB[c("dist", "p1", "p2")], list(dist = "gamma", p1 = 1.1, p2 = 0.1))
  expect_equal(h$alphaS[c("dist", "p1", "p2")], list(dist = "betashift", p1 = 5, p2 = 2))
  for (v in c("sigma2S", "sigma2B", "sigma2E")) {
    expect_equal(h[[v]][c("dist", "p1", "p2")], list(dist = "inversegamma", p1 = 1.5, p2 = 1.5))
  }
  expect_equal(h$muB[c("dist", "p1", "p2")], list(dist = "gaussian", p1 = 0, p2 = 1))
  expect_output(print(h), "thetaS")
})

test_that("set_hyperPriors() refuses priors that do not fit the parameter", {
  expect_snapshot(error = TRUE, set_hyperPriors(sigma2EDist = "gaussian"))
  expect_snapshot(error = TRUE, set_hyperPriors(alphaSDist = "gamma"))
  expect_snapshot(error = TRUE, set_hyperPriors(thetaBDist = "uniform", thetaBP1 = -1, thetaBP2 = 3))
  expect_snapshot(error = TRUE, set_hyperPriors(alphaBDist = "uniform", alphaBP1 = 0.5, alphaBP2 = 2))
  expect_snapshot(error = TRUE, set_hyperPriors(sigma2SDist = "inversegamma", sigma2SP1 = 0))
  expect_snapshot(error = TRUE, set_hyperPriors(alphaSInit = 2))
  expect_snapshot(error = TRUE, set_hyperPriors(thetaSInit = -1))
  expect_snapshot(error = TRUE, set_hyperPriors(muBDist = "fixed", muBInit = NA))
  expect_snapshot(error = TRUE, set_hyperPriors(thetaSDist = c("gamma", "gamma"), thetaSInit = c(1, 2, 3)))
  # allowed: a fixed Gaussian correlation, a beta prior on a scale (vignette 1.5)
  expect_silent(set_hyperPriors(alphaSDist = "fixed", alphaSInit = 2))
  expect_silent(set_hyperPriors(thetaSDist = "beta", thetaSP1 = 1.1, thetaSP2 = 6, thetaSInit = 0.5))
})

test_that("a prior family switched without its own parameters is refused, naming them", {
  # the defaults belong to the default family: gamma's (1.1, 0.1) as a
  # lognormal would be a different prior than the user thinks
  expect_snapshot(error = TRUE, {
    set_hyperPriors(thetaSDist = "lognormal")
    set_hyperPriors(thetaSDist = "beta", thetaSP2 = 6, thetaSInit = 0.5)
    set_hyperPriors(sigma2EDist = "exponential")
    set_hyperPriors(muBDist = c("gaussian", "logistic"))
    calibrate(ballSim, ballField, kappaDist = "gaussian")
    calibrate(ballSim, ballField, kappaDist = "uniform", kappaP1 = 7)
    calibrate(unname(ballSim), unname(ballField), kappaDist = "gaussian", kappaP2 = 1)
  })
  # given its parameters, the family is used as given
  h <- set_hyperPriors(sigma2EDist = "exponential", sigma2EP1 = 2)
  expect_identical(h$sigma2E[c("dist", "p1")], list(dist = "exponential", p1 = 2))
  h <- set_hyperPriors(sigma2EDist = "jeffreys")  # no parameters to give
  expect_identical(h$sigma2E$dist, "jeffreys")
  # the default family named explicitly keeps its defaults
  expect_identical(set_hyperPriors(thetaSDist = "gamma"), set_hyperPriors())
  set.seed(1)
  fit <- calibrate(ballSim, ballField, nMCMC = 40, nBurn = 20, nChains = 1,
                   kappaDist = "gaussian", kappaP1 = 9.8, kappaP2 = 1)
  # N(9.8, 1) in g's units, not the Beta's 1.1, 1.1
  expect_equal(fit$priorFns$kappa1(c(8, 10)), dnorm(c(8, 10), 9.8, 1, log = TRUE))
})
