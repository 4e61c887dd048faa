# References: explicit refits of the emulator without the held-out runs,
# written with dense_corr() (helper-dense.R) and base R's solve(): the GP
# conditional of y_B given y_-B, mean K_B,-B K_-B^-1 y_-B and covariance
# K_BB - K_B,-B K_-B^-1 K_-B,B, with K = sigma2S (R_s + nugget I).
# The compiled held-out predictives (.fbc_heldout(), through the dense or
# the Kronecker algebra) are checked against these plain-R dense solves.

# Held-out predictive of every run by refitting without it (or its fold).
refit_heldout <- function(Xs, ys, th, fold, nugget = 1e-6, kernel = "powexp") {
  m <- nrow(Xs)
  K <- th$sigma2S * (dense_corr(Xs, Xs, th$thetaS, th$alphaS, kernel) + nugget * diag(m))
  heldout_by_fold(K, ys, fold)
}
# The Gaussian conditional of each fold's responses given the others', for
# the runs' covariance K.
heldout_by_fold <- function(K, ys, fold) {
  mean <- var <- numeric(length(ys))
  for (k in unique(fold)) {
    B <- which(fold == k)
    A <- solve(K[-B, -B], K[-B, B, drop = FALSE])
    mean[B] <- crossprod(A, ys[-B])
    var[B] <- diag(K[B, B, drop = FALSE] - K[B, -B, drop = FALSE] %*% A)
  }
  list(mean = mean, var = var)
}

test_that("leave-one-out and k-fold predictions equal explicit refits", {
  set.seed(3)
  phi <- random_phi(2, 1)
  fit <- fixed_fit(phi)
  sc <- fit$model$scale
  th <- unpack_phi(phi, 2, 1)
  m <- length(fit$model$data$ys)
  cases <- list(list(folds = NULL, labels = seq_len(m)),
                list(folds = 3, labels = (seq_len(m) - 1) %% 3 + 1),
                list(folds = rep(1:4, each = 3), labels = rep(1:4, each = 3)))
  for (cs in cases) {
    ref <- refit_heldout(fit$model$data$Xs, fit$model$data$ys, th, cs$labels)
    for (method in c("MAP", "Bayesian")) {
      v <- emulator_cv(fit, method = method, folds = cs$folds)
      expect_equal(v$runs$mean, sc$ymean + sc$ysd * ref$mean, tolerance = 1e-8)
      expect_equal(v$runs$sd, sc$ysd * sqrt(ref$var), tolerance = 1e-8)
      expect_equal(v$runs$observed, sc$ymean + sc$ysd * fit$model$data$ys)
      z <- (fit$model$data$ys - ref$mean) / sqrt(ref$var)
      expect_equal(v$runs$z, z, tolerance = 1e-7)
      expect_equal(v$runs$pit, pnorm(z), tolerance = 1e-7)
    }
  }
  expect_equal(v$nFolds, 4L)
  expect_equal(v$runs$fold, rep(1:4, each = 3))
  # inputs in their own units, with the data's names
  expect_equal(as.matrix(v$runs[, c("x1", "x2", "t")]),
               FBC:::unscale_inputs(fit$model$data$Xs, sc, 1:3), ignore_attr = TRUE)
})

