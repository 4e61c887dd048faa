// Kernels: prior log-densities, walk transformations, the kernel module (every
// correlation of both GPs) and the dense linear algebra (LAPACK/BLAS on preallocated
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

// ---- The kernel module ---------------------------------------------------
// Every correlation of both GPs is computed by the functions below, for the
// family code `kern` of that GP. Separable families:
//   R(x, x') = prod_k r(|x_k - x'_k|; theta_k, alpha_k);
//   power exponential (KF_POWEXP): r(d) = exp(-theta d^alpha).
// A new family adds its case to each function (and its code in R).

void check_kernel(int kern) {
  if (kern != KF_POWEXP) Rcpp::stop("unknown correlation family code %d", kern);
}

// P(i,j) = |a_i - b_j|^alpha (pow; exact squares and absolute values).
static void pow_dist(const arma::vec& a, const arma::vec& b, double alpha, arma::mat& out) {
  const arma::uword na = a.n_elem, nb = b.n_elem;
  for (arma::uword j = 0; j < nb; ++j) {
    double* col = out.colptr(j);
    const double bj = b[j];
    for (arma::uword i = 0; i < na; ++i) {
      const double d = std::fabs(a[i] - bj);
      col[i] = (alpha == 2.0) ? d * d : (alpha == 1.0 ? d : std::pow(d, alpha));
    }
  }
}

// Per-dimension cache of what does not move. Power exponential:
// G(i,j) = log |a_i - b_j| (-Inf where they coincide), so that a move of
// alpha needs an exp per entry instead of a pow.
void kernel_dist(int kern, const arma::vec& a, const arma::vec& b, arma::mat& out, bool lower) {
  check_kernel(kern);
  const arma::uword na = a.n_elem, nb = b.n_elem;
  for (arma::uword j = 0; j < nb; ++j) {
    double* col = out.colptr(j);
    const double bj = b[j];
    for (arma::uword i = lower ? j : 0; i < na; ++i) col[i] = std::log(std::fabs(a[i] - bj));
  }
}

// The alpha-dependent part from the cache. Power exponential:
// P(i,j) = |a_i - b_j|^alpha = exp(alpha G(i,j)).
void kernel_term(int kern, const arma::mat& G, double alpha, arma::mat& out, bool lower) {
  check_kernel(kern);
  const arma::uword nr = G.n_rows, nc = G.n_cols;
  for (arma::uword j = 0; j < nc; ++j) {
    const double* g = G.colptr(j);
    double* col = out.colptr(j);
    for (arma::uword i = lower ? j : 0; i < nr; ++i) col[i] = std::exp(alpha * g[i]);
  }
}

