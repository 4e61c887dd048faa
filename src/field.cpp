// The field block's covariance given the simulator runs, S = D + Z M Z'
// (n x n): D the field rows' noise variances, Z each row's distinct row
// (grp), M the distinct rows' part (nu x nu: the emulator's conditional
// and the bias). FieldFactor::factor() factors it; with replicated rows
// (nu < n) on the distinct rows alone (Woodbury): with N = Z' D^-1 Z
// (diagonal) and K = I + N^1/2 M N^1/2,
//   log|S| = sum_i log d_i + log|K|,
//   S = D^1/2 F0 F0' D^1/2,  F0 = (I - U U') + U LK U',  LK = chol(K),
// U = D^-1/2 Z N^-1/2 (orthonormal columns), so that F0^-1 D^-1/2 is a
// whitening of S and S^-1 x = D^-1/2 (y + U (K^-1 c - c)) with y = D^-1/2 x,
// c = U' y: O(nu^3 + n) where the n x n factor costs O(n^3).
#include "fbc.h"

bool FieldFactor::factor(const arma::mat& M, const std::vector<int>& grp, const arma::vec& dv,
                         bool reduce, double floor) {
  const int n = grp.size(), nu = M.n_rows;
  reduced = reduce;
  double dmax = 0;
  if (!reduced) {
    L.set_size(n, n);
    for (int j = 0; j < n; ++j) {
      const int gj = grp[j];
      double* sc = L.colptr(j);
      for (int i = j; i < n; ++i) {
        const int gi = grp[i];
        sc[i] = M.at(std::max(gi, gj), std::min(gi, gj));
      }
      sc[j] += dv[j];
      dmax = std::max(dmax, sc[j]);
    }
    if (!chol_lower(L)) return false;
    if (floor > 0 && arma::min(L.diag()) < std::sqrt(floor * dmax)) return false;
    logdet = logdet_chol(L);
    return true;
  }
  d = dv;
  sd = arma::sqrt(d);
  sN.zeros(nu);
  for (int i = 0; i < n; ++i) sN[grp[i]] += 1.0 / d[i];
  sN = arma::sqrt(sN);
  L.set_size(nu, nu);
  for (int c = 0; c < nu; ++c) {
    for (int r = c; r < nu; ++r) L.at(r, c) = sN[r] * sN[c] * M.at(r, c);
    L.at(c, c) += 1.0;
    dmax = std::max(dmax, L.at(c, c));
  }
  if (!chol_lower(L)) return false;
  if (floor > 0 && arma::min(L.diag()) < std::sqrt(floor * dmax)) return false;
  logdet = logdet_chol(L) + arma::accu(arma::log(d));
  return true;
}

// Y = D^-1/2 X (in place) and C = U' Y (nu x k); sd = sqrt(d).
static void reduce_cols(const arma::vec& sd, const arma::vec& sN, const std::vector<int>& grp,
                        arma::mat& X, arma::mat& C) {
  const int n = grp.size();
  C.zeros(sN.n_elem, X.n_cols);
  for (arma::uword k = 0; k < X.n_cols; ++k) {
    double* x = X.colptr(k);
    double* c = C.colptr(k);
    for (int i = 0; i < n; ++i) {
      x[i] /= sd[i];
      c[grp[i]] += x[i] / sd[i];
    }
    for (arma::uword g = 0; g < sN.n_elem; ++g) c[g] /= sN[g];
  }
}

// X += U E (E nu x k).
static void add_u(const arma::vec& sd, const arma::vec& sN, const std::vector<int>& grp,
                  const arma::mat& E, arma::mat& X) {
  const int n = grp.size();
  for (arma::uword k = 0; k < X.n_cols; ++k) {
    double* x = X.colptr(k);
    const double* e = E.colptr(k);
    for (int i = 0; i < n; ++i) x[i] += e[grp[i]] / (sd[i] * sN[grp[i]]);
  }
}

// X <- L'^-1 X (L lower triangular).
static void back_solve(const arma::mat& L, arma::mat& X) {
  X = arma::solve(arma::trimatu(arma::trimatl(L).t()), X);
}

// The distinct rows' form of whiten() (back false: D^-1/2 X + U (LK^-1 C -
// C)) and of solve() (back true: D^-1/2 (D^-1/2 X + U (K^-1 C - C))), C =
// U' D^-1/2 X.
static void reduced_apply(const FieldFactor& F, const std::vector<int>& grp, arma::mat& X,
                          bool back) {
  arma::mat C;
  reduce_cols(F.sd, F.sN, grp, X, C);
  arma::mat E = C;
  solve_lower(F.L, E);
  if (back) back_solve(F.L, E);
  E -= C;
  add_u(F.sd, F.sN, grp, E, X);
  if (back) X.each_col() /= F.sd;
}

void FieldFactor::whiten(arma::mat& X, const std::vector<int>& grp) const {
  if (reduced) { reduced_apply(*this, grp, X, false); return; }
  solve_lower(L, X);
}

void FieldFactor::whiten(arma::vec& x, const std::vector<int>& grp) const {
  arma::mat X(x.memptr(), x.n_elem, 1, false, true);
  whiten(X, grp);
}

void FieldFactor::solve(arma::mat& X, const std::vector<int>& grp) const {
  if (reduced) { reduced_apply(*this, grp, X, true); return; }
  solve_lower(L, X);
  back_solve(L, X);
}

void FieldFactor::solve(arma::vec& x, const std::vector<int>& grp) const {
  arma::mat X(x.memptr(), x.n_elem, 1, false, true);
  solve(X, grp);
}

arma::mat FieldFactor::inverse(const std::vector<int>& grp) const {
  if (!reduced) {
    const arma::mat Li = arma::inv(arma::trimatl(L));
    return Li.t() * Li;
  }
  arma::mat X(grp.size(), grp.size(), arma::fill::eye);
  solve(X, grp);
  return X;
}

void FieldFactor::scale(double c) {
  logdet += (reduced ? d.n_elem : L.n_rows) * std::log(c);
  if (!reduced) { L = std::sqrt(c) * L; return; }
  d *= c;
  sd *= std::sqrt(c);
  sN /= std::sqrt(c);
}
