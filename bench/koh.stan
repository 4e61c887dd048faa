// The Kennedy-O'Hagan model of FBC (calibrate() defaults), written
// independently in Stan for the mixing benchmark (bench/mixing.R).
// Scaled space as in calibrate(): inputs in [0, 1], responses standardized;
// kappa on [0, 1] (native kappa = lo + rng * kappa).
//   y = (yf, ys) ~ N((muB 1_n, 0_m), C),
//   C = [ s2S Rs(Xk,Xk) + s2B Rb(Xf,Xf) + s2E I    s2S Rs(Xk,Xs)          ]
//       [ s2S Rs(Xs,Xk)                           s2S (Rs(Xs,Xs) + nug I) ]
//   R(x, x') = prod_k exp(-theta_k |x_k - x'_k|^alpha_k), Xk = (Xf, kappa).
// Priors (FBC's defaults): kappa ~ Beta(1.1, 1.1) on [0, 1] (stretched over
// the design range: the constant -log(rng) is added so that the density
// equals FBC's), theta ~ Gamma(1.1, rate 0.1), alpha - 1 ~ Beta(5, 2),
// s2S, s2B, s2E ~ InvGamma(1.5, 1.5), muB ~ N(0, 1). Every prior family's
// parameters come in as data. target += ..._lpdf keeps every constant so
// that log_prob() can be compared with FBC's log posterior.
functions {
  matrix corr(matrix X, matrix Y, vector theta, vector alpha) {
    int nx = rows(X);
    int ny = rows(Y);
    matrix[nx, ny] R;
    for (i in 1:nx) {
      for (j in 1:ny) {
        real s = 0;
        for (k in 1:cols(X)) {
          real dd = fabs(X[i, k] - Y[j, k]);
          if (dd > 0) s += theta[k] * pow(dd, alpha[k]);
        }
        R[i, j] = exp(-s);
      }
    }
    return R;
  }
}
data {
  int<lower=1> n;
  int<lower=1> m;
  int<lower=1> p;
  int<lower=1> q;
  matrix[n, p] Xf;
  vector[n] yf;
  matrix[m, p + q] Xs;
  vector[m] ys;
  real<lower=0> nugget;
  vector[q] kappaLogRange;   // log of each calibration input's design range
  real kappaP1;
  real kappaP2;
  real thetaP1;
  real thetaP2;
  real alphaP1;
  real alphaP2;
  real sigmaP1;
  real sigmaP2;
  real muP1;
  real muP2;
}
transformed data {
  vector[n + m] y = append_row(yf, ys);
}
parameters {
  vector<lower=0, upper=1>[q] kappa;
  vector<lower=0>[p + q] thetaS;
  vector<lower=1, upper=2>[p + q] alphaS;
  vector<lower=0>[p] thetaB;
  vector<lower=1, upper=2>[p] alphaB;
  real<lower=0> sigma2S;
  real<lower=0> sigma2B;
  real<lower=0> sigma2E;
  real muB;
}
model {
  matrix[n, p + q] Xk;
  matrix[n + m, n + m] C;
  vector[n + m] mu = append_row(rep_vector(muB, n), rep_vector(0, m));
  Xk[, 1:p] = Xf;
  for (l in 1:q) Xk[, p + l] = rep_vector(kappa[l], n);
  C[1:n, 1:n] = sigma2S * corr(Xk, Xk, thetaS, alphaS)
                + sigma2B * corr(Xf, Xf, thetaB, alphaB)
                + diag_matrix(rep_vector(sigma2E, n));
  C[(n + 1):(n + m), 1:n] = sigma2S * corr(Xs, Xk, thetaS, alphaS);
  C[1:n, (n + 1):(n + m)] = C[(n + 1):(n + m), 1:n]';
  C[(n + 1):(n + m), (n + 1):(n + m)] =
      sigma2S * add_diag(corr(Xs, Xs, thetaS, alphaS), nugget);
  target += multi_normal_cholesky_lpdf(y | mu, cholesky_decompose(C));
  target += beta_lpdf(kappa | kappaP1, kappaP2) - sum(kappaLogRange);
  target += gamma_lpdf(thetaS | thetaP1, thetaP2) + gamma_lpdf(thetaB | thetaP1, thetaP2);
  for (k in 1:(p + q)) target += beta_lpdf(alphaS[k] - 1 | alphaP1, alphaP2);
  for (k in 1:p) target += beta_lpdf(alphaB[k] - 1 | alphaP1, alphaP2);
  target += inv_gamma_lpdf(sigma2S | sigmaP1, sigmaP2)
            + inv_gamma_lpdf(sigma2B | sigmaP1, sigmaP2)
            + inv_gamma_lpdf(sigma2E | sigmaP1, sigmaP2);
  target += normal_lpdf(muB | muP1, muP2);
}
