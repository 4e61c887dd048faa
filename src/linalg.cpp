// Dense linear algebra on preallocated storage (LAPACK/BLAS), shared by the
// sampler and prediction.
#include "fbc.h"

bool chol_lower(arma::mat& A) {
  char uplo = 'L';
  arma::blas_int n = A.n_rows, info = 0;
  arma::lapack::potrf(&uplo, &n, A.memptr(), &n, &info);
  return info == 0;
}

double logdet_chol(const arma::mat& L) {
  double s = 0.0;
  for (arma::uword i = 0; i < L.n_rows; ++i) s += std::log(L.at(i, i));
  return 2.0 * s;
}

static void trsm_lower(const arma::mat& L, double* B, arma::blas_int nrhs) {
  char uplo = 'L', trans = 'N', diag = 'N';
  arma::blas_int n = L.n_rows, info = 0;
  arma::lapack::trtrs(&uplo, &trans, &diag, &n, &nrhs, L.memptr(), &n, B, &n, &info);
}

void solve_lower(const arma::mat& L, arma::vec& x) { trsm_lower(L, x.memptr(), 1); }
void solve_lower(const arma::mat& L, arma::mat& X) {
  trsm_lower(L, X.memptr(), X.n_cols);
}

void syrk_lower(const arma::mat& A, double alpha, double beta, arma::mat& C) {
  char uplo = 'L', trans = 'T';
  arma::blas_int n = A.n_cols, k = A.n_rows;
  arma::blas::syrk(&uplo, &trans, &n, &k, &alpha, A.memptr(), &k, &beta, C.memptr(), &n);
}
