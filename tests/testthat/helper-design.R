# The sinusoid of Koermer et al. (2024), eta(x, u) = sin(10 u x), without
# its bias: m scattered runs on [0, 1]^2 (a Latin hypercube), 5 field
# inputs x 2 replicates at u = pi / 5, noise sd 0.1.
sinus_problem <- function(m = 12, seed = 1) {
  set.seed(seed)
  u <- (sample(m) - stats::runif(m)) / m
  x <- (sample(m) - stats::runif(m)) / m
  xf <- rep(seq(0.1, 0.9, length.out = 5), 2)
  list(sim = data.frame(y = sin(10 * u * x), x = x, u = u),
       field = data.frame(y = sin(10 * pi / 5 * xf) + stats::rnorm(10, 0, 0.1), x = xf))
}
# `fit` with every adapted proposal's step made exp(6) = 400 times its
# (sampler-scale) sd: as after several reweighted steps whose runs
# narrowed the posterior, its moves accept almost nothing.
stale_proposals <- function(fit) {
  for (k in seq_along(fit$state$chains)) {
    st <- fit$state$chains[[k]]$sampler
    st$logsd[] <- 6
    for (b in seq_along(st$blocks)) st$blocks[[b]]$logscale <- 6
    fit$state$chains[[k]]$sampler <- st
  }
  fit
}

# The look-ahead of propose_runs() in plain R: the reference its C++
# (src/design.cpp) is checked against (test-design.R). This is the
# implementation the package ran before the criterion moved to C++ (dense
# algebra throughout), with the random numbers drawn as look_ahead()
# (R/propose_runs.R) draws them: the fantasies' draws by systematic
# resampling of the base weights (one uniform), then per step a random
# order of the normal quantiles.