test_that("several draws combine as a Gaussian mixture (total variance, mixture PIT)", {
  set.seed(3)
  phi <- random_phi(2, 1)
  fit <- fixed_fit(phi)
  sc <- fit$model$scale
  set.seed(8)
  phis <- rbind(phi, t(replicate(3, random_phi(2, 1))))
  Phi <- phis
  Phi[, 1] <- sc$xmin[3] + phis[, 1] * (sc$xmax[3] - sc$xmin[3])
  colnames(Phi) <- colnames(fit$Phi)
  fit <- fit_with_draws(fit, Phi, logPost = c(-3, -1, -7, -2))
  m <- length(fit$model$data$ys)
  refs <- lapply(1:4, function(i) refit_heldout(fit$model$data$Xs, fit$model$data$ys, unpack_phi(phis[i, ], 2, 1),
                                                seq_len(m)))
  mu <- sapply(refs, `[[`, "mean")
  s2 <- sapply(refs, `[[`, "var")
  v <- emulator_cv(fit)
  expect_equal(v$ndraws, 4L)
  expect_equal(v$runs$mean, sc$ymean + sc$ysd * rowMeans(mu), tolerance = 1e-8)
  # law of total variance of the equal-weight mixture (divisor M)
  tv <- rowMeans(s2) + rowMeans((mu - rowMeans(mu))^2)
  expect_equal(v$runs$sd, sc$ysd * sqrt(tv), tolerance = 1e-8)
  expect_equal(v$runs$pit, rowMeans(pnorm((fit$model$data$ys - mu) / sqrt(s2))), tolerance = 1e-7)
  # ndraws = 2: the first and the last draw
  v2 <- emulator_cv(fit, ndraws = 2)
  expect_equal(v2$runs$mean, sc$ymean + sc$ysd * rowMeans(mu[, c(1, 4)]), tolerance = 1e-8)
  # MAP: the second draw
  vm <- emulator_cv(fit, method = "MAP")
  expect_equal(vm$runs$mean, sc$ymean + sc$ysd * mu[, 2], tolerance = 1e-8)
  # coverage, RMSE and |z| > 3 from the per-run numbers
  expect_equal(unname(v$coverage), sapply(c(0.5, 0.9, 0.95), function(l) mean(abs(v$runs$pit - 0.5) < l / 2)))
  expect_equal(v$rmse, sqrt(mean((v$runs$observed - v$runs$mean)^2)))
  expect_equal(v$rmseRel, v$rmse / sc$ysd)
  expect_equal(v$shareZ3, mean(abs(v$runs$z) > 3))
})

# An fbc object whose simulator runs are a draw from the emulator's own GP
# at the fixed parameters: its held-out predictives are exact, so each z is
# N(0, 1) and the coverage is nominal up to sampling noise.
gp_truth_fit <- function(sigma2SFit, m = 400, seed = 21) {
  set.seed(3)
  fit <- fixed_fit(random_phi(2, 1))
  set.seed(seed)
  Xs <- matrix(runif(m * 3), m, 3)
  th <- c(2, 1, 3)
  al <- c(1.5, 1.5, 1.5)
  K <- dense_corr(Xs, Xs, th, al) + 1e-6 * diag(m)
  fit$model$data$Xs <- Xs
  fit$model$data$ys <- drop(crossprod(chol(K), rnorm(m)))  # sigma2S = 1
  fit$model$dims$m <- nrow(Xs)
  idx <- fit$indices
  fit$Phi[, idx$thetaS] <- matrix(th, nrow(fit$Phi), 3, byrow = TRUE)
  fit$Phi[, idx$alphaS] <- matrix(al, nrow(fit$Phi), 3, byrow = TRUE)
  fit$Phi[, idx$sigma2S] <- sigma2SFit
  fit
}

test_that("an exact emulator has nominal coverage; an overconfident one does not", {
  v <- emulator_cv(gp_truth_fit(1), method = "MAP")
  # 400 runs: binomial sd of a 95% coverage is 0.011
  expect_equal(unname(v$coverage), c(0.5, 0.9, 0.95), tolerance = 0.08)
  expect_lt(abs(mean(v$runs$z)), 0.15)
  expect_lt(abs(sd(v$runs$z) - 1), 0.1)
  expect_lte(v$shareZ3, 0.01)
  # sigma2S ten times too small: intervals sqrt(10) times too narrow
  bad <- emulator_cv(gp_truth_fit(0.1), method = "MAP")
  expect_equal(bad$runs$mean, v$runs$mean)
  expect_lt(bad$coverage[["95%"]], 0.6)
  expect_match(FBC:::validation_verdict(bad), "overconfident")
  expect_identical(FBC:::validation_verdict(v), character())
})

test_that("folds: the default rule and argument checks", {
  expect_null(FBC:::emulator_folds(NULL, 2000))
  expect_equal(FBC:::emulator_folds(NULL, 2001), (seq_len(2001) - 1) %% 10 + 1)
  expect_null(FBC:::emulator_folds(12, 12))
  expect_null(FBC:::emulator_folds(1:12, 12))
  set.seed(3)
  fit <- fixed_fit(random_phi(2, 1))
  expect_snapshot(error = TRUE, emulator_cv(fit, folds = 13))
  expect_snapshot(error = TRUE, emulator_cv(fit, folds = 1:5))
  expect_snapshot(error = TRUE, emulator_cv(fit, folds = rep(1, 12)))
  expect_snapshot(error = TRUE, emulator_cv(list()))
  expect_snapshot(error = TRUE, emulator_cv(fit, method = "exact"))
})

