// Exact leave-one-out predictive densities of the field data (loo.fbc()):
// the field rows of y = (yf, ys) given all the others, in closed form from
// the joint Gaussian at one parameter vector (Rasmussen and Williams 2006,
// section 5.4.2; Burkner, Gabry and Vehtari 2021 for non-factorized
// Gaussian models). The field block of C^-1 is S^-1 (S the Schur complement
// of the simulator block), and (C^-1 (y - mu))_f = S^-1 r with
// r = yf - muB - wz the field residual given the simulator runs. For a
// group G of field rows, with P = (S^-1)_GG and a = S^-1 r:
//   y_G | rest ~ N(y_G - P^-1 a_G, P^-1),
//   log p(y_G | rest) = -0.5 (|G| log 2 pi - log|P| + a_G' P^-1 a_G).
#include "fbc.h"

void Posterior::gaussian_loo(const arma::mat& Sinv, const arma::vec& r,
                             const std::vector<std::vector<int> >& groups, arma::vec& logdens) {
  const arma::vec a = Sinv * r;
  logdens.set_size(groups.size());
  for (size_t g = 0; g < groups.size(); ++g) {
    const arma::uvec G = arma::conv_to<arma::uvec>::from(groups[g]);
    arma::mat P = Sinv.submat(G, G);
    arma::vec z = a.elem(G);
    if (!chol_lower(P)) Rcpp::stop("the leave-one-out precision is not positive definite");
    solve_lower(P, z);  // z'z = a_G' P^-1 a_G
    logdens[g] = -0.5 * (G.n_elem * LOG_2PI - logdet_chol(P) + arma::dot(z, z));
  }
}

void SchurPosterior::fieldLoo(const std::vector<std::vector<int> >& groups,
                              arma::vec& logdens) const {
  const double muB = biasMean ? phi[iMuB] : 0.0;
  arma::vec r(n);
  for (int i = 0; i < n; ++i) r[i] = yf_[i] - muB - wz_.cur()[grp_[i]];
  gaussian_loo(FS_.cur().inverse(grp_), r, groups, logdens);
}

// Log leave-one-out predictive densities (scaled space) of the field data,
// one row per row of `phis`, one column per group: field row i is in group
// group[i] (labels 1 .. k); `model` is the model description (read_model()).
// [[Rcpp::export(.fbc_loo_c)]]
Rcpp::NumericMatrix fbc_loo(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                            const arma::vec& ys, const arma::mat& phis, double nugget,
                            const Rcpp::IntegerVector& group, const Rcpp::List& model) {
  std::unique_ptr<Posterior> pp = make_posterior(Xf, yf, Xs, ys, nugget, model);
  Posterior& post = *pp;
  const int n = post.n, M = phis.n_rows;
  const std::vector<std::vector<int> > groups = label_groups(group, n, "group");
  Rcpp::NumericMatrix out(M, groups.size());
  arma::vec ld;
  for_each_draw(post, phis, [&](arma::uword s) {
    post.fieldLoo(groups, ld);
    for (size_t g = 0; g < groups.size(); ++g) out(s, g) = ld[g];
    return true;
  });
  return out;
}
