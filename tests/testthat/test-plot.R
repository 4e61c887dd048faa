# Every test inspects the ggplot objects (layers, data); nothing is drawn.
fit_for_plots <- function() {
  set.seed(9)
  calibrate(ballSim, ballField, nMCMC = 300, nBurn = 100, thinning = 2, nChains = 1)
}

test_that("density plot: posterior, prior in reported units, mode; one facet per parameter", {
  fit <- fit_for_plots()
  p <- plot(fit)
  expect_s3_class(p, "ggplot")
  geoms <- vapply(p$layers, function(l) class(l$geom)[1], character(1))
  expect_identical(geoms, c("GeomArea", "GeomLine", "GeomVline"))
  post <- ggplot2::layer_data(p, 1)
  # the posterior curve is a density estimate of the kappa draws (integrates to ~1)
  expect_equal(sum(diff(post$x) * head(post$y, -1)), 1, tolerance = 0.02)
  d <- stats::density(fit$Phi[, "kappa1"], n = 256)
  expect_equal(post$x, d$x)
  prior <- ggplot2::layer_data(p, 2)
  expect_equal(prior$y, exp(fit$priorFns$kappa1(prior$x)))
  # stretched Beta(1.1, 1.1) over the design range of g, by hand
  lo <- min(ballSim[, 3]); hi <- max(ballSim[, 3])
  inside <- prior$x > lo & prior$x < hi
  expect_equal(prior$y[inside], dbeta((prior$x[inside] - lo) / (hi - lo), 1.1, 1.1) / (hi - lo))
  expect_equal(ggplot2::layer_data(p, 3)$xintercept, fit$estimates["kappa1", "mode"])

  p2 <- plot(fit, "thetaS")
  expect_equal(nrow(ggplot2::ggplot_build(p2)$layout$layout), 2)
  expect_equal(sort(unique(as.character(p2$layers[[3]]$data$parameter))), c("thetaS1", "thetaS2"))
  pr2 <- p2$layers[[2]]$data
  th1 <- pr2[pr2$parameter == "thetaS1", ]
  expect_equal(th1$density, dgamma(th1$value, 1.1, 0.1))  # default gamma(1.1, 0.1) prior
})

test_that("trace plot has one facet per parameter and the draws in order", {
  fit <- fit_for_plots()
  p <- plot(fit, parameter = "alphaS", type = "trace")
  expect_identical(class(p$layers[[1]]$geom)[1], "GeomLine")
  df <- p$data
  expect_equal(nrow(df), 2 * nrow(fit$Phi))
  expect_equal(df$value[df$parameter == "alphaS2"], unname(fit$Phi[, "alphaS2"]))
  expect_equal(df$draw[df$parameter == "alphaS2"], seq_len(nrow(fit$Phi)))
  expect_equal(nrow(ggplot2::ggplot_build(p)$layout$layout), 2)
})

test_that("fits plot: field data, MAP fits and 95% intervals against each input", {
  fit <- fit_for_plots()
  p <- plot(fit, type = "fits", xlab = "height")
  geoms <- vapply(p$layers, function(l) class(l$geom)[1], character(1))
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
