# References: dense_predict() (helper-predict.R) is the GP conditional written
# with the dense joint covariance of helper-dense.R and base R's solve(); the
# Bayesian combination is the law of total variance written out in plain R.

scaled_new <- function(X, sc) sweep(sweep(X, 2, sc$xmin[1:2]), 2, sc$xmax[1:2] - sc$xmin[1:2], "/")
Xnew <- matrix(c(1, 5, 9, 2, 10, -4.5, -4.9, -4.1, -4.6, -4.2), 5)

test_that("with every parameter fixed, predict() is the dense GP conditional (all types, both methods)", {
  set.seed(3)
  phi <- random_phi(2, 1)
  fit <- fixed_fit(phi)
  sc <- fit$model$scale
  expect_true(all(apply(fit$Phi, 2, stats::var) == 0))
  for (type in c("field", "mean", "simulator", "bias")) {
    ref <- dense_predict(fit$model$data$Xf, fit$model$data$yf, fit$model$data$Xs, fit$model$data$ys, phi,
                         scaled_new(Xnew, sc), type)
    shift <- if (type == "bias") 0 else sc$ymean
    for (method in c("Bayesian", "MAP")) {
      pr <- predict(fit, Xnew, method = method, type = type)
      expect_equal(pr$pred, shift + sc$ysd * ref$mean, tolerance = 1e-8)
      expect_equal(pr$se, sc$ysd * sqrt(ref$var), tolerance = 1e-8)
      # one Gaussian: the mixture quantiles are the Gaussian ones
      expect_equal(pr$lower, pr$pred - qnorm(0.975) * pr$se, tolerance = 1e-8)
      expect_equal(pr$upper, pr$pred + qnorm(0.975) * pr$se, tolerance = 1e-8)
    }
  }
})

test_that("every correlation family: predict() is the dense GP conditional", {
  # dense_predict() with the families of ?correlation written in plain R
  set.seed(4)
  phi <- random_phi(2, 1)
  for (kk in list(c("gaussian", "matern32"), c("matern52", "gaussian"),
                  c("matern32", "matern52"))) {
    fit <- fixed_fit(phi, kernelS = kk[1], kernelB = kk[2])
    sc <- fit$model$scale
    # the smoothness is not a parameter: no alpha columns
    expect_false(any(grepl("^alpha", colnames(fit$Phi))))
    for (type in c("field", "simulator", "bias")) {
      ref <- dense_predict(fit$model$data$Xf, fit$model$data$yf, fit$model$data$Xs, fit$model$data$ys, phi,
                           scaled_new(Xnew, sc), type, kernS = kk[1], kernB = kk[2])
      shift <- if (type == "bias") 0 else sc$ymean
      pr <- predict(fit, Xnew, method = "MAP", type = type)
      expect_equal(pr$pred, shift + sc$ysd * ref$mean, tolerance = 1e-8)
      expect_equal(pr$se, sc$ysd * sqrt(ref$var), tolerance = 1e-8)
    }
  }
})

test_that("without a discrepancy predict() is the dense GP conditional; the bias is exactly 0", {
  # dense_predict(discrepancy = "none"): no bias block, no muB
  set.seed(6)
  phi <- random_phi(2, 1, "none")
  fit <- fixed_fit(phi, discrepancy = "none")
  sc <- fit$model$scale
  expect_identical(colnames(fit$Phi), c("kappa1", "thetaS1", "thetaS2", "thetaS3", "alphaS1",
                                        "alphaS2", "alphaS3", "sigma2S", "sigma2E"))
  out <- list()
  for (type in c("field", "mean", "simulator", "bias")) {
    ref <- dense_predict(fit$model$data$Xf, fit$model$data$yf, fit$model$data$Xs, fit$model$data$ys, phi,
                         scaled_new(Xnew, sc), type, discrepancy = "none")
    shift <- if (type == "bias") 0 else sc$ymean
    out[[type]] <- pr <- predict(fit, Xnew, method = "MAP", type = type)
    expect_equal(pr$pred, shift + sc$ysd * ref$mean, tolerance = 1e-8)
    expect_equal(pr$se, sc$ysd * sqrt(ref$var), tolerance = 1e-8)
  }
  expect_identical(out$bias$pred, rep(0, 5))
  expect_identical(out$bias$se, rep(0, 5))
  expect_equal(out$mean, out$simulator, tolerance = 1e-12)
  # the field adds the measurement error variance (scaled space: sigma2E)
  expect_equal(out$field$se^2, out$mean$se^2 + sc$ysd^2 * phi[length(phi)], tolerance = 1e-10)
})

