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
    fixed = list(NA, NA, rep(0, length(x))),
    # sd = sqrt(X) half-Cauchy(scale s): f(x) = 2 / (pi s (1 + x / s^2)) * 1 / (2 sqrt(x))
    halft_sd = list(1, 0.5, ifelse(x > 0, -log(pi * 0.5 * sqrt(x) * (1 + x / 0.25)), -Inf))
  ))
  expect_setequal(names(ref), names(FBC:::prior_registry))
  for (fam in names(ref)) {
    r <- ref[[fam]]
    f <- prior_builder(fam, r[[1]], r[[2]])
    expect_equal(f(x), r[[3]], tolerance = 1e-12, info = fam)
  }
})

test_that("the registry's family codes are the compiled core's", {
  expect_identical(FBC:::.prior_codes(), FBC:::prior_families)
  expect_true(FBC:::check_prior_codes())
  # fits store the codes: they are those of every earlier version
  expect_identical(unname(FBC:::prior_families), 1:12)
  # a table that drifted is refused, naming the families that differ
  expect_snapshot(error = TRUE, {
    FBC:::check_prior_codes(replace(FBC:::.prior_codes(), "gamma", 12L))
    FBC:::check_prior_codes(FBC:::.prior_codes()[-11])
  })
  expect_error(FBC:::.log_prior(1, 13L, 0, 1), "unknown prior family code 13")
})

# Parameters for every family (those of the d* test above).
family_pars <- list(uniform = c(-1, 2.5), gaussian = c(0.4, 1.7), gamma = c(1.1, 0.1),
                    beta = c(2, 5), lognormal = c(0.2, 0.8), logistic = c(1, 0.5),
                    betashift = c(5, 2), exponential = c(1.3, NA), inversegamma = c(1.5, 1.5),
                    jeffreys = c(NA, NA), fixed = c(NA, NA), halft_sd = c(3, 0.5))

test_that("each proper family's cdf and quantile invert each other and match its density", {
  reg <- FBC:::prior_registry
  expect_setequal(names(family_pars), names(reg))
  expect_identical(names(Filter(function(f) !f$proper, reg)), c("jeffreys", "fixed"))
  u <- c(0.001, 0.1, 0.37, 0.5, 0.9, 0.999)
  for (fam in names(Filter(function(f) f$proper, reg))) {
    p <- family_pars[[fam]]
    q <- FBC:::prior_quantile(u, fam, p[1], p[2])
    expect_equal(FBC:::prior_cdf(q, fam, p[1], p[2]), u, tolerance = 1e-10, info = fam)
    # the mass between two quantiles, integrating the compiled density: the
    # cdf is in the units (rate, scale) the sampler's density uses
    f <- prior_builder(fam, p[1], p[2])
    mass <- integrate(function(x) exp(f(x)), q[2], q[5], rel.tol = 1e-10)$value
    expect_equal(mass, 0.8, tolerance = 1e-8, info = fam)
  }
  expect_identical(FBC:::prior_cdf(1, "jeffreys", NA, NA), NA_real_)
  expect_identical(FBC:::prior_quantile(0.5, "fixed", NA, NA), NA_real_)
})

test_that("each family's support is where its compiled density is finite", {
  eps <- 1e-6
  for (fam in setdiff(names(family_pars), "fixed")) {
    p <- family_pars[[fam]]
    s <- FBC:::family_support(fam, p[1], p[2])
    f <- prior_builder(fam, p[1], p[2])
    inside <- c(if (is.finite(s[1])) s[1] + eps else -1e3,
                if (is.finite(s[2])) s[2] - eps else 1e3)
    expect_true(all(is.finite(f(inside))), info = fam)
    outside <- c(s[1] - eps, s[2] + eps)[is.finite(s)]
    expect_equal(f(outside), rep(-Inf, length(outside)), info = fam)
    # the default start lies inside too
    expect_true(is.finite(f(FBC:::prior_center(fam, p[1], p[2]))), info = fam)
  }
  # fixed: log density 0 everywhere, no start of its own
  expect_equal(FBC:::family_support("fixed", NA, NA), c(-Inf, Inf))
  expect_identical(FBC:::prior_center("fixed", NA, NA), NA_real_)
})

