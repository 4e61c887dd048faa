# The compiled block (Schur complement) log-likelihood of src/model.cpp
# against dense_loglik() (helper-dense.R): one Cholesky factor of the full
# (n + m) x (n + m) covariance built entry by entry in plain R.

sizes <- list(c(n = 5, m = 12, p = 1, q = 1), c(n = 6, m = 15, p = 2, q = 1),
              c(n = 7, m = 14, p = 1, q = 2), c(n = 8, m = 20, p = 2, q = 2))

test_that("the block log-likelihood from scratch equals the dense one", {
  for (s in sizes) {
    dat <- random_koh_data(s[["n"]], s[["m"]], s[["p"]], s[["q"]], seed = sum(s))
    for (r in 1:5) {
      phi <- random_phi(s[["p"]], s[["q"]])
      block <- .fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6)
      dense <- dense_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6)
      expect_equal(block, dense, tolerance = 1e-8)
    }
  }
})

test_that("the cached one-move path equals the dense log-likelihood at every row", {
  for (s in sizes) {
    p <- s[["p"]]; q <- s[["q"]]
    dat <- random_koh_data(s[["n"]], s[["m"]], p, q, seed = 10 + sum(s))
    phis <- one_move_path(random_phi(p, q), p, q)
    path <- .loglik_path(dat$Xf, dat$yf, dat$Xs, dat$ys, phis, 1e-6)
    dense <- apply(phis, 1, function(phi) dense_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6))
    expect_equal(path, dense, tolerance = 1e-8)
    # returning to the start reproduces the from-scratch value
    expect_equal(path[nrow(phis)], path[1], tolerance = 1e-10)
    # the same with a rejected decoy proposal before every move, and with the
    # default sampler's joint moves: (thetaS, alphaS, sigma2S), (thetaB,
    # alphaB, sigma2B), and sigma2S, sigma2B, sigma2E scaled by one factor
    decoy <- .loglik_path(dat$Xf, dat$yf, dat$Xs, dat$ys, phis, 1e-6, decoys = TRUE)
    expect_equal(decoy, dense, tolerance = 1e-8)
    expect_joint_moves_dense(dat, phis, p, q)
  }
})

test_that("replicated field inputs (shared columns) give the dense log-likelihood", {
  # (predictions with replicates: test-predict.R, on the ball data, 3 per height)
  # the algebra computes Rs(Xs, Xk), Rs(Xk, Xk) and Rb for distinct field
  # rows only; rows repeated in any order must not change anything
  for (s in sizes) {
    p <- s[["p"]]; q <- s[["q"]]
    dat <- random_koh_data(s[["n"]], s[["m"]], p, q, seed = 30 + sum(s))
    rep_rows <- c(seq_len(s[["n"]]), 2, 1, 2, s[["n"]])
    dat$Xf <- dat$Xf[rep_rows, , drop = FALSE]
    dat$yf <- c(dat$yf, rnorm(4))
    phis <- one_move_path(random_phi(p, q), p, q)
    path <- .loglik_path(dat$Xf, dat$yf, dat$Xs, dat$ys, phis, 1e-6, decoys = TRUE)
    dense <- apply(phis, 1, function(phi) dense_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6))
    expect_equal(path, dense, tolerance = 1e-8)
  }
})

