# Every test inspects the ggplot objects (layers, data); nothing is drawn.
fit_for_plots <- function() {
  set.seed(9)
  calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, thinning = 2, nChains = 1)
}

test_that("density plot: posterior, prior in reported units, mode; one facet per parameter", {
  fit <- fit_for_plots()
  p <- plot(fit)
  expect_s3_class(p, "ggplot")
  geoms <- vapply(p$layers, function(l) class(l$geom)[1], character(1), USE.NAMES = FALSE)
  expect_identical(geoms, c("GeomArea", "GeomLine", "GeomVline"))
  post <- ggplot2::layer_data(p, 1)
  # the posterior curve is a density estimate of the kappa draws (integrates
  # to ~1), inside g's prior range: the simulator design's
  expect_equal(sum(diff(post$x) * head(post$y, -1)), 1, tolerance = 0.02)
  g <- range(ballSim[, "g"])
  d <- FBC:::support_density(fit$Phi[, "kappa1"], g[1], g[2])
  expect_equal(post$x, d$x)
  expect_equal(post$y, d$y)
  expect_true(all(post$x >= g[1] & post$x <= g[2]))
  # labels in the data's own names
  expect_identical(levels(p$layers[[1]]$data$parameter), "g (kappa1)")
  expect_identical(p$labels$x, "g")
  prior <- ggplot2::layer_data(p, 2)
  expect_equal(prior$y, exp(fit$priorFns$kappa1(prior$x)))
  # stretched Beta(1.1, 1.1) over the design range of g, by hand
  lo <- min(ballSim[, 3]); hi <- max(ballSim[, 3])
  inside <- prior$x > lo & prior$x < hi
  expect_equal(prior$y[inside], dbeta((prior$x[inside] - lo) / (hi - lo), 1.1, 1.1) / (hi - lo))
  expect_equal(ggplot2::layer_data(p, 3)$xintercept, fit$estimates["kappa1", "mode"])

  p2 <- plot(fit, "thetaS")
  expect_equal(nrow(ggplot2::ggplot_build(p2)$layout$layout), 2)
  expect_equal(sort(unique(as.character(p2$layers[[3]]$data$parameter))),
               c("thetaS1 (h)", "thetaS2 (g)"))
  expect_match(p2$labels$x, "scaled space")
  pr2 <- p2$layers[[2]]$data
  th1 <- pr2[pr2$parameter == "thetaS1 (h)", ]
  expect_equal(th1$density, dgamma(th1$value, 1.1, 0.1))  # default gamma(1.1, 0.1) prior
})

test_that("trace plot has one facet per parameter and the draws in order", {
  fit <- fit_for_plots()
  p <- plot(fit, parameter = "thetaS", type = "trace")
  expect_identical(class(p$layers[[1]]$geom)[1], "GeomLine")
  df <- p$data
  expect_equal(nrow(df), 2 * nrow(fit$Phi))
  expect_equal(df$value[df$parameter == "thetaS2 (g)"], unname(fit$Phi[, "thetaS2"]))
  expect_equal(df$draw[df$parameter == "thetaS2 (g)"], seq_len(nrow(fit$Phi)))
  # the same labels as the density plot
  expect_identical(levels(df$parameter), levels(plot(fit, "thetaS")$layers[[1]]$data$parameter))
  pk <- plot(fit, type = "trace")
  expect_identical(levels(pk$data$parameter), "g (kappa1)")
  expect_identical(pk$labels$y, "g")
  expect_equal(nrow(ggplot2::ggplot_build(p)$layout$layout), 2)
})

