// The kernel module: every correlation of both GPs, for the family chosen per GP.
#include "fbc.h"

// Every correlation of both GPs is computed by the functions below, for the
// family code `kern` of that GP. Separable families,
//   R(x, x') = prod_k r(d_k),  d_k = |x_k - x'_k|,  h_k = sqrt(theta_k) d_k:
//   power exponential (PowExp):  r = exp(-theta d^alpha);
//   Gaussian (Gaussian):         r = exp(-theta d^2);
//   Matern 3/2 (Matern32):       r = (1 + sqrt(3) h) exp(-sqrt(3) h);
//   Matern 5/2 (Matern52):       r = (1 + sqrt(5) h + 5 h^2 / 3) exp(-sqrt(5) h).
// All are 1 - c theta d^2 + ... near 0 (c = 1, 3/2, 5/6) but the power
// exponential with alpha < 2. Every function works through the same three
// per-dimension steps, so the cached and on-the-fly paths give the same
// numbers: a fixed value g(d) (dist: log d, d^2 or d), a term t(g, alpha)
// (term: exp(alpha g) for the power exponential, g for the others) and an
// accumulation over dimensions with coefficient c(theta) (coef), finished
// once per entry (finish):
//   power exponential, Gaussian: s += theta t,  r = exp(-s);
//   Matern (poly):  a = sqrt(3 or 5) sqrt(theta) t,  s += a,  w *= poly(a),
//            r = w exp(-s)  (poly(a) = 1 + a, or 1 + a + a^2 / 3).
// A family is one struct with its code and name (R/correlation.R's
// `kernels` table must agree: check_model_codes() at load), whether it has
// a smoothness alpha, and these steps; a new family is its struct and its
// entry in `Kernels`.

// The defaults: no smoothness, exp(-sum theta g) (w, the Matern product,
// unused).
struct KernelBase {
  static constexpr bool alpha = false;
  static double term(double g, double) { return g; }
  static double coef(double theta) { return theta; }
  static void accum(double c, double t, double& s, double&) { s += c * t; }
  static double finish(double s, double) { return std::exp(-s); }
};
struct PowExp : KernelBase {
  static constexpr int code = 1; static const char* name() { return "powexp"; }
  static constexpr bool alpha = true;
  static double dist(double d) { return std::log(std::fabs(d)); }
  static double term(double g, double alpha) { return std::exp(alpha * g); }
};
struct Gaussian : KernelBase {
  static constexpr int code = 2; static const char* name() { return "gaussian"; }
  static double dist(double d) { const double a = std::fabs(d); return a * a; }
};
// The Matern families: s the sum in the exponent, w the product of the
// polynomials poly(a) (M::factor).
template <class M> struct MaternBase : KernelBase {
  static double dist(double d) { return std::fabs(d); }
  static void accum(double c, double t, double& s, double& w) {
    const double a = c * t;
    s += a;
    w *= M::factor(a);
  }
  // w exp(-s) <= 1; beyond exp(-700) w could overflow in products of many
  // dimensions: go through logs there
  static double finish(double s, double w) {
    return s < 700.0 ? w * std::exp(-s) : std::exp(std::log(w) - s);
  }
};
struct Matern32 : MaternBase<Matern32> {
  static constexpr int code = 3; static const char* name() { return "matern32"; }
  static double coef(double theta) { return std::sqrt(3.0 * theta); }
  static double factor(double a) { return 1.0 + a; }
};
struct Matern52 : MaternBase<Matern52> {
  static constexpr int code = 4; static const char* name() { return "matern52"; }
  static double coef(double theta) { return std::sqrt(5.0 * theta); }
  static double factor(double a) { return 1.0 + a + a * a / 3.0; }
};

// The families, the one list.
template <class... Ks> struct KernelList {};
using Kernels = KernelList<PowExp, Gaussian, Matern32, Matern52>;