test_that("repeated field rows in several noise groups: the field block on the distinct rows gives the dense likelihood and predictions", {
  # four distinct inputs, each measured three times, the replicates of one
  # input in different measurement-error groups: the field block is
  # factored on the 4 distinct rows (field.cpp), exactly
  p <- 2; q <- 1
  d <- random_koh_data(4, 15, p, q, seed = 81)
  d$Xf <- d$Xf[rep(1:4, 3), , drop = FALSE]
  d$yf <- rnorm(12)
  noise <- rep(c(1L, 2L, 3L), each = 4)
  for (disc in c("gp", "sgasp", "none")) {
    model <- FBC:::compiled_model(p, q, discrepancy = disc, noise = noise)
    phis <- rbind(random_phi(p, q, disc, G = 3L), random_phi(p, q, disc, G = 3L))
    dense <- function(phi) dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, 1e-6, discrepancy = disc,
                                        noise = noise)
    for (i in 1:2) {
      expect_equal(.fbc_loglik(d$Xf, d$yf, d$Xs, d$ys, phis[i, ], 1e-6, model = model),
                   dense(phis[i, ]), tolerance = 1e-10)
    }
    path <- .loglik_path(d$Xf, d$yf, d$Xs, d$ys, phis, 1e-6, decoys = TRUE, model = model)
    expect_equal(path, apply(phis, 1, dense), tolerance = 1e-10)
    expect_joint_moves_dense(d, phis, p, q, discrepancy = disc, noise = noise)
    Xn <- d$Xf[c(1, 6), , drop = FALSE]
    got <- .fbc_predict(d$Xf, d$yf, d$Xs, d$ys, phis, Xn, 1L, 1e-6, 2L, model = model,
                        noise = c(3L, 1L))
    for (i in 1:2) {
      ref <- dense_predict(d$Xf, d$yf, d$Xs, d$ys, phis[i, ], Xn, "field", discrepancy = disc,
                           noise = noise, noiseNew = c(3L, 1L))
      expect_equal(got$mean[, i], ref$mean, tolerance = 1e-10)
      expect_equal(got$var[, i], ref$var, tolerance = 1e-10)
    }
  }
})

test_that("the sampler's retained log-likelihoods (accept and reject paths) equal the dense ones", {
  # Every retained draw was reached through a run of proposals, some accepted
  # and some rejected; a stale cache after a rejection would show up here.
  p <- 2; q <- 2
  dat <- random_koh_data(8, 20, p, q, seed = 7)
  sp <- FBC:::build_priors(list(dist = rep("beta", q), init = rep(NA, q), p1 = rep(1.1, q), p2 = rep(1.1, q)),
                           defaults_010$hypers,  # (a prior whose every move accepts and rejects in 60 sweeps)
                           list(xmin = rep(0, p + q), xmax = rep(1, p + q), p = p, q = q),
                           p, q)
  sp$model <- FBC:::compiled_model(p, q)
  set.seed(3)
  res <- run_sampler(dat, sp, "single", 60L, 20L, 4L)
  acc <- res$acceptance[!is.na(res$acceptance)]
  expect_true(all(acc > 0 & acc < 1))  # both branches were taken
  dense <- apply(res$draws, 1, function(phi) dense_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6))
  expect_equal(res$logLik, dense, tolerance = 1e-8)

  # the default sampler: each block shares one acceptance rate and returns
  # its adapted proposal factor; muB is drawn exactly (always accepted)
  set.seed(4)
  res <- run_sampler(dat, sp, "blocks", 260L, 200L, 4L)
  idx <- FBC:::param_indices(p, q)
  sim <- unname(unlist(idx[c("thetaS", "alphaS", "sigma2S")]))
  simBlock <- vapply(res$state$blocks, function(b) idx$thetaS[1] %in% b$index, logical(1))
  b1 <- res$state$blocks[simBlock][[1]]
  expect_identical(b1$index, sim)
  expect_length(unique(res$acceptance[sim]), 1)
  expect_true(res$acceptance[sim[1]] > 0 && res$acceptance[sim[1]] < 1)
  expect_equal(dim(b1$chol), c(length(sim), length(sim)))
  expect_true(b1$shaped)
  expect_identical(res$state$logsd[sim], sp$logsd[sim])  # single-site SDs left alone
  expect_identical(res$acceptance[idx$muB], 1)
  expect_true(res$scaleAcceptance > 0 && res$scaleAcceptance < 1)
  dense <- apply(res$draws, 1, function(phi) dense_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6))
  expect_equal(res$logLik, dense, tolerance = 1e-8)
})