test_that("under the S-GaSP predict() is the dense GP conditional with the discretized kernel", {
  # dense_predict(discrepancy = "sgasp"): bias mean 0, covariances from
  # Kz(x, x') = R(x, x') - R(x, U) (R(U, U) + nu / lambdaZ I)^-1 R(U, x')
  set.seed(7)
  phi <- random_phi(2, 1, "sgasp")
  fit <- fixed_fit(phi, discrepancy = "sgasp")
  sc <- fit$model$scale
  expect_identical(colnames(fit$Phi), c("kappa1", "thetaS1", "thetaS2", "thetaS3", "alphaS1",
                                        "alphaS2", "alphaS3", "thetaB1", "thetaB2", "alphaB1",
                                        "alphaB2", "lambdaZ", "sigma2S", "sigma2B", "sigma2E"))
  Xn <- rbind(Xnew, c(10 * fit$model$data$Xf[1, 1], fit$model$data$Xf[1, 2] - 5))  # on a field input
  for (type in c("field", "mean", "simulator", "bias")) {
    ref <- dense_predict(fit$model$data$Xf, fit$model$data$yf, fit$model$data$Xs, fit$model$data$ys, phi,
                         scaled_new(Xn, sc), type, discrepancy = "sgasp")
    shift <- if (type == "bias") 0 else sc$ymean
    for (method in c("Bayesian", "MAP")) {
      pr <- predict(fit, Xn, method = method, type = type)
      expect_equal(pr$pred, shift + sc$ysd * ref$mean, tolerance = 1e-8)
      expect_equal(pr$se, sc$ysd * sqrt(ref$var), tolerance = 1e-8)
    }
  }
})

test_that("the Bayesian method combines per-draw conditionals by total variance and mixture quantiles", {
  set.seed(3)
  phi <- random_phi(2, 1)
  fit <- fixed_fit(phi)
  sc <- fit$model$scale
  # replace the draws by 4 different parameter vectors (kappa in native units)
  set.seed(8)
  phis <- rbind(phi, t(replicate(3, random_phi(2, 1))))
  Phi <- phis
  Phi[, 1] <- sc$xmin[3] + phis[, 1] * (sc$xmax[3] - sc$xmin[3])
  colnames(Phi) <- colnames(fit$Phi)
  fit <- fit_with_draws(fit, Phi, logPost = c(-3, -1, -7, -2))
  Xn <- scaled_new(Xnew, sc)
  for (type in c("field", "bias")) {
    shift <- if (type == "bias") 0 else sc$ymean
    refs <- lapply(seq_len(4), function(i) {
      dense_predict(fit$model$data$Xf, fit$model$data$yf, fit$model$data$Xs, fit$model$data$ys, phis[i, ], Xn, type)
    })
    m <- shift + sc$ysd * sapply(refs, `[[`, "mean")
    s <- sc$ysd * sqrt(sapply(refs, `[[`, "var"))
    pr <- predict(fit, Xnew, type = type, draws = TRUE, level = 0.9)
    expect_equal(pr$draws, m, tolerance = 1e-8, ignore_attr = TRUE)
    expect_equal(pr$pred, rowMeans(m), tolerance = 1e-8)
    expect_equal(pr$se, sqrt(rowMeans(s^2) + apply(m, 1, var)), tolerance = 1e-8)
    # the bounds solve mean_i Phi((y - m_i) / s_i) = 0.05, 0.95
    expect_equal(rowMeans(pnorm((pr$lower - m) / s)), rep(0.05, 5), tolerance = 1e-7)
    expect_equal(rowMeans(pnorm((pr$upper - m) / s)), rep(0.95, 5), tolerance = 1e-7)
    # MAP: the draw with the highest log posterior (the second)
    pm <- predict(fit, Xnew, type = type, method = "MAP")
    expect_equal(pm$pred, m[, 2], tolerance = 1e-8)
    expect_equal(pm$se, s[, 2], tolerance = 1e-8)
  }
})

test_that("the field mean is the calibrated simulator plus the bias, draw by draw", {
  # E[eta + delta | y] = E[eta | y] + E[delta | y] for every draw (linearity)
  set.seed(6)
  fit <- calibrate(ballSim, ballField, nMCMC = 60, nBurn = 20, thinning = 4)
  h <- c(0.5, 2.2, 4)
  sim <- predict(fit, h, type = "simulator", draws = TRUE)$draws
  bias <- predict(fit, h, type = "bias", draws = TRUE)$draws
  mean_ <- predict(fit, h, type = "mean", draws = TRUE)
  expect_equal(mean_$draws, sim + bias, tolerance = 1e-8)
  field <- predict(fit, h, type = "field")
  expect_equal(field$pred, mean_$pred, tolerance = 1e-10)
  expect_true(all(field$se > mean_$se))
})