test_that("print and plot of a validation", {
  set.seed(3)
  fit <- fixed_fit(random_phi(2, 1))
  v <- emulator_cv(fit, folds = 3)
  expect_snapshot(print(v))
  p <- plot(v)
  expect_s3_class(p, "ggplot")
  # one panel per simulator input, named as in the data, and the QQ panel
  expect_equal(levels(p$data$panel), c("x1", "x2", "t", "normal QQ (x: N(0, 1) quantile)"))
  expect_equal(nrow(p$data), 4 * 12)
  qq <- p$data[p$data$panel == levels(p$data$panel)[4], ]
  expect_equal(qq$z, sort(v$runs$z))
  expect_equal(levels(plot(v, which = "qq")$data$panel), "normal QQ (x: N(0, 1) quantile)")
  expect_equal(levels(plot(v, which = "inputs")$data$panel), c("x1", "x2", "t"))
  expect_no_error(ggplot2::ggplot_build(p))
})

test_that("a Matern emulator: held-out predictions equal explicit refits in its family", {
  set.seed(5)
  phi <- random_phi(2, 1)
  fit <- fixed_fit(phi, kernelS = "matern52", kernelB = "gaussian")
  sc <- fit$model$scale
  th <- unpack_phi(phi, 2, 1)
  m <- length(fit$model$data$ys)
  X <- fit$model$data$Xs
  for (cs in list(list(folds = NULL, labels = seq_len(m)),
                  list(folds = 3, labels = (seq_len(m) - 1) %% 3 + 1))) {
    ref <- refit_heldout(X, fit$model$data$ys, th, cs$labels, kernel = "matern52")
    v <- emulator_cv(fit, method = "MAP", folds = cs$folds)
    expect_equal(v$runs$mean, sc$ymean + sc$ysd * ref$mean, tolerance = 1e-8)
    expect_equal(v$runs$sd, sc$ysd * sqrt(ref$var), tolerance = 1e-8)
  }
})

# A product design on the scaled space (p = 2, q = 1): every combination of
# I experimental settings and J calibration settings, rows shuffled, random
# responses and n field points (the Kronecker algebra's case).
product_koh_data <- function(I, J, n, seed) {
  set.seed(seed)
  Xg <- matrix(runif(I * 2), I, 2)
  tg <- runif(J)
  g <- expand.grid(i = seq_len(I), j = seq_len(J))[sample(I * J), ]
  list(Xf = matrix(runif(n * 2), n, 2), yf = rnorm(n), Xs = unname(cbind(Xg[g$i, ], tg[g$j])),
       ys = rnorm(I * J))
}

test_that("compiled held-out predictives equal dense refits on the dense and Kronecker algebras", {
  designs <- list(scattered = random_koh_data(n = 6, m = 30, p = 2, q = 1, seed = 4),
                  product = product_koh_data(5, 7, n = 6, seed = 4))
  expect_length(.sim_algebra(designs$scattered$Xs, 2L), 0)       # dense
  expect_identical(.sim_algebra(designs$product$Xs, 2L), c(5L, 7L))  # Kronecker 5 x 7
  for (d in designs) {
    m <- nrow(d$Xs)
    set.seed(6)
    phis <- rbind(random_phi(2, 1), random_phi(2, 1))
    # leave-one-out, 4 even folds, and uneven folds mixing single runs and blocks
    for (fold in list(seq_len(m), (seq_len(m) - 1) %% 4 + 1, c(3:1, rep(4:6, length.out = m - 3)))) {
      res <- .fbc_heldout(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, fold)
      for (i in 1:2) {
        ref <- refit_heldout(d$Xs, d$ys, unpack_phi(phis[i, ], 2, 1), fold)
        expect_equal(res$mean[, i], ref$mean, tolerance = 1e-8)
        expect_equal(res$var[, i], ref$var, tolerance = 1e-8)
      }
      # the dense algebra forced on the product design: the same numbers
      expect_equal(.fbc_heldout(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, fold, algebra = 1L), res,
                   tolerance = 1e-8)
    }
  }
  d <- designs$product
  expect_error(.fbc_heldout(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, rep(2L, 35)), "each used")
})