test_that("a covariance that is not positive definite gives -Inf, not a crash", {
  p <- 1; q <- 1
  dat <- random_koh_data(6, 12, p, q, seed = 5)
  idx <- FBC:::param_indices(p, q)
  set.seed(5)
  phi <- random_phi(p, q)
  bad <- phi
  bad[idx$sigma2E] <- -5  # the field block S has eigenvalues below zero
  C <- dense_cov(dat$Xf, dat$Xs, bad, 1e-6)
  expect_lt(min(eigen(C, symmetric = TRUE, only.values = TRUE)$values), 0)
  expect_identical(.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, bad, 1e-6), -Inf)
  negS <- phi
  negS[idx$sigma2S] <- -1  # the simulator block D = sigma2S Ds is negative definite
  expect_identical(.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, negS, 1e-6), -Inf)
  negT <- phi
  negT[idx$thetaS] <- -3  # not a correlation: Rs(Xs, Xs) is indefinite
  expect_identical(.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, negT, 1e-6), -Inf)
  # on a path the failing move stops it (the row and the rest are NA)
  path <- .loglik_path(dat$Xf, dat$yf, dat$Xs, dat$ys, rbind(phi, bad, phi), 1e-6)
  expect_equal(path[1], dense_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6), tolerance = 1e-8)
  expect_identical(path[2:3], c(NA_real_, NA_real_))

  # In the sampler such proposals are rejected: give sigma2E (by hand, as R
  # refuses it) a Gaussian(0, 1) prior on an identity walk, so that about
  # half of its proposals are negative.
  sp <- FBC:::build_priors(list(dist = "beta", init = NA, p1 = 1.1, p2 = 1.1),
                           set_hyperPriors(),
                           list(xmin = c(0, 0), xmax = c(1, 1), p = p, q = q), p, q)
  sp$model <- FBC:::compiled_model(p, q)
  tab <- as.list(sp$table)
  tab$family[idx$sigma2E] <- 2L  # PF_GAUSSIAN
  tab$p1[idx$sigma2E] <- 0
  tab$p2[idx$sigma2E] <- 1
  tab$transform[idx$sigma2E] <- 0L
  logsd <- sp$logsd
  logsd[idx$sigma2E] <- log(5)
  set.seed(6)
  sp$table <- tab
  sp$logsd <- logsd
  res <- run_sampler(dat, sp, "single", 40L, 0L, 1L)
  expect_equal(res$kept, 40L)
  expect_true(all(is.finite(res$logLik)))
  dense <- apply(res$draws, 1, function(phi) dense_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6))
  expect_equal(res$logLik, dense, tolerance = 1e-8)
  sigma2E <- FBC:::param_indices(p, q)$sigma2E
  expect_lt(res$acceptance[sigma2E], 0.6)  # the negative proposals were rejected
})

# Pairs of correlation families (simulator, bias) covering each family on
# each GP, mixed with the power exponential and with each other.
kernel_pairs <- list(c("gaussian", "matern32"), c("matern32", "matern52"),
                     c("matern52", "gaussian"), c("powexp", "matern52"),
                     c("matern32", "powexp"))

test_that("every correlation family: the block log-likelihood equals the dense one", {
  # dense_loglik() builds the covariance from dense_corr(), written from the
  # formulas of ?correlation (helper-dense.R)
  for (s in sizes[c(2, 4)]) {
    p <- s[["p"]]; q <- s[["q"]]
    dat <- random_koh_data(s[["n"]], s[["m"]], p, q, seed = 50 + sum(s))
    for (kk in kernel_pairs) {
      phi <- random_phi(p, q)
      block <- .fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6,
                           kernel_code(kk[1]), kernel_code(kk[2]))
      dense <- dense_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, kk[1], kk[2])
      expect_equal(block, dense, tolerance = 1e-8)
    }
  }
})

test_that("every correlation family: cached, on-the-fly and joint-move paths equal the dense log-likelihood", {
  old <- .fbc_cache_budget()
  on.exit(.fbc_cache_budget(old))
  # p + q = 5 puts 4 inputs in packed caches and 1 on the fly
  for (s in list(sizes[[2]], sizes[[4]], c(n = 5, m = 16, p = 2, q = 3))) {
    p <- s[["p"]]; q <- s[["q"]]
    dat <- random_koh_data(s[["n"]], s[["m"]], p, q, seed = 60 + sum(s))
    dat$Xf <- dat$Xf[c(seq_len(s[["n"]]), 1, 3), , drop = FALSE]  # replicates
    dat$yf <- c(dat$yf, rnorm(2))
    idx <- FBC:::param_indices(p, q)
    groups <- integer(length(random_phi(p, q)))
    groups[c(idx$thetaS, idx$alphaS, idx$sigma2S)] <- 1L
    groups[c(idx$thetaB, idx$alphaB, idx$sigma2B)] <- 2L
    for (kk in kernel_pairs) {
      kS <- kernel_code(kk[1]); kB <- kernel_code(kk[2])
      phis <- one_move_path(random_phi(p, q), p, q)
      dense <- apply(phis, 1, function(phi)
        dense_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, kk[1], kk[2]))
      cached <- .loglik_path(dat$Xf, dat$yf, dat$Xs, dat$ys, phis, 1e-6, decoys = TRUE,
                             kernS = kS, kernB = kB)
      expect_equal(cached, dense, tolerance = 1e-8)
      joint <- .loglik_path(dat$Xf, dat$yf, dat$Xs, dat$ys, phis, 1e-6, groups = groups,
                            decoys = TRUE, kernS = kS, kernB = kB)
      expect_equal(joint, dense, tolerance = 1e-8)
      .fbc_cache_budget(0)
      fly <- .loglik_path(dat$Xf, dat$yf, dat$Xs, dat$ys, phis, 1e-6, decoys = TRUE,
                          kernS = kS, kernB = kB)
      .fbc_cache_budget(old)
      # the on-the-fly path does the cached path's operations: the same numbers
      expect_equal(fly, cached, tolerance = 1e-12)
    }
  }
})

