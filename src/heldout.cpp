// Held-out predictions of the simulator runs (validate_emulator()): the
// simulator GP alone, y_s ~ N(0, sigma2S Ds), conditioned on the other runs.
// With Q = Ds^-1 and a = Q ys from the posterior's algebra (simHeldout()),
// per fold B of held-out runs (Rasmussen and Williams 2006, section 5.4.2):
//   mean_B = ys_B - (Q_BB)^-1 a_B,  var_B = sigma2S diag((Q_BB)^-1);
// a fold of one run r is its leave-one-out predictive, ys_r - a_r / Q_rr,
// sigma2S / Q_rr.
#include "fbc.h"

bool SchurPosterior::heldout(const std::vector<std::vector<int> >& folds, arma::vec& mean,
                             arma::vec& var) {
  arma::vec a;
  std::vector<arma::mat> QBB;
  simHeldout(folds, a, QBB);
  const double s2S = phi[iSigma2S];
  mean.set_size(m);
  var.set_size(m);
  arma::mat S;
  for (size_t k = 0; k < folds.size(); ++k) {
    const std::vector<int>& B = folds[k];
    if (!arma::inv_sympd(S, QBB[k])) return false;
    for (size_t i = 0; i < B.size(); ++i) {
      double sa = 0.0;
      for (size_t j = 0; j < B.size(); ++j) sa += S(i, j) * a[B[j]];
      mean[B[i]] = ys_[B[i]] - sa;
      var[B[i]] = s2S * S(i, i);
    }
  }
  return true;
}

// Held-out means and variances (scaled space) of the m simulator runs at
// each row of `phis` (m x draws matrices); run r is in fold fold[r]
// (labels 1 .. k); `model` is the model description (read_model()).
// [[Rcpp::export(.fbc_heldout_c)]]
Rcpp::List fbc_heldout(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                       const arma::vec& ys, const arma::mat& phis, double nugget,
                       const Rcpp::IntegerVector& fold, const Rcpp::List& model) {
  std::unique_ptr<Posterior> pp = make_posterior(Xf, yf, Xs, ys, nugget, model);
  Posterior& post = *pp;
  const int m = post.m, M = phis.n_rows;
  if (phis.n_cols != (arma::uword)post.d) Rcpp::stop("phis must have %d columns", post.d);
  if (fold.size() != m) Rcpp::stop("fold must have %d labels", m);
  std::vector<std::vector<int> > folds;
  for (int r = 0; r < m; ++r) {
    const int k = fold[r];
    if (k < 1 || k > m) Rcpp::stop("fold labels must be in 1..%d", m);
    if ((int)folds.size() < k) folds.resize(k);
    folds[k - 1].push_back(r);
  }
  for (const std::vector<int>& B : folds)
    if (B.empty()) Rcpp::stop("fold labels must be 1..k, each used");
  arma::mat mean(m, M), var(m, M);
  arma::vec mu, v;
  for (int i = 0; i < M; ++i) {
    if (!post.init(phis.row(i).t()) || !post.heldout(folds, mu, v))
      Rcpp::stop("The covariance matrix of draw %d is not positive definite.", i + 1);
    mean.col(i) = mu;
    var.col(i) = v;
  }
  return Rcpp::List::create(Rcpp::Named("mean") = mean, Rcpp::Named("var") = var);
}
