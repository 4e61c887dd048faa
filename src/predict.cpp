// Calibrated prediction: the GP conditional of a target given y = (yf, ys),
// one retained draw at a time, through the cached block factors of the
// posterior's algebra (Posterior::condition, model.cpp): the dense algebra
// solves with the Cholesky factor of the simulator block, the Kronecker one
// uses its eigendecompositions (no m x b solve).
//
// For a new scaled input x* with xk* = (x*, kappa), by type:
//   1 field:     eta(xk*) + delta(x*) + eps, prior mean muB, variance s2S + s2B + s2E
//   2 mean:      eta(xk*) + delta(x*),       prior mean muB, variance s2S + s2B
//   3 simulator: eta(xk*),                   prior mean 0,   variance s2S
//   4 bias:      delta(x*),                  prior mean muB, variance s2B
// New points are processed `block` rows at a time; `model` is the model
// description (read_model()); `noise` the measurement-error group of each
// new point (1-based; empty: group 1), for type 1; `source` the field data
// set of each new point (1-based), for the bias of types 1, 2 and 4 when
// each data set has its own (model$source).
#include "fbc.h"

// [[Rcpp::export(.fbc_predict_c)]]
Rcpp::List fbc_predict(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                       const arma::vec& ys, const arma::mat& phis, const arma::mat& Xnew,
                       int type, double nugget, int block, const Rcpp::List& model,
                       const Rcpp::IntegerVector& noise, const Rcpp::IntegerVector& source) {
  if (type < PT_FIELD || type > PT_BIAS) Rcpp::stop("type must be 1, 2, 3 or 4");
  std::unique_ptr<Posterior> pp = make_posterior(Xf, yf, Xs, ys, nugget, model);
  Posterior& post = *pp;
  const int p = post.p, N = Xnew.n_rows, M = phis.n_rows;
  if (Xnew.n_cols != (arma::uword)p) Rcpp::stop("Xnew must have %d columns", p);
  if (block < 1) block = 1;
  if (noise.size() != 0 && noise.size() != N) Rcpp::stop("noise must have %d groups", N);
  std::vector<int> g(N, 0);
  for (int c = 0; c < noise.size(); ++c) g[c] = noise[c] - 1;
  if (source.size() != 0 && source.size() != N) Rcpp::stop("source must have %d data sets", N);
  std::vector<int> src(N, 0);
  for (int c = 0; c < source.size(); ++c) src[c] = source[c] - 1;
  arma::mat mean(N, M), var(N, M);
  for_each_draw(post, phis, [&](arma::uword i) {
    for (int r0 = 0; r0 < N; r0 += block) {
      const int r1 = std::min(N, r0 + block) - 1;
      post.condition(Xnew.rows(r0, r1), type, mean.colptr(i) + r0, var.colptr(i) + r0,
                     g.data() + r0, source.size() ? src.data() + r0 : nullptr);
    }
    return true;
  });
  return Rcpp::List::create(Rcpp::Named("mean") = mean, Rcpp::Named("var") = var);
}
