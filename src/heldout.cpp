// Held-out predictions of the simulator runs (emulator_cv()): the
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

// The rows of each label: labels[i] in 1 .. k (k <= n, each used) for the n
// rows; group g - 1 holds the rows labelled g, in order. `what` names the
// labels in the errors.
std::vector<std::vector<int> > label_groups(const Rcpp::IntegerVector& labels, int n,
                                            const char* what) {
  if (labels.size() != n) Rcpp::stop("%s must have %d labels", what, n);
  std::vector<std::vector<int> > groups;
  for (int i = 0; i < n; ++i) {
    const int k = labels[i];
    if (k < 1 || k > n) Rcpp::stop("%s labels must be in 1..%d", what, n);
    if ((int)groups.size() < k) groups.resize(k);
    groups[k - 1].push_back(i);
  }
  for (const std::vector<int>& G : groups)
    if (G.empty()) Rcpp::stop("%s labels must be 1..k, each used", what);
  return groups;
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
  const std::vector<std::vector<int> > folds = label_groups(fold, m, "fold");
  arma::mat mean(m, M), var(m, M);
  arma::vec mu, v;
  for_each_draw(post, phis, [&](arma::uword i) {
    if (!post.heldout(folds, mu, v)) return false;
    mean.col(i) = mu;
    var.col(i) = v;
    return true;
  });
  return Rcpp::List::create(Rcpp::Named("mean") = mean, Rcpp::Named("var") = var);
}
