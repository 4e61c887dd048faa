# Plain-R GP conditional of a prediction target given y = (yf, ys), built from
# the dense joint covariance (helper-dense.R) with one explicit solve per
# target: mean = mu* + k' C^-1 (y - mu), var = v* - k' C^-1 k (scaled space).
# kernS, kernB: correlation families (dense_corr()); discrepancy "none": no
# bias (its mean and variance 0); a model without muB has bias mean 0; the
# S-GaSP's covariances are from the discretized kernel (bias_kernel_dense()).
dense_predict <- function(Xf, yf, Xs, ys, phi, Xnew, type, nugget = 1e-6, kernS = "powexp",
                          kernB = "powexp", discrepancy = "gp", noise = NULL, noiseNew = NULL,
                          levels = NULL, source = NULL, sourceNew = NULL) {
  p <- ncol(Xf); q <- ncol(Xs) - p; n <- nrow(Xf); m <- nrow(Xs)
  th <- unpack_phi(phi, p, q, discrepancy, max(noise, 1L), FBC:::level_count(levels),
                   FBC:::source_count(source))
  srcL <- if (is.null(source)) 0L else source$L
  Xb <- if (srcL) cbind(Xf, source$codes) else Xf
  Xnb <- if (srcL) cbind(Xnew, sourceNew) else Xnew
  if (discrepancy == "none") th[c("muB", "sigma2B")] <- list(0, 0)
  if (!model_has(discrepancy, "muB")) th$muB <- 0
  C <- dense_cov(Xf, Xs, phi, nugget, kernS, kernB, discrepancy, noise, levels, source)
  r <- c(yf - th$muB, ys)
  Xk <- cbind(Xf, matrix(th$kappa, n, q, byrow = TRUE))
  Xnk <- cbind(Xnew, matrix(th$kappa, nrow(Xnew), q, byrow = TRUE))
  ksim <- th$sigma2S * dense_corr(rbind(Xk, Xs), Xnk, th$thetaS, th$alphaS, kernS) *
    level_factor(rbind(Xk, Xs), Xnk, levels, th$rhoS)
  kbias <- if (discrepancy != "none") {
    rbind(th$sigma2B * bias_kernel_dense(Xb, Xnb, Xb, th, kernB, discrepancy, levels, srcL),
          matrix(0, m, nrow(Xnew)))
  } else {
    matrix(0, n + m, nrow(Xnew))
  }
  k <- switch(type, field = , mean = ksim + kbias, simulator = ksim, bias = kbias)
  mu0 <- if (type == "simulator") 0 else th$muB
  vb <- if (discrepancy == "none") 0 else
    th$sigma2B * diag(bias_kernel_dense(Xnb, Xnb, Xb, th, kernB, discrepancy, levels, srcL))
  s2E <- th$sigma2E[if (is.null(noiseNew)) rep(1L, nrow(Xnew)) else noiseNew]
  v0 <- switch(type, field = th$sigma2S + vb + s2E,
               mean = th$sigma2S + vb, simulator = th$sigma2S, bias = vb)
  list(mean = drop(mu0 + crossprod(k, solve(C, r))),
       var = v0 - colSums(k * solve(C, k)))
}

# A tiny fbc object on random data (p = 2, q = 1) with every parameter fixed
# at `phi` (sampler scale), so each retained draw equals phi; kernelS,
# kernelB: correlation families (a family without a smoothness gets no
# alpha prior: its alpha is not a parameter); discrepancy: any model, phi
# with its classes ("none": no bias classes; "sgasp": no muB, a lambdaZ),
# the priors of those it has fixed. `d`: other data on the scaled space
# (p = 2, q = 1), as random_koh_data() returns them.
fixed_fit <- function(phi, seed = 11, kernelS = "powexp", kernelB = "powexp",
                      d = random_koh_data(n = 7, m = 12, p = 2, q = 1, seed = seed),
                      discrepancy = "gp", ...) {
  # native units: inputs stretched, response shifted/scaled
  sim <- cbind(y = 3 + 2 * d$ys, x1 = 10 * d$Xs[, 1], x2 = d$Xs[, 2] - 5, t = 4 * d$Xs[, 3])
  field <- cbind(y = 3 + 2 * d$yf, x1 = 10 * d$Xf[, 1], x2 = d$Xf[, 2] - 5)
  sc <- FBC:::fbc_scale(sim, 2)
  th <- unpack_phi(phi, 2, 1, discrepancy)
  kap <- sc$xmin[3] + th$kappa * (sc$xmax[3] - sc$xmin[3])
  args <- list(
    thetaSDist = "fixed", thetaSInit = th$thetaS, alphaSDist = "fixed", alphaSInit = th$alphaS,
    thetaBDist = "fixed", thetaBInit = th$thetaB, alphaBDist = "fixed", alphaBInit = th$alphaB,
    sigma2SDist = "fixed", sigma2SInit = th$sigma2S, sigma2BDist = "fixed",
    sigma2BInit = th$sigma2B, sigma2EDist = "fixed", sigma2EInit = th$sigma2E,
    muBDist = "fixed", muBInit = th$muB)
  if (kernelS != "powexp") args[c("alphaSDist", "alphaSInit")] <- NULL
  if (kernelB != "powexp") args[c("alphaBDist", "alphaBInit")] <- NULL
  if (discrepancy == "none") args[grepl("^(thetaB|alphaB|sigma2B|muB)", names(args))] <- NULL
  if (!model_has(discrepancy, "muB")) args[grepl("^muB", names(args))] <- NULL
  if (model_has(discrepancy, "lambdaZ")) args[c("lambdaZDist", "lambdaZInit")] <- list("fixed", th$lambdaZ)
  hyp <- do.call(set_hyperPriors, args)
  # the random field inputs overhang the random design: the warning is expected
  suppressWarnings(
    calibrate(sim, field, nMCMC = 6, nBurn = 2, thinning = 2, kappaDist = "fixed",
              kappaInit = kap, hypers = hyp, kernelS = kernelS,
              # no bias GP: its family is not given (calibrate() warns it is unused)
              kernelB = if (discrepancy == "none") "matern52" else kernelB,
              discrepancy = discrepancy, ...),
    classes = "fbc_extrapolation")
}