# One draw's Gaussian system (scaled data): the joint covariance C of
# (ys, yf) under phi, its Cholesky factor, and for the candidates U the
# conditional means `mu` and variances `v` of a new run's value (nugget
# included) with A = L^-1 Cov(data, U) for the cross-covariances of a
# batch; `ll` the log-likelihood, `corr` the simulator kernel at phi. With
# target points XT (scaled experimental inputs): the calibrated
# prediction's (predict(type = "mean")) means mT and variances VT there and
# its covariances CTU (T x Nc) with the candidates' values, given the data.
draw_system <- function(phi, model, U, XT = NULL) {
  dat <- model$data
  d <- model$dims
  p <- d$p
  q <- d$q
  ix <- FBC:::param_indices(p, q, model$discrepancy, noise = d$noise, levels = d$levels,
                            sources = d$sources)
  kS <- FBC:::kernel_codes[[model$kernelS]]
  thS <- phi[ix$thetaS]
  alS <- phi[ix$alphaS]
  s2S <- phi[ix$sigma2S]
  # categorical inputs: the kernel times each one's level correlation
  # C[a(x), a(y)], the levels read off the indicator columns
  fac <- model$scale$factors
  nm <- c(model$scale$names$inputs, model$scale$names$calibration)
  levels_corr <- function(X, Y, z) {
    if (!length(fac)) return(1)
    Cs <- FBC:::.level_corr(vapply(fac, function(f) length(f$levels), 1L), z)
    out <- 1
    for (i in seq_along(fac)) {
      j <- match(fac[[i]]$columns, nm)
      out <- out * Cs[[i]][FBC:::indicator_codes(X[, j, drop = FALSE]),
                           FBC:::indicator_codes(Y[, j, drop = FALSE])]
    }
    out
  }
  corr <- function(X, Y) FBC:::.corr_matrix(X, Y, thS, alS, kS) * levels_corr(X, Y, phi[ix$rhoS])
  Z <- rbind(dat$Xs, cbind(dat$Xf, matrix(phi[ix$kappa], d$n, q, byrow = TRUE)))
  C <- s2S * corr(Z, Z)
  sim <- seq_len(d$m)
  fld <- d$m + seq_len(d$n)
  C[cbind(sim, sim)] <- C[cbind(sim, sim)] * (1 + FBC:::fbc_nugget)
  # a stochastic simulator (constant noise): each unique input's mean has
  # the noise variance sigma2R / n_i
  reps <- model$spec$model$replicates
  if (!is.null(reps)) {
    C[cbind(sim, sim)] <- C[cbind(sim, sim)] + phi[model$spec$classes == "sigma2R"] / reps$count
  }
  mu0 <- rep(0, d$m + d$n)
  bias <- model$discrepancy != "none"
  if (bias) {
    kB <- FBC:::kernel_codes[[model$kernelB]]
    corrB <- function(X, Y) {
      FBC:::.corr_matrix(X, Y, phi[ix$thetaB], phi[ix$alphaB], kB) * levels_corr(X, Y, phi[ix$rhoB])
    }
    # a bias per data set: the biases of data sets a and b correlated by
    # D[a, b] (their level correlation from rhoD); sx, sy the rows' data
    # sets (NULL: one bias)
    src <- model$spec$model$source
    D <- if (!is.null(src)) FBC:::.level_corr(model$spec$model$sourceLevels, phi[ix$rhoD])[[1]]
    corrD <- function(X, sx, Y, sy) if (is.null(sx)) corrB(X, Y) else corrB(X, Y) * D[sx, sy]
    Rb <- corrD(dat$Xf, src, dat$Xf, src)
    if (model$discrepancy == "sgasp") {
      # the S-GaSP (Gu and Wang 2018): the bias GP discretized on the
      # field's nu distinct inputs Xu (within a data set with a bias each),
      # Kz(x, x') = R(x, x') - R(x, Xu) (R(Xu, Xu) + nu / lambdaZ I)^-1 R(Xu, x')
      first <- !duplicated(cbind(dat$Xf, src))
      Xu <- dat$Xf[first, , drop = FALSE]
      su <- src[first]
      M <- solve(corrD(Xu, su, Xu, su) + nrow(Xu) / phi[ix$lambdaZ] * diag(nrow(Xu)))
      sgasp <- function(X, sx, Y, sy) corrD(X, sx, Y, sy) - corrD(X, sx, Xu, su) %*% M %*% corrD(Xu, su, Y, sy)
      Rb <- sgasp(dat$Xf, src, dat$Xf, src)
    }
    C[fld, fld] <- C[fld, fld] + phi[ix$sigma2B] * Rb
    if (length(ix$muB)) mu0[fld] <- phi[ix$muB]
  }
  # each field row's noise variance: its data set's (noise group's)
  C[cbind(fld, fld)] <- C[cbind(fld, fld)] + phi[ix$sigma2E][if (is.null(model$spec$model$noise)) 1L else model$spec$model$noise]
  R <- chol(C)
  r <- backsolve(R, c(dat$ys, dat$yf) - mu0, transpose = TRUE)
  A <- backsolve(R, s2S * corr(Z, U), transpose = TRUE)
  out <- list(A = A, mu = drop(crossprod(A, r)), v = s2S * (1 + FBC:::fbc_nugget) - colSums(A^2),
              ll = -0.5 * sum(r^2) - sum(log(diag(R))), s2S = s2S, corr = corr)
  if (length(XT)) {
    Tk <- cbind(XT, matrix(phi[ix$kappa], nrow(XT), q, byrow = TRUE))
    KT <- s2S * corr(Z, Tk)
    vB <- 0
    if (bias) {
      s2B <- phi[ix$sigma2B]
      if (model$discrepancy == "sgasp") {
        KT[fld, ] <- KT[fld, ] + s2B * sgasp(dat$Xf, NULL, XT, NULL)
        vB <- s2B * diag(sgasp(XT, NULL, XT, NULL))
      } else {
        KT[fld, ] <- KT[fld, ] + s2B * corrB(dat$Xf, XT)
        vB <- s2B
      }
    }
    KT <- backsolve(R, KT, transpose = TRUE)
    out$mT <- mu0[d$m + 1] + drop(crossprod(KT, r))
    out$VT <- s2S + vB - colSums(KT^2)
    out$CTU <- s2S * corr(Tk, U) - crossprod(KT, A)
  }
  out
}