test_that("emulator_cv() on a product design goes through the Kronecker algebra", {
  set.seed(3)
  phi <- random_phi(2, 1)
  fit <- fixed_fit(phi, d = product_koh_data(5, 7, n = 7, seed = 11))
  expect_identical(fit$model$algebra[c("name", "dims")], list(name = "kronecker", dims = c(5L, 7L)))
  sc <- fit$model$scale
  th <- unpack_phi(phi, 2, 1)
  m <- length(fit$model$data$ys)
  for (cs in list(list(folds = NULL, labels = seq_len(m)),
                  list(folds = 3, labels = (seq_len(m) - 1) %% 3 + 1),
                  list(folds = rep(c("a", "b"), c(30, 5)), labels = rep(1:2, c(30, 5))))) {
    ref <- refit_heldout(fit$model$data$Xs, fit$model$data$ys, th, cs$labels)
    v <- emulator_cv(fit, method = "MAP", folds = cs$folds)
    expect_equal(v$runs$mean, sc$ymean + sc$ysd * ref$mean, tolerance = 1e-8)
    expect_equal(v$runs$sd, sc$ysd * sqrt(ref$var), tolerance = 1e-8)
  }
})

test_that("wide intervals are called cautious only when no run is far off", {
  # sigma2S ten times too large: intervals sqrt(10) times too wide
  wide <- emulator_cv(gp_truth_fit(10), method = "MAP")
  expect_gt(wide$coverage[["50%"]], 0.85)
  expect_equal(sum(abs(wide$runs$z) > 3), 0)
  expect_match(FBC:::validation_verdict(wide), "too cautious")
  # two runs far off (fewer than the 3 that make it overconfident)
  wide$runs$z[c(5, 9)] <- c(4.2, -3.5)
  expect_snapshot(writeLines(strwrap(FBC:::validation_verdict(wide), 78)))
})

test_that("validation in blocks of draws equals one call, and shows progress when asked", {
  # 23 draws: blocks of 10, 10 and 3 give the numbers of one compiled call
  set.seed(8)
  fit <- calibrate(ballSim, ballField, nMCMC = 120, nBurn = 20, thinning = 2, nChains = 1)
  phis <- FBC:::sampler_draws(fit, 1:23)
  d <- fit$model$data
  one <- .fbc_heldout(d$Xf, d$yf, d$Xs, d$ys, phis, fit$settings$nugget, seq_along(d$ys),
                      model = fit$model$spec$model)
  old <- options(FBC.progress = TRUE)
  on.exit(options(old), add = TRUE)
  blocks <- FBC:::heldout_draws(fit, phis, seq_along(d$ys))
  # each draw is computed alone either way (to 1e-12: other BLASes may round
  # differently with other shapes)
  expect_equal(blocks, one[c("mean", "var")], tolerance = 1e-12)
})

test_that("with several outputs: an RMSE per output, and the output drawn as categorical", {
  # The raw RMSE pooled outputs of different units (here conc ~ 1
  # and rate ~ 100), and plot() drew the output's indicator as a numeric input
  set.seed(3)
  x <- runif(30); t <- runif(30, 0.5, 3)
  sim <- rbind(data.frame(y = 5 * exp(-t * x), x = x, out = "conc", t = t),
               data.frame(y = 200 * t * x, x = x, out = "rate", t = t))
  xf <- seq(0.05, 0.95, length.out = 8)
  field <- rbind(data.frame(y = 5 * exp(-1.7 * xf) + rnorm(8, 0, 0.05), x = xf, out = "conc"),
                 data.frame(y = 340 * xf + rnorm(8, 0, 0.5), x = xf, out = "rate"))
  set.seed(1)
  fit <- calibrate(sim, field, output = "out", outputs = "shared", nMCMC = 120, nBurn = 60, nChains = 1,
                   kernelS = "matern52", kernelB = "matern52")
  v <- emulator_cv(fit, method = "MAP")
  expect_identical(levels(v$runs$out), c("conc", "rate"))
  expect_identical(as.character(v$runs$out), sim$out)
  expect_identical(v$inputs, c("x", "out", "t"))
  # each output's RMSE from its own runs, in its own units
  err <- v$runs$observed - v$runs$mean
  expect_equal(v$rmse, c(conc = sqrt(mean(err[sim$out == "conc"]^2)),
                         rate = sqrt(mean(err[sim$out == "rate"]^2))))
  expect_output(print(v), "RMSE by output: conc [0-9.e-]+, rate [0-9.e-]+ \\(")
  p <- plot(v, which = "inputs")
  expect_identical(levels(p$data$panel), c("x", "out (1 conc, 2 rate)", "t"))
  expect_equal(p$data$x[p$data$panel == "out (1 conc, 2 rate)"], match(sim$out, c("conc", "rate")))
  expect_no_error(ggplot2::ggplot_build(p))
})

