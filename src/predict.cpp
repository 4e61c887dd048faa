// Calibrated prediction: the GP conditional of a target given y = (yf, ys),
// one retained draw at a time, through the cached block factors of Posterior.
//
// For a new scaled input x* with xk* = (x*, kappa), ks = Cov(ys, target),
// kf = Cov(yf, target), prior mean mu* and prior variance v*:
//   field:     kf = s2S Rs(Xk,xk*) + s2B Rb(Xf,x*), ks = s2S Rs(Xs,xk*),
//              mu* = muB, v* = s2S + s2B + s2E
//   mean:      as field, v* = s2S + s2B
//   simulator: kf = s2S Rs(Xk,xk*), ks = s2S Rs(Xs,xk*), mu* = 0, v* = s2S
//   bias:      kf = s2B Rb(Xf,x*), ks = 0, mu* = muB, v* = s2B
// The conditional itself is the algebra's (Posterior::condition): for the
// dense one, with g = Ls^-1 ks, a = kf - W'g, h = LS^-1 a (block inverse of C
// through the Schur complement S = LS LS'):
//   mean = mu* + g'z / s2S + h'v,   var = v* - g'g / s2S - h'h.
#include "fbc.h"

// [[Rcpp::export(.fbc_predict)]]
Rcpp::List fbc_predict(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                       const arma::vec& ys, const arma::mat& phis, const arma::mat& Xnew,
                       int type, double nugget, int block) {
  // type: 1 field, 2 mean, 3 simulator, 4 bias
  std::unique_ptr<Posterior> pp = make_posterior(Xf, yf, Xs, ys, nugget);
  Posterior& post = *pp;
  const int n = post.n, p = post.p, q = post.q, N = Xnew.n_rows, M = phis.n_rows;
  if (phis.n_cols != (arma::uword)post.d) Rcpp::stop("phis must have %d columns", post.d);
  if (Xnew.n_cols != (arma::uword)p) Rcpp::stop("Xnew must have %d columns", p);
  if (block < 1) block = 1;
  arma::mat mean(N, M), var(N, M);
  arma::mat Xk(n, p + q), Ks, Kf;
  Xk.cols(0, p - 1) = Xf;
  const bool simPart = type != 4, biasPart = type != 3;

  for (int i = 0; i < M; ++i) {
    const arma::vec phi = phis.row(i).t();
    if (!post.init(phi)) {
      Rcpp::stop("The covariance matrix of draw %d is not positive definite.", i + 1);
    }
    const arma::vec thetaS = phi.subvec(post.iThetaS, post.iAlphaS - 1);
    const arma::vec alphaS = phi.subvec(post.iAlphaS, post.iThetaB - 1);
    const arma::vec thetaB = phi.subvec(post.iThetaB, post.iAlphaB - 1);
    const arma::vec alphaB = phi.subvec(post.iAlphaB, post.iSigma2S - 1);
    const double s2S = phi[post.iSigma2S], s2B = phi[post.iSigma2B];
    const double s2E = phi[post.iSigma2E], muB = phi[post.iMuB];
    const arma::rowvec kappa = phi.subvec(post.iKappa, post.iThetaS - 1).t();
    for (int j = 0; j < q; ++j) Xk.col(p + j).fill(kappa[j]);
    double mu0 = 0.0, v0 = 0.0;
    switch (type) {
      case 1: mu0 = muB; v0 = s2S + s2B + s2E; break;
      case 2: mu0 = muB; v0 = s2S + s2B; break;
      case 3: mu0 = 0.0; v0 = s2S; break;
      default: mu0 = muB; v0 = s2B; break;
    }

    for (int r0 = 0; r0 < N; r0 += block) {
      const int r1 = std::min(N, r0 + block) - 1, b = r1 - r0 + 1;
      const arma::mat xs = Xnew.rows(r0, r1);
      arma::mat xk(b, p + q);
      xk.cols(0, p - 1) = xs;
      for (int j = 0; j < q; ++j) xk.col(p + j).fill(kappa[j]);
      Kf.zeros(n, b);
      Ks.zeros(Xs.n_rows, b);
      if (simPart) {
        Ks = s2S * corr_matrix(Xs, xk, thetaS, alphaS);
        Kf = s2S * corr_matrix(Xk, xk, thetaS, alphaS);
      }
      if (biasPart) Kf += s2B * corr_matrix(Xf, xs, thetaB, alphaB);
      post.condition(Ks, Kf, mu0, v0, mean.colptr(i) + r0, var.colptr(i) + r0);
    }
  }
  return Rcpp::List::create(Rcpp::Named("mean") = mean, Rcpp::Named("var") = var);
}