test_that("a family without a smoothness ignores alpha", {
  dat <- random_koh_data(6, 15, 2, 1, seed = 70)
  idx <- FBC:::param_indices(2, 1)
  set.seed(70)
  phi <- random_phi(2, 1)
  other <- phi
  other[c(idx$alphaS, idx$alphaB)] <- 1.3
  for (k in 2:4) {
    expect_identical(.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, k, k),
                     .fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, other, 1e-6, k, k))
  }
  expect_error(.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, 5L, 1L),
               "unknown correlation family")
})

# The compiled core takes the layout of phi from R's model description
# (R/model-classes.R) and assumes no order of the classes: the same parameters laid
# out in another order give the same log-likelihood, moves and predictions.
test_that("the compiled core reads the layout it is given, in any class order", {
  p <- 2; q <- 2
  dat <- random_koh_data(8, 20, p, q, seed = 11)
  idx <- FBC:::param_indices(p, q)
  model <- FBC:::compiled_model(p, q)
  # the classes in reverse order: muB first, kappa last
  rev_cls <- rev(names(idx))
  len <- lengths(idx)[rev_cls]
  perm <- unlist(idx[rev_cls], use.names = FALSE)   # new position -> old position
  model2 <- model
  model2$offset[rev_cls] <- as.integer(cumsum(len) - len)
  set.seed(4)
  phis <- t(replicate(4, random_phi(p, q)))
  for (r in seq_len(nrow(phis))) {
    expect_equal(.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phis[r, perm], 1e-6, model = model2),
                 dense_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phis[r, ], 1e-6), tolerance = 1e-8)
  }
  # cached moves along a path (every class, decoys rejected on the way)
  path <- one_move_path(phis[1, ], p, q)
  expect_equal(.loglik_path(dat$Xf, dat$yf, dat$Xs, dat$ys, path[, perm, drop = FALSE], 1e-6,
                            decoys = TRUE, model = model2),
               .loglik_path(dat$Xf, dat$yf, dat$Xs, dat$ys, path, 1e-6, decoys = TRUE),
               tolerance = 1e-10)
  Xn <- matrix(runif(6), 3, p)
  for (type in 1:4) {
    expect_equal(.fbc_predict(dat$Xf, dat$yf, dat$Xs, dat$ys, phis[1:2, perm], Xn, type, 1e-6,
                              500L, model = model2),
                 .fbc_predict(dat$Xf, dat$yf, dat$Xs, dat$ys, phis[1:2, ], Xn, type, 1e-6, 500L),
                 tolerance = 1e-10)
  }
})

test_that("a layout that does not fit the data is refused", {
  dat <- random_koh_data(5, 12, 1, 1, seed = 3)
  phi <- random_phi(1, 1)
  bad <- FBC:::compiled_model(1, 2)       # two calibration inputs for data with one
  expect_error(.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, model = bad),
               "kappa 2 entries where the data need 1")
  overlap <- FBC:::compiled_model(1, 1)
  overlap$offset[["muB"]] <- 0L
  expect_error(.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, model = overlap),
               "overlap")
})