test_that("blocks of new points give the same answers as one point at a time", {
  set.seed(3)
  fit <- fixed_fit(random_phi(2, 1))
  set.seed(4)
  big <- cbind(runif(1203, 0, 10), runif(1203, -4.9, -4.2))
  all <- predict(fit, big, method = "MAP")
  some <- c(1, 500, 501, 1001, 1203)
  each <- sapply(some, function(i) predict(fit, big[i, , drop = FALSE], method = "MAP")$pred)
  expect_equal(all$pred[some], each, tolerance = 1e-12)
  expect_length(all$se, 1203)
})

test_that("newdata may be a data frame, or a vector when p = 1", {
  set.seed(3)
  fit <- fixed_fit(random_phi(2, 1))
  expect_equal(predict(fit, data.frame(x1 = Xnew[, 1], x2 = Xnew[, 2]))$pred, predict(fit, Xnew)$pred)
  set.seed(2)
  fit1 <- calibrate(ballSim, ballField, nMCMC = 40, nBurn = 20, thinning = 10)
  expect_equal(predict(fit1, c(1, 2))$pred, predict(fit1, matrix(c(1, 2)))$pred)
})

test_that("bad arguments give clear errors", {
  set.seed(3)
  fit <- fixed_fit(random_phi(2, 1))
  expect_snapshot(error = TRUE, {
    predict(fit, c(1, 2))
    predict(fit, matrix(1:3, 1))
    predict(fit, matrix(c(1, NA), 1))
    predict(fit, data.frame(a = 1, b = "x"))
    predict(fit, "a")
    predict(fit, Xnew, method = "mode")
    predict(fit, Xnew, type = "noise")
    predict(fit, Xnew, level = 1)
    predict(fit, Xnew, draws = NA)
  })
})

test_that("ball data: predictions at h = 2.2, 2.4 match the reference (vignette 1.4)", {
  skip_if_not_slow()
  set.seed(42)
  fit <- calibrate(ballSim, ballField, nMCMC = 2500, nBurn = 500, thinning = 4)
  for (method in c("Bayesian", "MAP")) {
    pr <- predict(fit, c(2.2, 2.4), method = method)
    expect_equal(pr$pred, c(0.69, 0.73), tolerance = 0.04 / 0.7)
    expect_true(all(pr$se > 0.02 & pr$se < 0.12))
    expect_true(all(pr$lower < pr$pred & pr$pred < pr$upper))
  }
})

test_that("unknown or misspelled arguments are refused, not ignored", {
  set.seed(3)
  fit <- fixed_fit(random_phi(2, 1))
  expect_snapshot(error = TRUE, {
    predict(fit, Xnew, lvl = 0.5)
    predict(fit, Xnew, 0.5)
    predict(fit, Xnew, typ = "bias", samples = 10)
  })
  # the argument itself is not evaluated to say so
  expect_error(predict(fit, Xnew, levle = stop("evaluated")), class = "fbc_unused_dots")
})

test_that("ndraws uses evenly spaced draws over all chains; NULL uses them all", {
  set.seed(21)
  fit <- calibrate(ballSim, ballField, nMCMC = 80, nBurn = 40, thinning = 2, nChains = 2)
  n <- nrow(fit$Phi)  # 40: 20 per chain
  h <- c(0.7, 2.2, 3.9)
  pr <- predict(fit, h, ndraws = 7, draws = TRUE)
  rows <- as.integer(round(seq(1, n, length.out = 7)))  # 1, 8, 14, 20, 27, 33, 40: both chains
  expect_identical(attr(pr, "draw_rows"), rows)
  expect_true(all(c(1, 2) %in% fit$chain[rows]))
  # the same as predicting from a fit that holds only those draws
  sub <- fit_with_draws(fit, fit$Phi[rows, ], fit$chain[rows], fit$logPost[rows], fit$logLik[rows])
  ref <- predict(sub, h, ndraws = NULL, draws = TRUE)
  expect_equal(pr[c("pred", "se", "lower", "upper", "draws")],
               ref[c("pred", "se", "lower", "upper", "draws")], tolerance = 1e-14)
  # NULL, and any ndraws >= the number of draws, use every draw
  all <- predict(fit, h, ndraws = NULL, draws = TRUE)
  expect_identical(attr(all, "draw_rows"), seq_len(n))
  expect_identical(predict(fit, h, draws = TRUE), all)  # default 1000 > 40
  expect_equal(ncol(all$draws), n)
  expect_snapshot(error = TRUE, {
    predict(fit, h, ndraws = 0)
    predict(fit, h, ndraws = "all")
  })
})