test_that("the registry's parameter names are those of prior_builder()'s help table", {
  rd <- paste(as.character(tools::Rd_db("FBC")[["prior_builder.Rd"]]), collapse = "")
  for (fam in names(FBC:::prior_registry)) {
    row <- regmatches(rd, regexpr(sprintf('\\\\code\\{"%s"\\}[^\n]*', fam), rd))
    cells <- trimws(strsplit(row, "\\\\tab")[[1]][-1])
    expect_length(cells, 2)
    params <- FBC:::prior_registry[[fam]]$params
    for (k in 1:2) {
      want <- params[paste0("p", k)]
      if (is.na(want)) want <- "(unused)"
      # the cell starts with the name as a whole word
      expect_identical(substr(cells[k], 1, nchar(want)), unname(want), info = fam)
      expect_false(grepl("^[[:alnum:]]", substring(cells[k], nchar(want) + 1)), info = fam)
    }
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

test_that("halft_sd: the sd is half-t, in closed form for the half-Cauchy and through dt() for df = 3", {
  x <- c(1e-6, 0.01, 0.3, 2, 50)
  # P(X <= x) = P(sd <= sqrt(x)) = (2 / pi) atan(sqrt(x) / s) for the half-Cauchy
  expect_equal(FBC:::prior_cdf(x, "halft_sd", 1, 2), 2 / pi * atan(sqrt(x) / 2), tolerance = 1e-12)
  # df = 3: the density of the sd, 2 dt(s / scale, 3) / scale, times ds/dx = 1 / (2 sqrt(x))
  f <- prior_builder("halft_sd", 3, 0.5)
  expect_equal(exp(f(x)), 2 * dt(sqrt(x) / 0.5, 3) / 0.5 / (2 * sqrt(x)), tolerance = 1e-12)
  # proper: the density of the variance integrates to 1 over (0, Inf)
  expect_equal(integrate(function(v) exp(f(v)), 0, Inf, rel.tol = 1e-10)$value, 1, tolerance = 1e-7)
})

test_that("the default noise prior is the half-Cauchy on the sd; the vignette's is kept by name", {
  h <- set_hyperPriors()
  expect_equal(h$sigma2E[c("dist", "p1", "p2")], list(dist = "halft_sd", p1 = 1, p2 = 1))
  v <- set_hyperPriors(sigma2EDist = "inversegamma", sigma2EP1 = 1.5, sigma2EP2 = 1.5)
  expect_equal(v$sigma2E[c("dist", "p1", "p2")], list(dist = "inversegamma", p1 = 1.5, p2 = 1.5))
  # the reason (?set_hyperPriors): the inverse gamma puts almost no mass on a
  # noise sd below a tenth of the response's, the half-Cauchy about 6%
  expect_lt(FBC:::prior_cdf(0.1^2, "inversegamma", 1.5, 1.5), 1e-40)
  expect_equal(FBC:::prior_cdf(0.1^2, "halft_sd", 1, 1), 2 / pi * atan(0.1))
})

test_that("set_hyperPriors() gives the vignette's A.1 defaults (but the noise's)", {
  h <- set_hyperPriors()
  expect_s3_class(h, "fbc_hypers")
  expect_equal(h$thetaS[c("dist", "p1", "p2")], list(dist = "gamma", p1 = 1.1, p2 = 0.1))
  expect_equal(h$thetaB[c("dist", "p1", "p2")], list(dist = "gamma", p1 = 1.1, p2 = 0.1))
  expect_equal(h$alphaS[c("dist", "p1", "p2")], list(dist = "betashift", p1 = 5, p2 = 2))
  for (v in c("sigma2S", "sigma2B")) {
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

test_that("printed priors show each family with its own parameters", {
  expect_snapshot(print(set_hyperPriors()))
  # switched to families that take no parameters: the default family's are not shown
  h <- set_hyperPriors(alphaSDist = "fixed", alphaSInit = 2, sigma2EDist = "jeffreys",
                       sigma2EInit = 0.2, thetaSDist = "lognormal", thetaSP1 = 0, thetaSP2 = 2,
                       thetaSInit = NA, thetaBDist = c("gamma", "fixed"), thetaBInit = c(1, 0.5))
  out <- capture.output(print(h))
  expect_identical(grep("alphaS", out, value = TRUE), "  alphaS   fixed at 2")
  expect_identical(grep("sigma2E", out, value = TRUE), "  sigma2E  jeffreys (improper), init 0.2")
  expect_identical(grep("thetaS", out, value = TRUE),
                   "  thetaS   lognormal(meanlog 0, sdlog 2), init default")
  expect_identical(grep("thetaB", out, value = TRUE),
                   "  thetaB   [1] gamma(shape 1.1, rate 0.1), init 1; [2] fixed at 0.5")
})

test_that("prior_family_name() gives the registry's name of each code", {
  codes <- FBC:::prior_families
  expect_identical(FBC:::prior_family_name(unname(codes)), names(codes))
  expect_identical(FBC:::prior_family_name(rev(unname(codes))), rev(names(codes)))
  expect_identical(FBC:::prior_family_name(c(codes[["beta"]], -99L)), c("beta", NA))
})

test_that("a class a user adds is not in the priors without a family, and its other arguments need one", {
  # set_hyperPriors() as it would be with such a class (over "asked",
  # default family NULL) in the table
  tbl <- FBC:::model_classes
  extra <- tbl[tbl$class == "muB", ]
  extra$class <- "extra"
  extra$over <- "asked"
  tbl <- rbind(tbl, extra)
  # (its priors with a family are checked as every class's, by functions
  # that read the package's table: not reached here)
  cp <- c(FBC:::class_priors, list(extra = list(prior = alist(NULL, NA, 0, 1), help = "An extra.")))
  env <- list2env(list(model_classes = tbl, param_classes = tbl$class, class_priors = cp,
                       class_domain = stats::setNames(tbl$domain, tbl$class)),
                  parent = asNamespace("FBC"))
  shp <- FBC::set_hyperPriors
  formals(shp) <- c(formals(shp), stats::setNames(cp$extra$prior, paste0("extra", c("Dist", "Init", "P1", "P2"))))
  environment(shp) <- env
  expect_identical(unclass(shp()), unclass(set_hyperPriors()))
  expect_null(shp(muBP2 = 2)$extra)
  expect_snapshot(error = TRUE, shp(extraP1 = 1, extraInit = 0.5))
})