# discrepancy = "none": y_f = eta(x, kappa) + eps, no bias classes in phi.
# The compiled log-likelihood against dense_loglik(discrepancy = "none")
# (no bias block, no muB), from scratch and along cached move paths.
test_that("without a discrepancy the block log-likelihood equals the dense one", {
  for (s in sizes) {
    p <- s[["p"]]; q <- s[["q"]]
    none <- FBC:::compiled_model(p, q, discrepancy = "none")
    expect_identical(none$discrepancy, 1L)
    expect_identical(unname(none$length[c("thetaB", "alphaB", "sigma2B", "muB")]), rep(0L, 4))
    dat <- random_koh_data(s[["n"]], s[["m"]], p, q, seed = 50 + sum(s))
    for (r in 1:5) {
      phi <- random_phi(p, q, "none")
      expect_length(phi, q + 2 * (p + q) + 2)
      expect_equal(.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, model = none),
                   dense_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, discrepancy = "none"),
                   tolerance = 1e-8)
    }
    # cached moves of every class with rejected decoys; joint simulator
    # moves and the scale move of (sigma2S, sigma2E); replicated inputs
    dat$Xf <- dat$Xf[c(seq_len(s[["n"]]), 2, 1), , drop = FALSE]
    dat$yf <- c(dat$yf, rnorm(2))
    phis <- one_move_path(random_phi(p, q, "none"), p, q, "none")
    dense <- apply(phis, 1, function(phi) {
      dense_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, discrepancy = "none")
    })
    path <- .loglik_path(dat$Xf, dat$yf, dat$Xs, dat$ys, phis, 1e-6, decoys = TRUE, model = none)
    expect_equal(path, dense, tolerance = 1e-8)
    expect_joint_moves_dense(dat, phis, p, q, discrepancy = "none")
  }
})

# discrepancy = "sgasp": the bias block is sigma2B Z Rz Z' with the S-GaSP
# correlation of Gu and Wang (2018) written in plain R from the paper's
# discretized kernel (bias_corr_dense()), mean 0 (no muB), one lambdaZ. The
# compiled log-likelihood from scratch and along cached move paths
# (lambdaZ moved alone and in the bias's joint move), with replicated field
# inputs (Rz lives on the distinct inputs).
test_that("under the S-GaSP the block log-likelihood equals the dense one", {
  for (s in sizes) {
    p <- s[["p"]]; q <- s[["q"]]
    sg <- FBC:::compiled_model(p, q, discrepancy = "sgasp")
    expect_identical(sg$discrepancy, 2L)
    expect_identical(unname(sg$length[c("thetaB", "sigma2B", "muB", "lambdaZ")]), c(as.integer(p), 1L, 0L, 1L))
    dat <- random_koh_data(s[["n"]], s[["m"]], p, q, seed = 70 + sum(s))
    for (r in 1:5) {
      phi <- random_phi(p, q, "sgasp")
      expect_equal(.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, model = sg),
                   dense_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, discrepancy = "sgasp"),
                   tolerance = 1e-8)
    }
    dat$Xf <- dat$Xf[c(seq_len(s[["n"]]), 2, 1, 2), , drop = FALSE]
    dat$yf <- c(dat$yf, rnorm(3))
    phis <- one_move_path(random_phi(p, q, "sgasp"), p, q, "sgasp")
    lz <- FBC:::param_indices(p, q, "sgasp")$lambdaZ
    more <- phis[rep(nrow(phis), 3), ]
    more[, lz] <- more[1, lz] * c(0.1, 30, 1)  # strong and weak shrinkage, back
    phis <- rbind(phis, more)
    dense <- apply(phis, 1, function(phi) {
      dense_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, discrepancy = "sgasp")
    })
    path <- .loglik_path(dat$Xf, dat$yf, dat$Xs, dat$ys, phis, 1e-6, decoys = TRUE, model = sg)
    expect_equal(path, dense, tolerance = 1e-8)
    expect_joint_moves_dense(dat, phis, p, q, discrepancy = "sgasp")
  }
})