# draw_system() with independent outputs (outputs = "independent"): each
# output o's system from its own rows and parameters (phi's output-o
# copies, kappa, and the sigma2E of its noise groups, as OutputsPosterior
# maps them), put together as one draw's: A block-diagonal over the outputs
# (a candidate's column nonzero in its output's rows only), mu, v, mT, VT
# from its output's system, ll the sum, CTU zero between outputs, and the
# prior covariance `corr` (with s2S 1): output o's s2S_o R_o(x, y) between
# two points of output o, 0 between outputs.
draw_system_outputs <- function(phi, model, U, XT = NULL) {
  d <- model$dims
  K <- d$outputs
  sc <- model$scale
  jo <- match(sc$output$columns, c(sc$names$inputs, sc$names$calibration))
  out_of <- function(X) FBC:::indicator_codes(X[, jo, drop = FALSE])
  noise <- model$spec$model$noise
  if (is.null(noise)) noise <- rep(1L, d$n)
  cls <- FBC:::param_class_of(d$p, d$q, model$discrepancy, noise = d$noise, levels = d$levels,
                              sources = d$sources, outputs = K)
  own <- FBC:::param_output_of(d$p, d$q, model$discrepancy, noise = d$noise, levels = d$levels,
                               sources = d$sources, outputs = K)
  ixE <- which(cls == "sigma2E")
  oU <- out_of(U)
  oT <- if (length(XT)) out_of(XT)
  blocks <- lapply(seq_len(K), function(o) {
    rf <- model$data$outF == o
    rs <- model$data$outS == o
    groups <- sort(unique(noise[rf]))
    keep <- own == o | (own == 0 & cls != "sigma2E") | seq_along(cls) %in% ixE[groups]
    mo <- model
    mo$data <- list(Xf = model$data$Xf[rf, , drop = FALSE], yf = model$data$yf[rf],
                    Xs = model$data$Xs[rs, , drop = FALSE], ys = model$data$ys[rs])
    mo$dims$n <- sum(rf)
    mo$dims$m <- sum(rs)
    mo$dims$noise <- length(groups)
    mo$scale$factors <- sc$factors[names(sc$factors) != sc$output$name]
    mo$spec$model$noise <- match(noise[rf], groups)
    if (!is.null(mo$spec$model$source)) mo$spec$model$source <- model$spec$model$source[rf]
    draw_system(phi[keep], mo, U[oU == o, , drop = FALSE],
                if (length(XT)) XT[oT == o, , drop = FALSE])
  })
  Nc <- nrow(U)
  No <- vapply(blocks, function(b) nrow(b$A), 1L)
  out <- list(A = matrix(0, sum(No), Nc), mu = numeric(Nc), v = numeric(Nc),
              ll = sum(vapply(blocks, `[[`, 1, "ll")), s2S = 1)
  for (o in seq_len(K)) {
    out$A[sum(No[seq_len(o - 1)]) + seq_len(No[o]), oU == o] <- blocks[[o]]$A
    out$mu[oU == o] <- blocks[[o]]$mu
    out$v[oU == o] <- blocks[[o]]$v
  }
  out$corr <- function(X, Y) {
    oX <- out_of(X)
    oY <- out_of(Y)
    C <- matrix(0, nrow(X), nrow(Y))
    for (o in seq_len(K)) {
      C[oX == o, oY == o] <- blocks[[o]]$s2S *
        blocks[[o]]$corr(X[oX == o, , drop = FALSE], Y[oY == o, , drop = FALSE])
    }
    C
  }
  if (length(XT)) {
    out$mT <- out$VT <- numeric(nrow(XT))
    out$CTU <- matrix(0, nrow(XT), Nc)
    for (o in unique(oT)) {
      out$mT[oT == o] <- blocks[[o]]$mT
      out$VT[oT == o] <- blocks[[o]]$VT
      out$CTU[oT == o, oU == o] <- blocks[[o]]$CTU
    }
  }
  out
}