# A stochastic simulator (5 exp(-t x) plus N(0, 0.2^2) run noise) on 3 x 3
# unique inputs with 1 to 4 replicates each, and field data at t = 1.7.
noisy_runs <- function(seed = 2) {
  set.seed(seed)
  U <- expand.grid(x = c(0, 1.5, 3), t = c(0.5, 1.75, 3))
  X <- U[rep(seq_len(9), c(1, 3, 2, 4, 2, 3, 1, 2, 4)), ]
  sim <- cbind(y = 5 * exp(-X$t * X$x) + rnorm(nrow(X), 0, 0.2), x = X$x, t = X$t)
  rownames(sim) <- NULL
  xf <- seq(0.1, 2.9, length.out = 4)
  list(sim = sim, field = cbind(y = 5 * exp(-1.7 * xf) + rnorm(4, 0, 0.05), x = xf))
}

test_that("with the simulator's noise, every run is predicted with its input's replicates held out", {
  pb <- noisy_runs()
  set.seed(4)
  fit <- suppressWarnings(calibrate(pb$sim, pb$field, discrepancy = "none", nMCMC = 100,
                                    nBurn = 50, nChains = 1, converge = FALSE))
  sc <- fit$model$scale
  phi <- FBC:::sampler_draws(fit, which.max(fit$logPost))[1, ]
  idx <- FBC:::param_indices(1, 1, "none", replicates = 1L)
  th <- lapply(idx, function(i) phi[i])
  # plain R on every run: K = sigma2S (R_s + nugget) over the runs' inputs
  # plus r I, each input's runs held out together
  X <- cbind((pb$sim[, "x"] - sc$xmin[1]) / (sc$xmax[1] - sc$xmin[1]),
             (pb$sim[, "t"] - sc$xmin[2]) / (sc$xmax[2] - sc$xmin[2]))
  y <- (pb$sim[, 1] - sc$ymean) / sc$ysd
  n <- nrow(X)
  group <- FBC:::sim_replicates(pb$sim)$group
  # (replicates share eta, and so its nugget)
  K <- th$sigma2S * (dense_corr(X, X, th$thetaS, th$alphaS, "matern52") +
                       fit$settings$nugget * outer(group, group, "==")) + th$sigma2R * diag(n)
  ref <- heldout_by_fold(K, y, group)
  v <- emulator_cv(fit, method = "MAP")
  expect_identical(nrow(v$runs), n)
  expect_identical(v$runs$fold, group)
  expect_equal(v$runs$observed, pb$sim[, 1])
  expect_equal(v$runs$mean, sc$ymean + sc$ysd * ref$mean, tolerance = 1e-8)
  expect_equal(v$runs$sd, sc$ysd * sqrt(ref$var), tolerance = 1e-8)
  expect_equal(v$runs$pit, pnorm((y - ref$mean) / sqrt(ref$var)), tolerance = 1e-7)
  expect_equal(as.matrix(v$runs[, c("x", "t")]), pb$sim[, c("x", "t")], ignore_attr = TRUE)
  # folds: a number counts the unique inputs; labels per run keep replicates together
  lab <- c(1, 2, 3, 1, 2, 3, 1, 2, 3)[group]
  v3 <- emulator_cv(fit, method = "MAP", folds = lab)
  expect_identical(v3$nFolds, 3L)
  for (k in 1:3) {
    B <- which(lab == k)
    A <- solve(K[-B, -B], K[-B, B, drop = FALSE])
    expect_equal(v3$runs$mean[B], sc$ymean + sc$ysd * drop(crossprod(A, y[-B])), tolerance = 1e-8)
  }
  expect_identical(emulator_cv(fit, method = "MAP", folds = 3)$runs$mean, v3$runs$mean)
  expect_snapshot(print(v), transform = function(x) gsub("-?[0-9]+\\.[0-9]+", "<num>", x))
  expect_snapshot(error = TRUE, {
    emulator_cv(fit, folds = seq_len(n))
    emulator_cv(fit, folds = 1:9)
  })
})