test_that("the S-GaSP shrinks towards no discrepancy and grows back to the bias GP", {
  # Rz = (R^-1 + lambda / nu I)^-1: lambda -> 0 gives R (the KOH bias GP
  # with muB = 0), lambda -> Inf gives 0 (no discrepancy)
  dat <- random_koh_data(6, 14, 1, 1, seed = 5)
  phi <- random_phi(1, 1, "sgasp")
  ix <- FBC:::param_indices(1, 1, "sgasp")
  gp <- numeric(length(unlist(FBC:::param_indices(1, 1, "gp"))))
  ig <- FBC:::param_indices(1, 1, "gp")
  for (cls in setdiff(names(ig), "muB")) gp[ig[[cls]]] <- phi[ix[[cls]]]
  ll <- function(lambda) {
    phi[ix$lambdaZ] <- lambda
    .fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6,
                model = FBC:::compiled_model(1, 1, discrepancy = "sgasp"))
  }
  expect_equal(ll(1e-9), .fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, gp, 1e-6), tolerance = 1e-6)
  nonePhi <- numeric(length(unlist(FBC:::param_indices(1, 1, "none"))))
  inn <- FBC:::param_indices(1, 1, "none")
  for (cls in names(inn)) nonePhi[inn[[cls]]] <- phi[ix[[cls]]]
  expect_equal(ll(1e12), .fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, nonePhi, 1e-6,
                                     model = FBC:::compiled_model(1, 1, discrepancy = "none")),
               tolerance = 1e-6)
})

test_that("the compiled core reads the discrepancy model off the layout and refuses one that does not fit", {
  dat <- random_koh_data(5, 12, 1, 1, seed = 3)
  # a layout from lengths named by class (R's table order)
  lay <- function(model, len) {
    model$offset <- stats::setNames(as.integer(cumsum(len) - len), names(len))
    model$length <- stats::setNames(as.integer(len), names(len))
    # (a class not in the table: its moves touch the residual only)
    roles <- FBC:::class_roles(names(len))
    model$touch <- replace(roles$touch, is.na(roles$touch), 0L)
    model$scaled <- replace(roles$scaled, is.na(roles$scaled), FALSE)
    model
  }
  gp <- FBC:::compiled_model(1, 1)
  len <- gp$length
  # the discrepancy code is not what the compiled core reads: a "none" code
  # with the bias classes laid out is the KOH model
  phi <- random_phi(1, 1)
  coded <- gp
  coded$discrepancy <- 1L
  expect_identical(.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, model = coded),
                   .fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, model = gp))
  # the bias classes without sigma2B (no bias GP)
  expect_error(.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi[-9], 1e-6,
                           model = lay(gp, replace(len, "sigma2B", 0L))),
               "thetaB 1 entries where the data need 0")
  # a bias without its length-scale
  expect_error(.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi[-6], 1e-6,
                           model = lay(gp, replace(len, "thetaB", 0L))),
               "thetaB 0 entries where the data need 1")
  # muB and lambdaZ: none, or one per output with a bias
  expect_error(.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, c(phi, 0), 1e-6,
                           model = lay(gp, replace(len, "muB", 2L))),
               "muB 2 entries where the data need 1")
  # a class the compiled core does not compute with has no say (its
  # parameters are the sampler's alone); a class it needs may not be missing
  extra <- lay(gp, c(len, zeta = 1L))
  expect_identical(.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, c(phi, 0.5), 1e-6, model = extra),
                   .fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, model = gp))
  expect_error(.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi[-1], 1e-6,
                           model = lay(gp, len[names(len) != "kappa"])),
               "kappa 0 entries where the data need 1")
  # a phi of another length than the layout's is refused, not read past
  expect_error(.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi[-length(phi)], 1e-6, model = gp),
               "phi has 10 entries where the model's layout has 11")
  expect_error(.fbc_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, c(phi, 1), 1e-6, model = gp),
               "phi has 12 entries where the model's layout has 11")
})

test_that("the help and messages list the discrepancy models of the table", {
  dm <- FBC:::discrepancy_models
  docs <- FBC:::discrepancy_docs()
  expect_match(docs, "^@param discrepancy ")
  for (i in seq_len(nrow(dm))) {
    expect_match(docs, sprintf("`\"%s\"` (%s%s)", dm$name[i], if (i == 1L) "the default, " else "",
                               dm$help[i]), fixed = TRUE)
  }
  expect_identical(FBC:::or_list(c("a", "b", "c")), "a, b or c")
  # set_hyperPriors()'s help names the models with or without a class
  hyper <- FBC:::hyper_param_docs()
  expect_false(any(grepl("{with}", hyper, fixed = TRUE) | grepl("{without}", hyper, fixed = TRUE)))
  # a model without a class says why, and the message names the models with it
  for (disc in dm$name) for (cls in FBC:::model_classes$class[!FBC:::class_in_model(disc)]) {
    why <- FBC:::discrepancy_lacks(cls, disc)
    if (!model_has(disc, "sigma2B")) expect_identical(why, "has no bias GP")
    else expect_identical(why, unname(FBC:::class_lacks[cls]))
    having <- FBC:::discrepancy_having(cls)
    for (d in FBC:::class_models(cls)) expect_match(having, sprintf("`discrepancy = \"%s\"`", d), fixed = TRUE)
    expect_no_match(having, sprintf("\"%s\"", disc), fixed = TRUE)
  }
})