# The greedy look-ahead over the particles' systems `sys`: n points chosen
# one at a time, each maximising the expected reduction of kappa's
# (weighted) posterior variance with the pending points' fantasised values
# (Y, one column per pending point, nfantasy rows) conditioned on per draw.
# With targets (sys from draw_system(XT =)) the criterion is the calibrated
# prediction's variance averaged over them (target_var()).
look_ahead_r <- function(sys, parts, U, model, n, nfantasy, entropy = FALSE, noise = NULL) {
  S <- length(sys)
  lw0 <- parts$lw0 + if (isTRUE(parts$plugin)) vapply(sys, `[[`, numeric(1), "ll") else 0
  kap <- parts$kappa
  w0 <- exp(lw0 - max(lw0))
  targets <- !is.null(sys[[1]]$mT)
  variance <- if (targets) {
    cond0 <- pending_conditionals(sys, U, integer(), matrix(0, nfantasy, 0))
    target_var(w0 / sum(w0), cond0$MT[, , 1], cond0$VTP)
  } else {
    kappa_crit(kap, entropy, matrix(w0 / sum(w0)))
  }
  # each fantasy j comes from draw src[j] (systematic resampling by the base weights)
  cw <- cumsum(w0)
  usrc <- (seq_len(nfantasy) - stats::runif(1)) / nfantasy  # systematic resampling
  src <- vapply(usrc, function(u) min(S, which(cw >= u * cw[S])[1]), 1L)
  zs <- vapply(seq_len(n), function(k) stats::qnorm((sample.int(nfantasy) - 0.5) / nfantasy),
               numeric(nfantasy))
  scores <- matrix(0, nrow(U), n)
  chosen <- integer()
  gain <- numeric()
  YP <- matrix(0, nfantasy, 0)
  base <- matrix(lw0, S, nfantasy)  # log-weights given the pending fantasies
  for (step in seq_len(n)) {
    cond <- pending_conditionals(sys, U, chosen, YP, noise)
    sc <- score_candidates(cond, src, matrix(zs, nfantasy)[, step], base, kap, entropy)
    sc$gain[chosen] <- -Inf
    scores[, step] <- sc$gain
    best <- which.max(sc$gain)
    chosen <- c(chosen, best)
    gain <- c(gain, sc$gain[best])
    YP <- cbind(YP, sc$Y[best, ])
    base <- base + matrix(sc$logd[, best + (seq_len(nfantasy) - 1L) * nrow(U)], S, nfantasy)
  }
  list(chosen = chosen, gain = gain, variance = variance, scores = scores)
}

# Sum over the columns of kap of the variances under each column of the
# normalised weights W (S x K): a K-vector.
weighted_var <- function(kap, W) {
  colSums(W * rowSums(kap^2)) - colSums(crossprod(kap, W)^2)
}

# The entropy of each column of the normalised weights W, -sum w log w
# (0 log 0 = 0): kappa's entropy on the plug-in's kappa values.
weighted_entropy <- function(W) -colSums(ifelse(W > 0, W * log(W), 0))

# The kappa criterion: its entropy or its variance.
kappa_crit <- function(kap, entropy, W) if (entropy) weighted_entropy(W) else weighted_var(kap, W)

# The calibrated prediction's variance averaged over the targets under the
# normalised weights w (S), each draw's predictive means MT and variances
# VT (S x T): the mixture's variance per target (law of total variance).
target_var <- function(w, MT, VT) {
  MT <- matrix(MT, length(w))
  mean(colSums(w * (VT + MT^2)) - colSums(w * MT)^2)
}