// The correlation from the terms. Power exponential:
// R(i,j) = exp(-sum_k theta_k P_k(i,j)).
void kernel_combine(int kern, const std::vector<const arma::mat*>& P,
                    const arma::vec& theta, arma::mat& out, bool lower) {
  check_kernel(kern);
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

// kernel_combine(kernel_term(kernel_dist(...))) with no per-dimension
// storage: the same operations in the same order, so the same numbers.
// Power exponential: R(i,j) = exp(-sum_k theta_k exp(alpha_k log|X_ik - Y_jk|)).
void kernel_corr(int kern, const arma::mat& X, const arma::mat& Y, int K, const double* theta,
                 const double* alpha, arma::mat& out, bool lower) {
  check_kernel(kern);
  const arma::uword nr = X.n_rows, nc = Y.n_rows;
  for (arma::uword j = 0; j < nc; ++j) {
    double* col = out.colptr(j);
    const arma::uword i0 = lower ? j : 0;
    for (arma::uword i = i0; i < nr; ++i) col[i] = 0.0;
    for (int k = 0; k < K; ++k) {
      const double* x = X.colptr(k);
      const double yj = Y.at(j, k), t = theta[k], a = alpha[k];
      for (arma::uword i = i0; i < nr; ++i)
        col[i] += t * std::exp(a * std::log(std::fabs(x[i] - yj)));
    }
    for (arma::uword i = i0; i < nr; ++i) col[i] = std::exp(-col[i]);
  }
}

// Packed lower-triangle storage of a symmetric m x m quantity: entry (i, j),
// i >= j, at packed_offset(j, m) + i - j.
size_t packed_offset(size_t j, size_t m) { return j * m - j * (j - 1) / 2; }

// kernel_dist(a, a, lower) in packed storage (m (m + 1) / 2 doubles).
void kernel_dist_packed(int kern, const arma::vec& a, std::vector<double>& G) {
  check_kernel(kern);
  const size_t m = a.n_elem;
  G.resize(m * (m + 1) / 2);
  for (size_t j = 0; j < m; ++j) {
    double* g = G.data() + packed_offset(j, m);
    const double aj = a[j];
    for (size_t i = j; i < m; ++i) g[i - j] = std::log(std::fabs(a[i] - aj));
  }
}

// kernel_corr(X, X, lower) with the per-dimension packed kernel_dist()
// caches G[k] where given (non-null), on the fly elsewhere: the same numbers.
void kernel_corr_self(int kern, const arma::mat& X, int K, const double* theta,
                      const double* alpha, const std::vector<const double*>& G,
                      arma::mat& out) {
  check_kernel(kern);
  const size_t m = X.n_rows;
  for (size_t j = 0; j < m; ++j) {
    double* col = out.colptr(j);
    for (size_t i = j; i < m; ++i) col[i] = 0.0;
    for (int k = 0; k < K; ++k) {
      const double t = theta[k], a = alpha[k];
      if (k < (int) G.size() && G[k]) {
        const double* g = G[k] + packed_offset(j, m) - j;
        for (size_t i = j; i < m; ++i) col[i] += t * std::exp(a * g[i]);
      } else {
        const double* x = X.colptr(k);
        const double xj = x[j];
        for (size_t i = j; i < m; ++i) col[i] += t * std::exp(a * std::log(std::fabs(x[i] - xj)));
      }
    }
    for (size_t i = j; i < m; ++i) col[i] = std::exp(-col[i]);
  }
}

// out_i = prod_l r(|X(i, col0 + l) - point_l|; theta_l, alpha_l), l < K.
// Power exponential: exp(-sum_l theta_l |X(i, col0 + l) - point_l|^alpha_l).
void kernel_corr_point(int kern, const arma::mat& X, int col0, int K, const double* point,
                       const double* theta, const double* alpha, arma::vec& out) {
  check_kernel(kern);
  const int nr = X.n_rows;
  out.zeros();
  for (int l = 0; l < K; ++l) {
    const double kap = point[l], th = theta[l], al = alpha[l];
    const double* xs = X.colptr(col0 + l);
    for (int i = 0; i < nr; ++i) out[i] += th * std::pow(std::fabs(xs[i] - kap), al);
  }
  for (int i = 0; i < nr; ++i) out[i] = std::exp(-out[i]);
}

// R(X, Y)_{ij} = prod_k r(|X_ik - Y_jk|; theta_k, alpha_k).
arma::mat corr_matrix(const arma::mat& X, const arma::mat& Y,
                      const arma::vec& theta, const arma::vec& alpha, int kern) {
  check_kernel(kern);
  arma::mat out(X.n_rows, Y.n_rows, arma::fill::zeros);
  arma::mat P(X.n_rows, Y.n_rows);
  for (arma::uword k = 0; k < X.n_cols; ++k) {
    pow_dist(X.col(k), Y.col(k), alpha[k], P);
    out += theta[k] * P;
  }
  return arma::exp(-out);
}

// [[Rcpp::export(.corr_matrix)]]
arma::mat corr_matrix_r(const arma::mat& X, const arma::mat& Y,
                        const arma::vec& theta, const arma::vec& alpha, int kernel = 1) {
  return corr_matrix(X, Y, theta, alpha, kernel);
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
