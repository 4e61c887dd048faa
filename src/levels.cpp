// The categorical inputs' level correlations (R/factors.R).
//
// A categorical input with L levels enters the data as indicator columns
// (one for two levels, [x = l_2]; one per level from three, [x = l_a]).
// Both GPs hold the indicators' thetaS and thetaB at 0 (they add nothing to
// the separable kernel) and multiply the kernel by the levels' correlation:
//   R((x, a), (x', b)) = R_num(x, x') C[a, b],
// with C an unstructured L x L correlation matrix, positive definite by
// construction from its L (L - 1) / 2 canonical partial correlations z in
// (-1, 1) (Lewandowski, Kurowicka and Joe 2009; Stan's corr_matrix), taken
// column by column: z(1,0), ..., z(L-1,0), z(2,1), ..., z(L-1,L-2). z(i,0)
// is the correlation of levels i and 0; z(i,j), j > 0, the partial
// correlation of levels i and j given levels 0 .. j-1. The lower Cholesky
// factor W of C has rows
//   W[i,0] = z(i,0),  W[i,j] = z(i,j) sqrt(1 - sum_{k<j} W[i,k]^2),
//   W[i,i] = sqrt(1 - sum_{k<i} W[i,k]^2),   C = W W'.
#include "fbc.h"

int level_count(const std::vector<LevelInput>& in) {
  int n = 0;
  for (const LevelInput& f : in) n += f.L * (f.L - 1) / 2;
  return n;
}

void level_corr(const std::vector<LevelInput>& in, const double* z,
                std::vector<arma::mat>& C) {
  C.resize(in.size());
  for (size_t f = 0; f < in.size(); ++f) {
    const int L = in[f].L;
    arma::mat W(L, L, arma::fill::zeros);
    W(0, 0) = 1.0;
    // the CPCs of this input, column by column
    arma::mat Z(L, L, arma::fill::zeros);
    for (int j = 0; j < L - 1; ++j)
      for (int i = j + 1; i < L; ++i) Z(i, j) = *z++;
    for (int i = 1; i < L; ++i) {
      double acc = 0.0;
      for (int j = 0; j < i; ++j) {
        W(i, j) = Z(i, j) * std::sqrt(std::max(0.0, 1.0 - acc));
        acc += W(i, j) * W(i, j);
      }
      W(i, i) = std::sqrt(std::max(0.0, 1.0 - acc));
    }
    C[f] = W * W.t();
    C[f].diag().ones();
  }
}

// The level (0-based) of row i of X for input f, read off its indicators.
int level_of(const arma::mat& X, arma::uword i, const LevelInput& f) {
  if (f.ncol == 1) return X.at(i, f.col) > 0.5 ? 1 : 0;
  int best = 0;
  for (int a = 1; a < f.ncol; ++a)
    if (X.at(i, f.col + a) > X.at(i, f.col + best)) best = a;
  return best;
}

// out(i, j) *= C[a[i], b[j]] over the first nr rows and nc columns of out
// (lower: only i >= j).
static void scale_by_codes(const arma::mat& C, const int* a, const int* b, arma::uword nr,
                           arma::uword nc, arma::mat& out, bool lower) {
  for (arma::uword j = 0; j < nc; ++j) {
    const double* cj = C.colptr(b[j]);
    double* col = out.colptr(j);
    for (arma::uword i = lower ? j : 0; i < nr; ++i) col[i] *= cj[a[i]];
  }
}

void level_scale(const std::vector<LevelInput>& in, const std::vector<arma::mat>& C,
                 const arma::mat& X, const arma::mat& Y, arma::mat& out, bool lower,
                 int rows) {
  if (in.empty()) return;
  const arma::uword nr = rows < 0 ? X.n_rows : rows, nc = rows < 0 ? Y.n_rows : rows;
  std::vector<int> a(nr), b(nc);
  for (size_t f = 0; f < in.size(); ++f) {
    for (arma::uword i = 0; i < nr; ++i) a[i] = level_of(X, i, in[f]);
    for (arma::uword j = 0; j < nc; ++j) b[j] = level_of(Y, j, in[f]);
    scale_by_codes(C[f], a.data(), b.data(), nr, nc, out, lower);
  }
}

void source_scale(int L, const double* z, const int* a, const int* b, arma::mat& out,
                  bool lower) {
  std::vector<LevelInput> in(1);
  in[0].L = L;
  std::vector<arma::mat> C;
  level_corr(in, z, C);
  scale_by_codes(C[0], a, b, out.n_rows, out.n_cols, out, lower);
}

void level_scale(const std::vector<LevelInput>& in, const double* z, const arma::mat& X,
                 const arma::mat& Y, arma::mat& out, bool lower) {
  if (in.empty()) return;
  std::vector<arma::mat> C;
  level_corr(in, z, C);
  level_scale(in, C, X, Y, out, lower);
}

// The level correlations from their partial correlations, for R
// (level_correlation() and the tests): one matrix per categorical input.
// [[Rcpp::export(.level_corr)]]
Rcpp::List level_corr_r(const Rcpp::IntegerVector& L, const arma::vec& z) {
  std::vector<LevelInput> in(L.size());
  for (int f = 0; f < L.size(); ++f) {
    if (L[f] < 2) Rcpp::stop("a categorical input needs at least 2 levels");
    in[f].L = L[f];
  }
  if ((int) z.n_elem != level_count(in))
    Rcpp::stop("%d partial correlations given where the levels need %d", (int) z.n_elem,
               level_count(in));
  std::vector<arma::mat> C;
  level_corr(in, z.memptr(), C);
  Rcpp::List out(C.size());
  for (size_t f = 0; f < C.size(); ++f) out[f] = C[f];
  return out;
}
