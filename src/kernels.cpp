// Kernels: prior log-densities, walk transformations, power-exponential
// correlation and the dense linear algebra (LAPACK/BLAS on preallocated
// storage) shared by the sampler and prediction.
#include "fbc.h"

// log p(x) for a prior family; -Inf outside the support.
//   uniform(a, b) 1/(b-a); gaussian(mean, sd); gamma(shape, rate);
//   beta(s1, s2); lognormal(meanlog, sdlog); logistic(location, scale);
//   betashift = beta(s1, s2) of x - 1; exponential(rate);
//   inversegamma(shape a, scale b) b^a/Gamma(a) x^-(a+1) exp(-b/x);
//   jeffreys 1/x (x > 0); fixed: log 1 = 0.
double log_prior(int family, double x, double p1, double p2) {
  const double ninf = R_NegInf;
  if (ISNAN(x)) return ninf;
  switch (family) {
  case PF_UNIFORM:
    return (x >= p1 && x <= p2) ? -std::log(p2 - p1) : ninf;
  case PF_GAUSSIAN:
    return R::dnorm(x, p1, p2, 1);
  case PF_GAMMA:
    return x > 0 ? R::dgamma(x, p1, 1.0 / p2, 1) : ninf;
  case PF_BETA:
    return (x >= 0 && x <= 1) ? R::dbeta(x, p1, p2, 1) : ninf;
  case PF_LOGNORMAL:
    return x > 0 ? R::dlnorm(x, p1, p2, 1) : ninf;
  case PF_LOGISTIC:
    return R::dlogis(x, p1, p2, 1);
  case PF_BETASHIFT:
    return (x >= 1 && x <= 2) ? R::dbeta(x - 1.0, p1, p2, 1) : ninf;
  case PF_EXPONENTIAL:
    return x >= 0 ? R::dexp(x, 1.0 / p1, 1) : ninf;
  case PF_INVGAMMA:
    return x > 0 ? p1 * std::log(p2) - R::lgammafn(p1) - (p1 + 1.0) * std::log(x) - p2 / x
                 : ninf;
  case PF_JEFFREYS:
    return x > 0 ? -std::log(x) : ninf;
  case PF_FIXED:
    return 0.0;
  }
  Rcpp::stop("unknown prior family code %d", family);
}

// Vectorised log prior for R's prior_builder(): x is in the prior's units.
// [[Rcpp::export(.log_prior)]]
Rcpp::NumericVector log_prior_vec(const Rcpp::NumericVector& x, int family,
                                  double p1, double p2) {
  Rcpp::NumericVector out(x.size());
  for (R_xlen_t i = 0; i < x.size(); ++i) out[i] = log_prior(family, x[i], p1, p2);
  return out;
}

// Random-walk scale w for a parameter x: identity, w = log x, or
// w = log((x - 1) / (2 - x)) for alpha in (1, 2).
double to_walk(int transform, double x) {
  switch (transform) {
  case TR_LOG: return std::log(x);
  case TR_LOGIT12: return std::log((x - 1.0) / (2.0 - x));
  default: return x;
  }
}

double from_walk(int transform, double w) {
  switch (transform) {
  case TR_LOG: return std::exp(w);
  case TR_LOGIT12: return 1.0 + 1.0 / (1.0 + std::exp(-w));
  default: return w;
  }
}

// log |dx/dw|: the Jacobian that makes a symmetric walk on w target p(x):
// log x for the log walk, log((x - 1)(2 - x)) for the logit walk.
double log_jacobian(int transform, double x) {
  switch (transform) {
  case TR_LOG: return std::log(x);
  case TR_LOGIT12: return std::log((x - 1.0) * (2.0 - x));
  default: return 0.0;
  }
}

// P(i,j) = |a_i - b_j|^alpha.
void pow_dist(const arma::vec& a, const arma::vec& b, double alpha,
              arma::mat& out, bool lower) {
  const arma::uword na = a.n_elem, nb = b.n_elem;
  for (arma::uword j = 0; j < nb; ++j) {
    double* col = out.colptr(j);
    const double bj = b[j];
    for (arma::uword i = lower ? j : 0; i < na; ++i) {
      const double d = std::fabs(a[i] - bj);
      col[i] = (alpha == 2.0) ? d * d : (alpha == 1.0 ? d : std::pow(d, alpha));
    }
  }
}

// G(i,j) = log |a_i - b_j| (-Inf where they coincide), computed once so that
// a move of alpha needs an exp per entry instead of a pow.
void log_dist(const arma::vec& a, const arma::vec& b, arma::mat& out, bool lower) {
  const arma::uword na = a.n_elem, nb = b.n_elem;
  for (arma::uword j = 0; j < nb; ++j) {
    double* col = out.colptr(j);
    const double bj = b[j];
    for (arma::uword i = lower ? j : 0; i < na; ++i) col[i] = std::log(std::fabs(a[i] - bj));
  }
}

// P(i,j) = |a_i - b_j|^alpha = exp(alpha G(i,j)) from G = log_dist(a, b).
void pow_from_log(const arma::mat& G, double alpha, arma::mat& out, bool lower) {
  const arma::uword nr = G.n_rows, nc = G.n_cols;
  for (arma::uword j = 0; j < nc; ++j) {
    const double* g = G.colptr(j);
    double* col = out.colptr(j);
    for (arma::uword i = lower ? j : 0; i < nr; ++i) col[i] = std::exp(alpha * g[i]);
  }
}

// R(i,j) = exp(-sum_k theta_k P_k(i,j)).
void corr_from_pows(const std::vector<const arma::mat*>& P,
                    const arma::vec& theta, arma::mat& out, bool lower) {
  const arma::uword nr = out.n_rows, nc = out.n_cols, K = P.size();
  for (arma::uword j = 0; j < nc; ++j) {
    double* col = out.colptr(j);
    const arma::uword i0 = lower ? j : 0;
    for (arma::uword i = i0; i < nr; ++i) col[i] = 0.0;
    for (arma::uword k = 0; k < K; ++k) {
      const double* pk = P[k]->colptr(j);
      const double t = theta[k];
      for (arma::uword i = i0; i < nr; ++i) col[i] += t * pk[i];
    }
    for (arma::uword i = i0; i < nr; ++i) col[i] = std::exp(-col[i]);
  }
}

// R(X, Y)_{ij} = prod_k exp(-theta_k |X_ik - Y_jk|^alpha_k).
arma::mat corr_matrix(const arma::mat& X, const arma::mat& Y,
                      const arma::vec& theta, const arma::vec& alpha) {
  arma::mat out(X.n_rows, Y.n_rows, arma::fill::zeros);
  arma::mat P(X.n_rows, Y.n_rows);
  for (arma::uword k = 0; k < X.n_cols; ++k) {
    pow_dist(X.col(k), Y.col(k), alpha[k], P, false);
    out += theta[k] * P;
  }
  return arma::exp(-out);
}

// [[Rcpp::export(.corr_matrix)]]
arma::mat corr_matrix_r(const arma::mat& X, const arma::mat& Y,
                        const arma::vec& theta, const arma::vec& alpha) {
  return corr_matrix(X, Y, theta, alpha);
}

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