// f(K()) for the family K whose code is kern (an error for no family).
template <class F> static void for_kernel(int kern, F, KernelList<>) {
  Rcpp::stop("unknown correlation family code %d", kern);
}
template <class F, class K, class... Ks>
static void for_kernel(int kern, F f, KernelList<K, Ks...>) {
  if (kern == K::code) f(K()); else for_kernel(kern, f, KernelList<Ks...>());
}
// Calls fn<K>(args...) for the family K of code kern.
#define KERNEL_DISPATCH(kern, fn, ...) \
  for_kernel(kern, [&](auto k) { fn<decltype(k)>(__VA_ARGS__); }, Kernels())

void check_kernel(int kern) { for_kernel(kern, [](auto) {}, Kernels()); }

bool kernel_has_alpha(int kern) {
  bool a = false;
  for_kernel(kern, [&](auto k) { a = decltype(k)::alpha; }, Kernels());
  return a;
}

// The families' codes by name, and the names of those with a smoothness
// (.model_codes(): R's table is checked against them).
template <class... Ks> static Rcpp::List kernel_table_of(KernelList<Ks...>) {
  Rcpp::IntegerVector code = Rcpp::IntegerVector::create(int(Ks::code)...);
  code.names() = Rcpp::CharacterVector::create(Ks::name()...);
  Rcpp::CharacterVector alpha;
  for (const auto& a : {std::make_pair(bool(Ks::alpha), Ks::name())...}) if (a.first) alpha.push_back(a.second);
  return Rcpp::List::create(Rcpp::Named("code") = code, Rcpp::Named("alpha") = alpha);
}
Rcpp::List kernel_table() { return kernel_table_of(Kernels()); }

// out(i, j) = f(a_i - b_j) (lower: i >= j only).
template <class Fn>
static void outer_fill(const arma::vec& a, const arma::vec& b, arma::mat& out, bool lower, Fn f) {
  for (arma::uword j = 0; j < b.n_elem; ++j) {
    double* col = out.colptr(j);
    const double bj = b[j];
    for (arma::uword i = lower ? j : 0; i < a.n_elem; ++i) col[i] = f(a[i] - bj);
  }
}

// Per-dimension cache of what does not move: G(i,j) = g(a_i - b_j) (power
// exponential: log |a_i - b_j|, -Inf where they coincide, so that a move of
// alpha needs an exp per entry instead of a pow).
template <class F>
static void kernel_dist_t(const arma::vec& a, const arma::vec& b, arma::mat& out, bool lower) {
  outer_fill(a, b, out, lower, F::dist);
}
void kernel_dist(int kern, const arma::vec& a, const arma::vec& b, arma::mat& out, bool lower) {
  KERNEL_DISPATCH(kern, kernel_dist_t, a, b, out, lower);
}

// The alpha-dependent part from the cache: P(i,j) = exp(alpha G(i,j)) =
// |a_i - b_j|^alpha for the power exponential; the families without a
// smoothness have none (P = G: callers use G itself, see kernel_has_alpha()).
template <class F>
static void kernel_term_t(const arma::mat& G, double alpha, arma::mat& out, bool lower) {
  const arma::uword nr = G.n_rows, nc = G.n_cols;
  for (arma::uword j = 0; j < nc; ++j) {
    const double* g = G.colptr(j);
    double* col = out.colptr(j);
    for (arma::uword i = lower ? j : 0; i < nr; ++i) col[i] = F::term(g[i], alpha);
  }
}
void kernel_term(int kern, const arma::mat& G, double alpha, arma::mat& out, bool lower) {
  KERNEL_DISPATCH(kern, kernel_term_t, G, alpha, out, lower);
}

// Column j of a correlation, rows i0 .. nr - 1:
//   col_i = finish(accumulate_k over coef(theta_k) t_k(i))
// (power exponential: exp(-sum_k theta_k t_k(i))), dim(k) giving dimension
// k's terms t_k as a function of the row; w a workspace of nr doubles (the
// Matern products). Every correlation below goes through it, so the cached
// and on-the-fly paths give the same numbers.
template <class F, class Dim>
static void corr_column(double* col, double* w, arma::uword i0, arma::uword nr, int K,
                        const double* theta, Dim dim) {
  for (arma::uword i = i0; i < nr; ++i) { col[i] = 0.0; w[i] = 1.0; }
  for (int k = 0; k < K; ++k) {
    const double c = F::coef(theta[k]);
    const auto t = dim(k);
    for (arma::uword i = i0; i < nr; ++i) F::accum(c, t(i), col[i], w[i]);
  }
  for (arma::uword i = i0; i < nr; ++i) col[i] = F::finish(col[i], w[i]);
}