# Per draw, each candidate's value given the data and the pending points'
# fantasised values YP (nfantasy x k): conditional means M (array S x Nc x
# nfantasy, as S x (Nc nfantasy)) and variances cv (S x Nc). With targets
# also their means MT (S x T x J), variances VTP (S x T) and covariances with
# the candidates CP (S x T x Nc), given the pending points.
pending_conditionals <- function(sys, U, P, YP, noise = NULL) {
  S <- length(sys)
  Nc <- nrow(U)
  J <- nrow(YP)
  M <- matrix(0, S, Nc * J)
  cv <- matrix(0, S, Nc)
  nT <- length(sys[[1]]$mT)
  MT <- array(0, c(S, nT, J))
  VTP <- matrix(0, S, nT)
  CP <- array(0, c(S, nT, Nc))
  for (s in seq_len(S)) {
    y <- sys[[s]]
    # a run's value: eta plus the simulator's noise (S x Nc, noise[s, c])
    if (!is.null(noise)) y$v <- y$v + noise[s, ]
    if (nT) {
      MT[s, , ] <- y$mT
      VTP[s, ] <- y$VT
      CP[s, , ] <- y$CTU
    }
    if (length(P)) {
      AP <- y$A[, P, drop = FALSE]
      SPP <- y$s2S * y$corr(U[P, , drop = FALSE], U[P, , drop = FALSE])
      diag(SPP) <- diag(SPP) * (1 + FBC:::fbc_nugget) + if (is.null(noise)) 0 else noise[s, P]
      SPP <- SPP - crossprod(AP)
      ScP <- y$s2S * y$corr(U, U[P, , drop = FALSE]) - crossprod(y$A, AP)
      ScP[P, ] <- SPP  # a candidate at a pending point: its own covariance
      B <- t(solve(SPP, t(ScP)))
      cv[s, ] <- y$v - rowSums(B * ScP)
      M[s, ] <- as.vector(y$mu + B %*% (t(YP) - y$mu[P]))
      if (nT) {
        CTP <- y$CTU[, P, drop = FALSE]
        BT <- t(solve(SPP, t(CTP)))
        VTP[s, ] <- y$VT - rowSums(BT * CTP)
        MT[s, , ] <- y$mT + BT %*% (t(YP) - y$mu[P])
        CP[s, , ] <- y$CTU - BT %*% t(ScP)
      }
    } else {
      cv[s, ] <- y$v
      M[s, ] <- rep(y$mu, J)
    }
  }
  cv <- pmax(cv, 1e-12 * vapply(sys, `[[`, numeric(1), "s2S"))
  list(M = M, cv = cv, J = J, Nc = Nc, MT = MT, VTP = VTP, CP = CP, nT = nT)
}

# Expected posterior variance of kappa after a run at each candidate, given
# the pending points: fantasy j of candidate c is draw src[j]'s conditional
# value (z[j] its normal deviate, common to every candidate); the draws are
# reweighted by its density under each. Returns the expected variance's
# reduction (gain), the fantasised values Y (Nc x J) and the log-densities.
score_candidates <- function(cond, src, z, base, kap, entropy = FALSE) {
  S <- nrow(cond$cv)
  Nc <- cond$Nc
  J <- length(src)
  cols <- seq_len(Nc) + rep((seq_len(J) - 1L) * Nc, each = Nc)  # (c, j), c fastest
  sdv <- sqrt(cond$cv)
  Y <- matrix(cond$M[cbind(rep(src, each = Nc), cols)] +
                sdv[cbind(rep(src, each = Nc), rep(seq_len(Nc), J))] * rep(z, each = Nc), Nc, J)
  logd <- stats::dnorm(matrix(rep(as.vector(Y), each = S), S), cond$M,
                       sdv[, rep(seq_len(Nc), J), drop = FALSE], log = TRUE)
  L <- logd + base[, rep(seq_len(J), each = Nc), drop = FALSE]
  L <- exp(L - rep(apply(L, 2, max), each = S))
  W <- L / rep(colSums(L), each = S)
  b <- exp(base - rep(apply(base, 2, max), each = S))
  b <- b / rep(colSums(b), each = S)
  if (cond$nT == 0) {
    after <- rowMeans(matrix(kappa_crit(kap, entropy, W), Nc, J))
    before <- mean(kappa_crit(kap, entropy, b))
  } else {
    # per draw the run at c moves the targets' means by b (y - M) and their
    # variances by -b CP, b = CP / cv
    after <- vapply(seq_len(Nc), function(c) {
      B <- matrix(cond$CP[, , c], S) / cond$cv[, c]
      mean(vapply(seq_len(J), function(j) {
        e <- Y[c, j] - cond$M[, c + (j - 1L) * Nc]
        target_var(W[, c + (j - 1L) * Nc], matrix(cond$MT[, , j], S) + B * e,
                   pmax(cond$VTP - B * matrix(cond$CP[, , c], S), 0))
      }, numeric(1)))
    }, numeric(1))
    before <- mean(vapply(seq_len(J), function(j) target_var(b[, j], cond$MT[, , j], cond$VTP),
                          numeric(1)))
  }
  list(gain = before - after, Y = Y, logd = logd)
}