test_that("fits plot: field data, MAP fits and 95% intervals against each input", {
  fit <- fit_for_plots()
  p <- plot(fit, type = "fits", xlab = "height")
  geoms <- vapply(p$layers, function(l) class(l$geom)[1], character(1), USE.NAMES = FALSE)
  expect_identical(geoms, c("GeomLinerange", "GeomPoint", "GeomPoint"))
  df <- p$data
  expect_equal(df$x, unname(ballField[, "h"]))
  expect_equal(df$observed, unname(ballField[, "t"]))
  map <- predict(fit, ballField[, "h"], method = "MAP")
  expect_equal(df$fitted, map$pred)
  expect_equal(ggplot2::layer_data(p, 1)$ymax, map$upper)
  expect_identical(levels(df$input), "height")
  expect_identical(levels(plot(fit, type = "fits")$data$input), "h")  # default: column name
})

test_that("unknown classes, types and bad xlab are clear errors", {
  fit <- fit_for_plots()
  expect_snapshot(error = TRUE, {
    plot(fit, parameter = "gamma")
    plot(fit, type = "histogram")
    plot(fit, type = "fits", xlab = c("a", "b"))
  })
})

test_that("unknown plot arguments are refused", {
  fit <- fit_for_plots()
  expect_snapshot(error = TRUE, {
    plot(fit, paramter = "thetaS")
    plot(fit, main = "g")
  })
})

test_that("the density respects the support: reflected at finite bounds, zero outside", {
  # reference: the reflected Gaussian-kernel estimate written out as a sum
  set.seed(4)
  draws <- rbeta(3000, 1, 4)  # piles up at its bound 0
  d <- FBC:::support_density(draws, 0, 1)
  expect_true(all(d$x >= 0 & d$x <= 1))
  expect_equal(d$x[1], 0)
  # trapezoid rule over the support: the mass reflected back is not lost
  expect_equal(sum(diff(d$x) * (head(d$y, -1) + tail(d$y, -1)) / 2), 1, tolerance = 0.005)
  bw <- bw.nrd0(draws)
  direct <- vapply(d$x, function(v) {
    mean(dnorm(v, draws, bw) + dnorm(2 * 0 - v, draws, bw) + dnorm(2 * 1 - v, draws, bw))
  }, numeric(1))
  expect_equal(d$y, direct, tolerance = 0.01)
  # near the bound the plain estimate loses half its mass; this one does not
  expect_gt(d$y[1], 0.9 * dbeta(0.01, 1, 4))
  # one finite bound (a variance): reflected at 0 only
  v <- rexp(2000)
  d1 <- FBC:::support_density(v, 0, Inf)
  expect_equal(d1$x[1], 0)
  expect_equal(sum(diff(d1$x) * (head(d1$y, -1) + tail(d1$y, -1)) / 2), 1, tolerance = 0.005)
})

test_that("a posterior pressed against its prior bound is drawn inside it", {
  # g's prior U(6, 9) excludes free fall's 9.81: the draws pile up at 9
  set.seed(9)
  fit <- calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, thinning = 2, nChains = 1,
                   kappaDist = "uniform", kappaP1 = 6, kappaP2 = 9)
  post <- ggplot2::layer_data(plot(fit), 1)
  expect_lte(max(post$x), 9)
  expect_gte(min(post$x), 6)
  expect_equal(sum(diff(post$x) * (head(post$y, -1) + tail(post$y, -1)) / 2), 1, tolerance = 0.01)
  # the plain estimate would spill past 9
  expect_gt(max(stats::density(fit$Phi[, "kappa1"])$x), 9)
})