// The correlation from the cached terms P_k.
template <class F>
static void kernel_combine_t(const std::vector<const arma::mat*>& P, const arma::vec& theta,
                             arma::mat& out, bool lower) {
  std::vector<double> w(out.n_rows);
  for (arma::uword j = 0; j < out.n_cols; ++j)
    corr_column<F>(out.colptr(j), w.data(), lower ? j : 0, out.n_rows, P.size(), theta.memptr(),
                   [&](int k) {
                     const double* pk = P[k]->colptr(j);
                     return [=](arma::uword i) { return pk[i]; };
                   });
}
void kernel_combine(int kern, const std::vector<const arma::mat*>& P,
                    const arma::vec& theta, arma::mat& out, bool lower) {
  KERNEL_DISPATCH(kern, kernel_combine_t, P, theta, out, lower);
}

// kernel_combine(kernel_term(kernel_dist(...))) with no per-dimension
// storage: the same operations in the same order, so the same numbers.
template <class F>
static void kernel_corr_t(const arma::mat& X, const arma::mat& Y, int K, const double* theta,
                          const double* alpha, arma::mat& out, bool lower) {
  std::vector<double> w(X.n_rows);
  for (arma::uword j = 0; j < Y.n_rows; ++j)
    corr_column<F>(out.colptr(j), w.data(), lower ? j : 0, X.n_rows, K, theta, [&](int k) {
      const double* x = X.colptr(k);
      const double yj = Y.at(j, k), a = alpha[k];
      return [=](arma::uword i) { return F::term(F::dist(x[i] - yj), a); };
    });
}
void kernel_corr(int kern, const arma::mat& X, const arma::mat& Y, int K, const double* theta,
                 const double* alpha, arma::mat& out, bool lower) {
  KERNEL_DISPATCH(kern, kernel_corr_t, X, Y, K, theta, alpha, out, lower);
}

// The Vecchia algebra's small systems as flat sets of entries: the lower
// triangle of the first s rows of X, column by column (entry e: column j,
// rows i = j .. s - 1), ne = s (s + 1) / 2 entries. Per dimension k the
// fixed values G[k ne + e] = dist(X_ik - X_jk) (vecchia.cpp caches them per
// run: the runs' conditioning sets never change).
template <class F>
static void kernel_dist_tri_t(const arma::mat& X, int s, int K, double* G) {
  for (int k = 0; k < K; ++k) {
    const double* x = X.colptr(k);
    for (int j = 0; j < s; ++j) {
      const double xj = x[j];
      for (int i = j; i < s; ++i) *G++ = F::dist(x[i] - xj);
    }
  }
}
void kernel_dist_tri(int kern, const arma::mat& X, int s, int K, double* G) {
  KERNEL_DISPATCH(kern, kernel_dist_tri_t, X, s, K, G);
}

// The correlations of ne flat entries from their per-dimension values G:
//   out_e = finish(accumulate_k coef(theta_k) term(G[k ne + e], alpha_k)),
// each entry in the same operations and order as kernel_corr() (so the
// same numbers whether G was cached or just computed). w: ne doubles of
// workspace (the Matern products).
template <class F>
static void kernel_corr_flat_t(const double* G, size_t ne, int K, const double* theta,
                               const double* alpha, double* out, double* w) {
  for (size_t e = 0; e < ne; ++e) { out[e] = 0.0; w[e] = 1.0; }
  for (int k = 0; k < K; ++k) {
    const double* g = G + (size_t) k * ne;
    const double c = F::coef(theta[k]), a = alpha[k];
    for (size_t e = 0; e < ne; ++e) F::accum(c, F::term(g[e], a), out[e], w[e]);
  }
  // finish(0, w) = w exp(-0) = w (the diagonal, coinciding inputs): no exp
  for (size_t e = 0; e < ne; ++e) out[e] = out[e] == 0.0 ? w[e] : F::finish(out[e], w[e]);
}
void kernel_corr_flat(int kern, const double* G, size_t ne, int K, const double* theta,
                      const double* alpha, double* out, double* w) {
  KERNEL_DISPATCH(kern, kernel_corr_flat_t, G, ne, K, theta, alpha, out, w);
}