# look_ahead_r() for runs of K values (several outputs: a run gives every
# output): the candidates U are runs of K rows (rows (r - 1) K + 1:K), a
# run's K values fantasised jointly from their joint Gaussian given the
# data and the pending runs' values, the draws reweighted by its K-variate
# density (with targets the prediction's means and variances moved by the
# run's K values); step k's deviates are the columns (k - 1) K + 1:K of
# the normal quantiles, drawn as look_ahead() draws them.
look_ahead_runs_r <- function(sys, parts, U, model, n, nfantasy, K, entropy = FALSE) {
  S <- length(sys)
  Nr <- nrow(U) / K
  J <- nfantasy
  lw0 <- parts$lw0 + if (isTRUE(parts$plugin)) vapply(sys, `[[`, numeric(1), "ll") else 0
  kap <- parts$kappa
  w0 <- exp(lw0 - max(lw0))
  targets <- !is.null(sys[[1]]$mT)
  cond0 <- pending_conditionals(sys, U, integer(), matrix(0, J, 0))
  variance <- if (targets) target_var(w0 / sum(w0), cond0$MT[, , 1], cond0$VTP) else
    kappa_crit(kap, entropy, matrix(w0 / sum(w0)))
  cw <- cumsum(w0)
  usrc <- (seq_len(J) - stats::runif(1)) / J
  src <- vapply(usrc, function(u) min(S, which(cw >= u * cw[S])[1]), 1L)
  zs <- vapply(seq_len(n * K), function(k) stats::qnorm((sample.int(J) - 0.5) / J), numeric(J))
  zs <- matrix(zs, J)
  norm_w <- function(L) {
    w <- exp(L - max(L))
    w / sum(w)
  }
  scores <- matrix(0, Nr, n)
  chosen <- integer()
  P <- integer()
  gain <- numeric()
  YP <- matrix(0, J, 0)
  base <- matrix(lw0, S, J)
  for (step in seq_len(n)) {
    cond <- pending_conditionals(sys, U, P, YP)
    # per draw the covariance of every candidate row's value given the
    # data and the pending points (a run's block is what is needed)
    Cov <- lapply(seq_len(S), function(s) {
      y <- sys[[s]]
      C <- y$s2S * y$corr(U, U)
      diag(C) <- diag(C) * (1 + FBC:::fbc_nugget)
      C <- C - crossprod(y$A)
      # given the pending rows' values (P: rows of U)
      if (length(P)) C <- C - C[, P, drop = FALSE] %*% solve(C[P, P, drop = FALSE], C[P, , drop = FALSE])
      C
    })
    M <- array(cond$M, c(S, nrow(U), J))
    before <- mean(vapply(seq_len(J), function(j) {
      b <- norm_w(base[, j])
      if (targets) target_var(b, cond$MT[, , j], cond$VTP) else kappa_crit(kap, entropy, matrix(b))
    }, numeric(1)))
    # the log-density of run r's values y under each draw, in fantasy j,
    # and (targets) each draw's moved means and variances
    dens <- function(r, j, y) {
      idx <- (r - 1L) * K + seq_len(K)
      vapply(seq_len(S), function(s) {
        Sig <- Cov[[s]][idx, idx]
        L <- t(chol(Sig))
        e <- forwardsolve(L, y - M[s, idx, j])
        -0.5 * sum(e^2) - sum(log(diag(L)))
      }, numeric(1))
    }
    fantasy <- function(r, j) {
      idx <- (r - 1L) * K + seq_len(K)
      s <- src[j]
      M[s, idx, j] + drop(t(chol(Cov[[s]][idx, idx])) %*% zs[j, (step - 1L) * K + seq_len(K)])
    }
    g <- vapply(seq_len(Nr), function(r) {
      if (r %in% chosen) return(-Inf)
      idx <- (r - 1L) * K + seq_len(K)
      after <- mean(vapply(seq_len(J), function(j) {
        y <- fantasy(r, j)
        w <- norm_w(base[, j] + dens(r, j, y))
        if (!targets) return(kappa_crit(kap, entropy, matrix(w)))
        nT <- cond$nT
        mt <- matrix(0, S, nT)
        vt <- matrix(0, S, nT)
        for (s in seq_len(S)) {
          Sig <- Cov[[s]][idx, idx]
          CPs <- matrix(cond$CP[s, , idx], nT)
          mt[s, ] <- cond$MT[s, , j] + CPs %*% solve(Sig, y - M[s, idx, j])
          vt[s, ] <- pmax(cond$VTP[s, ] - rowSums((CPs %*% solve(Sig)) * CPs), 0)
        }
        target_var(w, mt, vt)
      }, numeric(1)))
      before - after
    }, numeric(1))
    scores[, step] <- g
    best <- which.max(g)
    chosen <- c(chosen, best)
    gain <- c(gain, g[best])
    Yb <- t(vapply(seq_len(J), function(j) fantasy(best, j), numeric(K)))
    for (j in seq_len(J)) base[, j] <- base[, j] + dens(best, j, Yb[j, ])
    P <- c(P, (best - 1L) * K + seq_len(K))
    YP <- cbind(YP, matrix(Yb, J))
  }
  list(chosen = chosen, gain = gain, variance = variance, scores = scores)
}