test_that("a fixed parameter is shown as its value; an improper prior is not drawn", {
  # print()'s advice for alphaS at 2, followed; sigma2E under Jeffreys' 1/x
  set.seed(9)
  fit <- calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, thinning = 2, nChains = 1,
                   hypers = set_hyperPriors(alphaSDist = "fixed", alphaSInit = 2,
                                            sigma2EDist = "jeffreys", sigma2EInit = 0.2),
                   kernelS = "powexp", kernelB = "powexp")
  p <- plot(fit, "alphaS")
  expect_identical(levels(p$layers[[3]]$data$parameter),
                   c("alphaS1 (h), fixed at 2", "alphaS2 (g), fixed at 2"))
  expect_equal(nrow(p$layers[[1]]$data), 0)  # no posterior density
  expect_equal(nrow(p$layers[[2]]$data), 0)  # no prior density
  expect_equal(ggplot2::layer_data(p, 3)$xintercept, c(2, 2))
  expect_identical(p$labels$caption, "alphaS1, alphaS2: fixed, no density.")
  expect_equal(nrow(ggplot2::ggplot_build(p)$layout$layout), 2)
  expect_s3_class(plot(fit, "alphaS", type = "trace"), "ggplot")

  pe <- plot(fit, "sigma2E")
  expect_gt(nrow(ggplot2::layer_data(pe, 1)), 0)  # the posterior is drawn
  expect_equal(nrow(pe$layers[[2]]$data), 0)      # 1/x is not a density
  expect_identical(pe$labels$caption, "sigma2E: improper jeffreys prior, not drawn.")
  expect_null(plot(fit, "sigma2S")$labels$caption)
})

test_that("fits plot: a row of panels per output and field data set", {
  # With source = the data sets were overlaid in one panel
  set.seed(3)
  x <- runif(30); t <- runif(30, 0.5, 3)
  sim <- rbind(data.frame(y = 5 * exp(-t * x), x = x, out = "conc", t = t),
               data.frame(y = 2 * t * x, x = x, out = "rate", t = t))
  xf <- seq(0.05, 0.95, length.out = 8)
  field <- rbind(data.frame(y = 5 * exp(-1.7 * xf) + rnorm(8, 0, 0.05), x = xf, out = "conc",
                            lab = rep(c("A", "B"), 4)),
                 data.frame(y = 3.4 * xf + rnorm(8, 0, 0.05), x = xf, out = "rate", lab = "A"))
  set.seed(1)
  fit <- calibrate(sim, field, output = "out", outputs = "shared", source = "lab", nMCMC = 120, nBurn = 60,
                   nChains = 1, kernelS = "matern52", kernelB = "matern52")
  p <- plot(fit, type = "fits")
  expect_identical(levels(p$data$output), c("conc, lab A", "conc, lab B", "rate, lab A"))
  expect_identical(as.character(p$data$output),
                   paste0(field$out, ", lab ", field$lab))
  expect_s3_class(p$facet, "FacetGrid")
  expect_no_error(ggplot2::ggplot_build(p))
  # data sets alone
  ball <- data.frame(ballField, lab = rep(c("A", "B"), length.out = nrow(ballField)))
  fit2 <- calibrate(ballSim, ball, source = "lab", nMCMC = 60, nBurn = 30, nChains = 1)
  expect_identical(levels(plot(fit2, type = "fits")$data$output), c("lab A", "lab B"))
})

test_that("plot(type = \"failure\") maps the probability of failure over two inputs", {
  s <- ballSim
  s[s[, "g"] > 11 & s[, "h"] > 2.5, 1] <- NA
  set.seed(7)
  fit <- suppressMessages(calibrate(s, ballField, nMCMC = 100, nBurn = 50, nChains = 1,
                                    showProgress = FALSE))
  p <- plot(fit, type = "failure", inputs = c("g", "h"))
  expect_s3_class(p, "ggplot")
  d <- ggplot2::layer_data(p, 1)
  expect_equal(nrow(d), 3600L)
  # the failed corner (g > 11, h > 2.5) is likelier to fail than the opposite one
  hi <- p$data$p[p$data$a > 12 & p$data$b > 3.2]
  lo <- p$data$p[p$data$a < 8 & p$data$b < 1.5]
  expect_gt(mean(hi), 0.7)
  expect_lt(mean(lo), 0.2)
  expect_equal(sum(ggplot2::layer_data(p, 2)$shape == 4), sum(is.na(s[, 1])))
  expect_snapshot(plot(fit, type = "failure", inputs = c("g", "kappa")), error = TRUE)
  set.seed(7)
  clean <- calibrate(ballSim, ballField, nMCMC = 100, nBurn = 50, nChains = 1, showProgress = FALSE)
  expect_snapshot(plot(clean, type = "failure"), error = TRUE)
})