size_t packed_offset(size_t j, size_t m) { return j * m - j * (j - 1) / 2; }

// kernel_dist(a, a, lower) in packed storage (m (m + 1) / 2 doubles): the
// flat entries of kernel_dist_tri() for one dimension are that layout.
void kernel_dist_packed(int kern, const arma::vec& a, std::vector<double>& G) {
  G.resize(a.n_elem * (a.n_elem + 1) / 2);
  kernel_dist_tri(kern, a, a.n_elem, 1, G.data());
}

template <class F>
static void kernel_corr_self_t(const arma::mat& X, int K, const double* theta,
                               const double* alpha, const std::vector<const double*>& G,
                               arma::mat& out) {
  const size_t m = X.n_rows;
  std::vector<double> w(m);
  for (size_t j = 0; j < m; ++j)
    corr_column<F>(out.colptr(j), w.data(), j, m, K, theta, [&](int k) {
      // g: the cache's column j, indexed by row as a column of out is
      const double* g = k < (int) G.size() && G[k] ? G[k] + packed_offset(j, m) - j : nullptr;
      const double* x = X.colptr(k);
      const double xj = x[j], a = alpha[k];
      return [=](arma::uword i) { return F::term(g ? g[i] : F::dist(x[i] - xj), a); };
    });
}
void kernel_corr_self(int kern, const arma::mat& X, int K, const double* theta,
                      const double* alpha, const std::vector<const double*>& G,
                      arma::mat& out) {
  KERNEL_DISPATCH(kern, kernel_corr_self_t, X, K, theta, alpha, G, out);
}

// out_i = prod_l r(|X(i, col0 + l) - point_l|; theta_l, alpha_l), l < K.
// Power exponential: exp(-sum_l theta_l |X(i, col0 + l) - point_l|^alpha_l).
template <class F>
static void kernel_corr_point_t(const arma::mat& X, int col0, int K, const double* point,
                                const double* theta, const double* alpha, arma::vec& out) {
  const arma::uword nr = X.n_rows;
  std::vector<double> w(nr);
  corr_column<F>(out.memptr(), w.data(), 0, nr, K, theta, [&](int l) {
    const double kap = point[l], al = alpha[l];
    const double* xs = X.colptr(col0 + l);
    return [=](arma::uword i) {
      return F::alpha ? std::pow(std::fabs(xs[i] - kap), al) : F::dist(xs[i] - kap);
    };
  });
}
void kernel_corr_point(int kern, const arma::mat& X, int col0, int K, const double* point,
                       const double* theta, const double* alpha, arma::vec& out) {
  KERNEL_DISPATCH(kern, kernel_corr_point_t, X, col0, K, point, theta, alpha, out);
}

arma::mat corr_matrix(const arma::mat& X, const arma::mat& Y,
                      const arma::vec& theta, const arma::vec& alpha, int kern) {
  check_kernel(kern);
  if (kern == PowExp::code) {
    arma::mat out(X.n_rows, Y.n_rows, arma::fill::zeros);
    arma::mat P(X.n_rows, Y.n_rows);
    for (arma::uword k = 0; k < X.n_cols; ++k) {
      // |x - y|^alpha, exact squares and absolute values
      const double al = alpha[k];
      outer_fill(X.col(k), Y.col(k), P, false, [al](double x) {
        const double d = std::fabs(x);
        return al == 2.0 ? d * d : (al == 1.0 ? d : std::pow(d, al));
      });
      out += theta[k] * P;
    }
    return arma::exp(-out);
  }
  arma::mat out(X.n_rows, Y.n_rows);
  kernel_corr(kern, X, Y, X.n_cols, theta.memptr(), alpha.memptr(), out, false);
  return out;
}

// [[Rcpp::export(.corr_matrix)]]
arma::mat corr_matrix_r(const arma::mat& X, const arma::mat& Y,
                        const arma::vec& theta, const arma::vec& alpha, int kernel = 1) {
  return corr_matrix(X, Y, theta, alpha, kernel);
}