# Checks on propose_runs()'s runs for two_outputs() (helper-outputs.R):
# their inputs (no output column), in the runs' ranges, none at a run.
expect_two_output_runs <- function(pr, sim) {
  expect_named(pr, c("x", "t", "gain"))
  expect_true(all(pr$x >= min(sim$x) & pr$x <= max(sim$x)))
  expect_true(all(pr$t >= min(sim$t) & pr$t <= max(sim$t)))
  expect_false(any(paste(pr$x, pr$t) %in% paste(sim$x, sim$t)))
}

# A design_loop() of two_outputs()' functions on its field's inner inputs:
# 5 starting runs, then a batch of 2 and the budget's last run (`...` to
# calibrate()). Checks that f is called once per run with the run's rows
# at each output (the output column a factor), that runs are counted as
# runs, and that each row's response is its output's. Returns the loop.
two_output_loop <- function(field, ...) {
  f1 <- function(x, t) 5 * exp(-t * x)
  f2 <- function(x, t) 2 * t * x
  f <- function(x, kappa) {
    stopifnot(is.factor(x$out), identical(as.character(x$out), c("conc", "rate")))
    ifelse(x$out == "conc", f1(x$x, kappa[["t"]]), f2(x$x, kappa[["t"]]))
  }
  set.seed(3)
  out <- suppressWarnings(design_loop(f, field[field$x > 0.1 & field$x < 0.9, ],
                                      lower = c(x = 0, t = 0.5), upper = c(x = 1, t = 3),
                                      n0 = 5, batch = 2, budget = 3, output = "out",
                                      discrepancy = "none", nMCMC = 600, nBurn = 200,
                                      nChains = 1, design = list(ndraws = 40, nfantasy = 20),
                                      showProgress = FALSE, ...))
  expect_equal(out$history$runs, c(5, 7, 8))
  expect_equal(nrow(out$sim), 16)
  expect_equal(out$fit$model$dims$m, 16)
  expect_equal(out$sim$out, rep(c("conc", "rate"), 8))
  expect_equal(out$sim$x[c(TRUE, FALSE)], out$sim$x[c(FALSE, TRUE)])
  expect_equal(out$sim$y, ifelse(out$sim$out == "conc", f1(out$sim$x, out$sim$t),
                                 f2(out$sim$x, out$sim$t)))
  out
}

# every hyperparameter fixed (scaled units): kappa alone is sampled, so its
# posterior is a 1-D grid (helper-grid.R)
sinus_hypers <- function() {
  set_hyperPriors(thetaSDist = "fixed", thetaSInit = c(8, 8), sigma2SDist = "fixed",
                  sigma2SInit = 1, sigma2EDist = "fixed", sigma2EInit = 0.02)
}
sinus_fit <- function(pb, nMCMC = 4200, seed = 3) {
  set.seed(seed)
  calibrate(pb$sim, pb$field, discrepancy = "none", hypers = sinus_hypers(), nMCMC = nMCMC,
            nBurn = 200, nChains = 1, showProgress = FALSE)
}
# a short fit of the sinusoid, hyperparameters sampled (600 sweeps): the
# draws the look-ahead's checks against plain R start from
short_fit <- function(pb, discrepancy = "none", nChains = 1, seed = 4) {
  set.seed(seed)
  calibrate(pb$sim, pb$field, discrepancy = discrepancy, nMCMC = 600, nBurn = 200,
            nChains = nChains, showProgress = FALSE)
}
sinus_loglik <- function(d) {
  function(phi) dense_loglik(d$Xf, d$yf, d$Xs, d$ys, phi, fbc_nugget, "matern52", "matern52",
                             discrepancy = "none")
}