test_that("without a discrepancy the sampler retains dense log-likelihoods and has no bias moves", {
  p <- 2; q <- 1
  dat <- random_koh_data(8, 20, p, q, seed = 17)
  sp <- FBC:::build_priors(list(dist = "beta", init = NA, p1 = 1.1, p2 = 1.1), set_hyperPriors(),
                           list(xmin = rep(0, p + q), xmax = rep(1, p + q), p = p, q = q),
                           p, q, "none")
  sp$model <- FBC:::compiled_model(p, q, discrepancy = "none")
  expect_identical(sp$vars, c("kappa1", "thetaS1", "thetaS2", "thetaS3", "alphaS1", "alphaS2",
                              "alphaS3", "sigma2S", "sigma2E"))
  mv <- FBC:::sampler_moves("blocks", sp)
  expect_identical(names(mv$blocks), c("kappa1", "sim"))
  expect_true(mv$scale)
  expect_false(mv$gibbsMuB)
  set.seed(5)
  res <- run_sampler(dat, sp, "blocks", 260L, 200L, 4L)
  expect_true(res$scaleAcceptance > 0 && res$scaleAcceptance < 1)
  dense <- apply(res$draws, 1, function(phi) {
    dense_loglik(dat$Xf, dat$yf, dat$Xs, dat$ys, phi, 1e-6, discrepancy = "none")
  })
  expect_equal(res$logLik, dense, tolerance = 1e-8)
})

test_that("a class a user adds (over \"asked\") has parameters only in the models given its prior", {
  # the package's table with one such class added, read by copies of the
  # functions that size the layout
  tbl <- FBC:::model_classes
  extra <- tbl[tbl$class == "muB", ]
  extra$class <- "extra"
  extra$over <- "asked"
  tbl <- rbind(tbl, extra)
  env <- list2env(list(model_classes = tbl, user_classes = tbl$class[tbl$over == "asked"]),
                  parent = asNamespace("FBC"))
  for (f in c("class_sizes", "class_in_model", "param_indices", "layout_codes", "param_names",
              "asked_classes")) {
    fn <- get(f, asNamespace("FBC"))
    environment(fn) <- env
    assign(f, fn, envir = env)
  }
  sizes <- env$class_sizes(2, 1)
  expect_identical(sizes[["extra"]], 0L)
  expect_identical(env$class_sizes(2, 1, asked = "extra")[["extra"]], 1L)
  # every other class as without it
  expect_identical(env$class_sizes(2, 1, asked = "extra")[names(FBC:::class_sizes(2, 1))],
                   FBC:::class_sizes(2, 1))
  # a model without it has the layout it had; with it, the class comes last
  expect_identical(env$layout_codes(2, 1), FBC:::layout_codes(2, 1))
  with <- env$layout_codes(2, 1, asked = "extra")
  d <- sum(FBC:::layout_codes(2, 1)$length)
  expect_identical(with$offset[["extra"]], d)
  expect_identical(with$length[["extra"]], 1L)
  expect_identical(env$param_names(2, 1, asked = "extra"), c(FBC:::param_names(2, 1), "extra"))
  # asked: by the priors (an fbc_hypers with the class) or off a compiled layout
  expect_identical(env$asked_classes(set_hyperPriors()), character())
  h <- set_hyperPriors()
  h$extra <- list(dist = "gaussian", init = 0, p1 = 0, p2 = 1)
  expect_identical(env$asked_classes(h), "extra")
  expect_identical(env$asked_classes(compiled = with), "extra")
  expect_identical(env$asked_classes(compiled = FBC:::layout_codes(2, 1)), character())
  # the package's own classes: none is asked for, so every model's layout
  # is as before
  expect_identical(FBC:::asked_classes(set_hyperPriors()), character())
})