# Equal to rounding, not bit for bit: an optimized BLAS (OpenBLAS) takes
# other kernel paths for other block shapes, so the last bits may differ.
test_that("points in blocks give the answers of one block", {
  set.seed(21)
  fit <- calibrate(ballSim, ballField, nMCMC = 80, nBurn = 40, thinning = 2, nChains = 2)
  h <- seq(0.3, 4.1, length.out = 23)
  one <- predict(fit, h, draws = TRUE, level = 0.8)
  old <- options(FBC.predict_block = 4)  # 6 blocks, the last one of 3 points
  on.exit(options(old))
  blocked <- predict(fit, h, draws = TRUE, level = 0.8)
  expect_equal(blocked, one, tolerance = 1e-12)
  expect_equal(predict(fit, h, method = "MAP"), {
    options(FBC.predict_block = NULL); predict(fit, h, method = "MAP")
  }, tolerance = 1e-12)
  # with a progress bar forced on, the same numbers
  options(FBC.predict_block = 5, FBC.progress = TRUE, cli.progress_show_after = 0)
  expect_equal(suppressMessages(predict(fit, h, draws = TRUE, level = 0.8)), one, tolerance = 1e-12)
  options(FBC.progress = NULL, cli.progress_show_after = NULL, FBC.predict_block = NULL)
  # block sizes: bounded by the memory budget, >= 500 points otherwise
  expect_equal(FBC:::predict_block_size(5000, 1000), 500L)
  expect_equal(FBC:::predict_block_size(1e6, 1000), 6250L)  # 1e8 bytes / (16 * 1000)
  expect_equal(FBC:::predict_block_size(1e6, 1e5), 62L)
  expect_equal(FBC:::predict_block_size(20, 1000), 20L)
})

test_that("mixture quantiles solve the mixture's distribution function, also far from Gaussian", {
  # reference: uniroot on the mixture CDF written out in plain R
  set.seed(5)
  M <- 50
  mu <- rbind(c(rep(-3, 25), rep(3, 25)),            # two separated modes
              rnorm(M, 0, 0.01),                      # near one Gaussian
              c(rnorm(49, 0, 1), 40),                 # one far component
              rnorm(M, 100, 1))
  sd <- rbind(rep(0.5, M), runif(M, 1, 2), rep(1, M), runif(M, 1e-3, 1e-2))
  for (p in c(0.025, 0.5, 0.975)) {
    q <- FBC:::mixture_quantile(mu, sd, p)
    ref <- vapply(1:4, function(i) {
      uniroot(function(x) mean(pnorm(x, mu[i, ], sd[i, ])) - p, c(-200, 200), tol = 1e-13)$root
    }, numeric(1))
    expect_equal(q, ref, tolerance = 1e-8)
    expect_equal(rowMeans(pnorm(q, mu, sd)), rep(p, 4), tolerance = 1e-10)
  }
})

test_that("a prediction prints as a table, without the rows of the draws it used", {
  set.seed(21)
  fit <- calibrate(ballSim, ballField, nMCMC = 80, nBurn = 40, thinning = 2, nChains = 2)
  h <- seq(0.5, 4, length.out = 25)
  pr <- predict(fit, h, draws = TRUE)
  expect_s3_class(pr, "fbc_prediction")
  expect_equal(length(attr(pr, "draw_rows")), nrow(fit$Phi))  # 40 draws
  out <- capture.output(print(pr))
  expect_identical(out[1], "<fbc_prediction> 25 points from 40 posterior draws")
  expect_false(any(grepl("draw_rows|attr", out)))
  expect_length(out, 1 + 21 + 2)  # header, 20 rows under the column names, 2 notes
  expect_identical(out[23:24], c("... 5 more points: see `$pred`, `$se`, `$lower`, `$upper`",
                                 "$draws: the per-draw predictive means, 25 x 40"))
  map <- predict(fit, h[1:3], method = "MAP")
  expect_snapshot(print(map, digits = 3))
  # still a list of its parts
  expect_identical(as.data.frame(map)$upper, map$upper)
  expect_snapshot(error = TRUE, print(pr, digits = "3"))
})
