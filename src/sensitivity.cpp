// Global sensitivity of the simulator (R/sensitivity.R): per draw, the
// emulator's conditional mean given y = (yf, ys) as a kernel expansion
//   mu(z) = sum_j w_j R(z, Z_j),   R(z, z') = prod_k r_k(z_k - z'_k),
// (SchurPosterior::simMean()) and its Sobol variances in closed form from
// one-dimensional integrals of the correlation against each input's measure
// mu_k (Oakley and O'Hagan 2004):
//   I1[j, k]    = int r_k(t - Z_jk) dmu_k(t),
//   I2_k[j, l]  = int r_k(t - Z_jk) r_k(t - Z_lk) dmu_k(t),
//   f0 = E mu = sum_j w_j prod_k I1[j, k],
//   E[E(mu | z_k)^2]    = (w a_k)' I2_k (w a_k),   a_k[j] = prod_{i != k} I1[j, i],
//   E[mu^2]             = w' (I2_1 o ... o I2_D) w                     (o: entrywise),
//   E[E(mu | z_-k)^2]   = (w I1[, k])' (o_{i != k} I2_i) (w I1[, k]),
// so that V = E[mu^2] - f0^2, the first-order variance V_k = E[E(mu | z_k)^2]
// - f0^2 and the total one VT_k = V - (E[E(mu | z_-k)^2] - f0^2): O(N^2 D)
// per draw (N = m + distinct field rows) after the posterior's factors.
// The one-dimensional integrals are exact against a uniform measure for the
// Gaussian family (and the power exponential at alpha = 2: error functions)
// and the Matern families (exponentials times polynomials), and otherwise
// Gauss-Legendre (or the user's) quadrature nodes and weights, the
// correlations at the nodes from the kernel module (kernels.cpp).
// A categorical input f multiplies the correlation by its levels' C_f[a, b]
// (levels.cpp): against its levels' probabilities pi it is one more factor
// of the product, I1[j, f] = sum_l pi_l C_f[l, a_j] and I2_f[j, k] =
// sum_l pi_l C_f[l, a_j] C_f[l, a_k]; a point mass (an output held at its
// level) folds C_f[j, a_i] into the weights and adds no variance.
#include "fbc.h"
#include <functional>
#include <numeric>

static const double PI_ = 3.141592653589793238462643383280;

// x <- Ds^-1 x from the inverse simHeldout() forms (one fold of every run).
void SchurPosterior::simSolve(arma::vec& x) {
  std::vector<std::vector<int> > folds(1, std::vector<int>(m));
  std::iota(folds[0].begin(), folds[0].end(), 0);
  arma::vec a;
  std::vector<arma::mat> QBB;
  simHeldout(folds, a, QBB);
  x = QBB[0] * x;
}

// Ds = Ls Ls': two triangular solves.
void DensePosterior::simSolve(arma::vec& x) {
  const arma::mat& L = Ls_.cur();
  solve_lower(L, x);
  x = arma::solve(arma::trimatu(arma::trimatl(L).t()), x);
}

// With C = [D B; B' A] and the Schur complement S = LS LS' (model.cpp),
//   E[eta(z) | y] = Rs(z, Xs) Ds^-1 ys
//                   + s2S [Rs(z, Xk) - Rs(z, Xs) Ds^-1 Rs(Xs, Xk)] S^-1 r
// (r = yf - muB - Rs(Xk, Xs) Ds^-1 ys, replicates summed onto their distinct
// row): with beta = s2S S^-1 r summed by distinct row, the weights are
// Ds^-1 (ys - Rs(Xs, Xk) beta) on the runs and beta on the field rows.
// With support points P, a conditional sample path instead: its values at P
// are drawn given y, f_P = mu_P + L u (L L' = Cov(eta(P) | y), u standard
// normal, R's generator), and the path is E[eta(z) | y, eta(P) = f_P]
//   = mu*(z) + s2S Rs(z, P) c,   c = Cov(eta(P) | y)^-1 (f_P - mu_P) = L^-T u,
// where mu* is the mean above given y* = y - Cov(y, eta(P)) c: one more
// kernel expansion, with the centres P added.
// Without P, wb: the bias's posterior mean given y is s2B Kb(x)' S^-1 r
// (model.cpp, condition()), Kb = Rb(Xu, x) or, under S-GaSP, c (Rb(Xu, Xu)
// + c I)^-1 Rb(Xu, x) (biasModelCross()): wb = s2B S^-1 r summed by
// distinct row, times c (Rb + c I)^-1 under S-GaSP.
void SchurPosterior::simMean(arma::mat& Z, arma::vec& w, const arma::mat* P, arma::vec* wb) {
  const double s2S = phi[iSigma2S], muB = biasMean ? phi[iMuB] : 0.0;
  arma::mat Xk(nu_, p + q);
  if (p > 0) Xk.cols(0, p - 1) = Xu_;
  for (int k = 0; k < q; ++k) Xk.col(p + k).fill(phi[iKappa + k]);
  arma::mat K;
  runPrior(phi, Xs_, Xk, K);  // s2S Rs(Xs, Xk)
  arma::vec ys = ys_, yf = yf_, wz = wz_.cur(), cP;
  if (P) {
    RunConditional rc;
    runConditional(*P, arma::mat(0, p), rc);
    arma::mat C, L, KP;
    runPrior(phi, *P, *P, C);
    C -= rc.A.t() * rc.A;
    // a jitter relative to the prior variance, raised until C factors; where
    // it does not by 1e-4 (an approximate algebra's C need not be positive
    // semi-definite), c = C^+ (f_P - mu_P) = V Lam^-1/2 u over the
    // eigenvalues above 1e-10 s2S (the others' directions fixed at the mean)
    bool ok = false;
    for (double jit = 1e-10; !ok && jit < 1e-3; jit *= 100) {
      C.diag() += jit * s2S;
      ok = arma::chol(L, C, "lower");
    }
    cP.set_size(P->n_rows);
    for (arma::uword i = 0; i < cP.n_elem; ++i) cP[i] = R::norm_rand();
    if (ok) {
      cP = arma::solve(arma::trimatu(L.t()), cP);
    } else {
      arma::vec lam;
      arma::mat U;
      if (!arma::eig_sym(lam, U, C)) Rcpp::stop("the conditional covariance at the support points has no eigendecomposition");
      for (arma::uword i = 0; i < lam.n_elem; ++i)
        cP[i] = lam[i] > 1e-10 * s2S ? cP[i] / std::sqrt(lam[i]) : 0.0;
      cP = U * cP;
    }
    runPrior(phi, Xs_, *P, KP);
    ys -= KP * cP;
    runPrior(phi, Xk, *P, KP);
    const arma::vec u = KP * cP;
    for (int i = 0; i < n; ++i) yf[i] -= u[grp_[i]];
    arma::vec t = ys;
    simSolve(t);
    wz = K.t() * t / s2S;
  }
  arma::vec v(n);
  for (int i = 0; i < n; ++i) v[i] = yf[i] - muB - wz[grp_[i]];
  FS_.cur().solve(v, grp_);
  arma::vec beta(nu_, arma::fill::zeros);
  for (int i = 0; i < n; ++i) beta[grp_[i]] += s2S * v[i];
  if (wb) {
    wb->zeros(bias ? nu_ : 0);
    if (bias) {
      const double s2B = phi[iSigma2B];
      for (int i = 0; i < n; ++i) (*wb)[grp_[i]] += s2B * v[i];
      arma::mat Wb(wb->memptr(), nu_, 1, false, true);
      arma::vec unused;
      const arma::vec thetaB = phi.subvec(iThetaB, iThetaB + p - 1);
      const arma::vec alphaB = phi.subvec(iAlphaB, iAlphaB + p - 1);
      biasModelCross([&] {
        arma::mat R = corr_matrix(Xu_, Xu_, thetaB, alphaB, kernB_);
        level_scale(levels, phi.memptr() + iRhoB, Xu_, Xu_, R, false);
        return R;
      }, Wb, unused);
    }
  }
  arma::vec c = ys - K * beta / s2S;
  simSolve(c);
  Z = arma::join_cols(Xs_, Xk);
  w = arma::join_cols(c, beta);
  if (P) {
    Z = arma::join_cols(Z, *P);
    w = arma::join_cols(w, s2S * cP);
  }
}

// erf(x) - erf(y) for x >= y without cancellation in the tails.
static double erf_diff(double x, double y) {
  if (y > 0) return std::erfc(y) - std::erfc(x);
  if (x < 0) return std::erfc(-x) - std::erfc(-y);
  return std::erf(x) - std::erf(y);
}

// The Gaussian family exp(-theta d^2) against the uniform measure on [a, b]:
// I1 and I2 in closed form (erf).
static void gauss_uniform(const arma::vec& c, double theta, double a, double b, double* I1,
                          arma::mat* I2) {
  const arma::uword N = c.n_elem;
  if (!(theta > 1e-300)) {
    for (arma::uword j = 0; j < N; ++j) I1[j] = 1.0;
    if (I2) I2->ones(N, N);
    return;
  }
  const double len = b - a, st = std::sqrt(theta), s2 = std::sqrt(2.0 * theta);
  const double k1 = std::sqrt(PI_ / theta) / (2.0 * len);
  const double k2 = std::sqrt(PI_ / (2.0 * theta)) / (2.0 * len);
  for (arma::uword j = 0; j < N; ++j) I1[j] = k1 * erf_diff(st * (b - c[j]), st * (a - c[j]));
  if (!I2) return;
  I2->set_size(N, N);
  for (arma::uword l = 0; l < N; ++l) {
    for (arma::uword j = l; j < N; ++j) {
      const double d = c[j] - c[l], mid = 0.5 * (c[j] + c[l]);
      const double v = std::exp(-0.5 * theta * d * d) * k2 * erf_diff(s2 * (b - mid), s2 * (a - mid));
      I2->at(j, l) = v;
      I2->at(l, j) = v;
    }
  }
}

// h[k] = int_0^X v^k exp(-lam v) dv for k = 0..K (X >= 0, K <= 4), given
// e = exp(-lam X): k! / lam^(k+1) [1 - e sum_{i <= k} z^i / i!] (z = lam X),
// where z is small the bracket as e sum_{i > k} z^i / i! (no cancellation).
static void exp_moments(double lam, double X, int K, double e, double* h) {
  // k! / lam^(k+1) for lam = 1 and 2
  static const double f1[5] = {1.0, 1.0, 2.0, 6.0, 24.0};
  static const double f2[5] = {0.5, 0.25, 0.25, 0.375, 0.75};
  const double* f = lam == 1.0 ? f1 : f2;
  const double z = lam * X;
  if (z < 1.0) {
    // t_i = z^i / i!, the tails sum_{i > k} t_i from the smallest term up
    static const double inv[24] = {0.0, 1.0, 1.0 / 2, 1.0 / 3, 1.0 / 4, 1.0 / 5, 1.0 / 6,
                                   1.0 / 7, 1.0 / 8, 1.0 / 9, 1.0 / 10, 1.0 / 11, 1.0 / 12,
                                   1.0 / 13, 1.0 / 14, 1.0 / 15, 1.0 / 16, 1.0 / 17, 1.0 / 18,
                                   1.0 / 19, 1.0 / 20, 1.0 / 21, 1.0 / 22, 1.0 / 23};
    double t[24];
    t[0] = 1.0;
    for (int i = 1; i < 24; ++i) t[i] = t[i - 1] * z * inv[i];
    double tail = 0.0;
    for (int i = 23; i > K; --i) tail += t[i];
    for (int k = K; k >= 0; --k) {
      h[k] = f[k] * e * tail;
      tail += t[k];
    }
    return;
  }
  double term = 1.0, sum = 1.0;
  h[0] = f[0] * (1.0 - e);
  for (int k = 1; k <= K; ++k) {
    term *= z / k;
    sum += term;
    h[k] = f[k] * (1.0 - e * sum);
  }
}

// int_{u0}^{u1} c(s u) exp(-lam s u) du for the polynomial c (degree K) in
// v = s u, 0 <= u0 <= u1; e1 = exp(-lam s u1) (and e0 at u0).
static double exp_poly(const double* c, int K, double s, double lam, double u0, double u1,
                       double e1) {
  double h1[5], h0[5] = {0.0, 0.0, 0.0, 0.0, 0.0};
  exp_moments(lam, s * u1, K, e1, h1);
  if (u0 > 0.0) exp_moments(lam, s * u0, K, std::exp(-lam * s * u0), h0);
  double out = 0.0;
  for (int k = 0; k <= K; ++k) out += c[k] * (h1[k] - h0[k]);
  return out / s;
}

// The Matern families r(d) = P(s |d|) exp(-s |d|) (P(v) = 1 + v, s =
// sqrt(3 theta); P(v) = 1 + v + v^2 / 3, s = sqrt(5 theta)) against the
// uniform measure on [a, b]: I1 and I2 in closed form. Either side of a
// centre the integrand is a polynomial times an exponential (exp_poly());
// between two centres c1 <= c2 the exponentials multiply to the constant
// exp(-s (c2 - c1)) and the polynomial (degree <= 4) is integrated exactly by
// three Gauss-Legendre nodes. The exponentials come from each centre's
// distances to a and b (one exp per centre) unless they could underflow.
static void matern_uniform(const arma::vec& c, double theta, int kern, double a, double b,
                           double* I1, arma::mat* I2) {
  const arma::uword N = c.n_elem;
  const int K = kern == 3 ? 1 : 2;
  const double s = std::sqrt((kern == 3 ? 3.0 : 5.0) * theta);
  if (!(s > 1e-150)) {
    for (arma::uword j = 0; j < N; ++j) I1[j] = 1.0;
    if (I2) I2->ones(N, N);
    return;
  }
  const double pc[3] = {1.0, 1.0, 1.0 / 3.0};
  const double len = b - a;
  // Ea[j] = exp(-s (c_j - a)) and Eb[j] = exp(-s (b - c_j)) for centres in [a, b]
  const bool shared = s * (b - a) < 300.0;
  std::vector<double> Ea(N), Eb(N);
  for (arma::uword j = 0; j < N; ++j) {
    const double cj = c[j];
    Ea[j] = std::exp(-s * std::max(cj - a, 0.0));
    Eb[j] = std::exp(-s * std::max(b - cj, 0.0));
    double v = 0.0;
    if (b > std::max(a, cj)) v += exp_poly(pc, K, s, 1.0, std::max(a, cj) - cj, b - cj, Eb[j]);
    if (std::min(b, cj) > a) v += exp_poly(pc, K, s, 1.0, cj - std::min(b, cj), cj - a, Ea[j]);
    I1[j] = v / len;
  }
  if (!I2) return;
  static const double gx[3] = {-0.7745966692414834, 0.0, 0.7745966692414834};
  static const double gw[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
  // For two centres inside [a, b] the tails' moments int_0^X v^k exp(-2 v) dv
  // depend on one centre each (X = s (b - c2) right of both, s (c1 - a) left
  // of both): computed once per centre, not once per pair.
  std::vector<double> hb, ha;
  if (shared) {
    hb.assign(5 * N, 0.0);
    ha.assign(5 * N, 0.0);
    for (arma::uword j = 0; j < N; ++j) {
      if (c[j] < a || c[j] > b) continue;
      exp_moments(2.0, s * (b - c[j]), 2 * K, Eb[j] * Eb[j], &hb[5 * j]);
      exp_moments(2.0, s * (c[j] - a), 2 * K, Ea[j] * Ea[j], &ha[5 * j]);
    }
  }
  I2->set_size(N, N);
  for (arma::uword l = 0; l < N; ++l) {
    for (arma::uword j = l; j < N; ++j) {
      const bool jl = c[j] <= c[l];
      const arma::uword i1 = jl ? j : l, i2 = jl ? l : j;
      const double c1 = c[i1], c2 = c[i2];
      const bool inside = shared && c1 >= a && c2 <= b;
      const double e = s * (c2 - c1);
      const double E = inside ? Eb[i1] / Eb[i2] : std::exp(-e);
      // Q(v) = P(v + e) P(v): P(v + e) = sh[0] + sh[1] v (+ sh[2] v^2)
      double sh[3];
      if (K == 1) {
        sh[0] = 1.0 + e; sh[1] = 1.0; sh[2] = 0.0;
      } else {
        sh[0] = 1.0 + e + e * e / 3.0; sh[1] = 1.0 + 2.0 * e / 3.0; sh[2] = 1.0 / 3.0;
      }
      double Q[5] = {0.0, 0.0, 0.0, 0.0, 0.0};
      for (int i = 0; i <= K; ++i)
        for (int k = 0; k <= K; ++k) Q[i + k] += sh[i] * pc[k];
      double v = 0.0;
      if (inside) {
        const double* r = &hb[5 * i2];
        const double* l = &ha[5 * i1];
        for (int k = 0; k <= 2 * K; ++k) v += Q[k] * (r[k] + l[k]);
        v *= E / s;
      } else if (b > std::max(a, c2)) {
        const double e1 = std::exp(-2.0 * s * (b - c2));
        v += E * exp_poly(Q, 2 * K, s, 2.0, std::max(a, c2) - c2, b - c2, e1);
      }
      if (!inside && std::min(b, c1) > a) {
        const double e1 = std::exp(-2.0 * s * (c1 - a));
        v += E * exp_poly(Q, 2 * K, s, 2.0, c1 - std::min(b, c1), c1 - a, e1);
      }
      const double lo = std::max(a, c1), hi = std::min(b, c2);
      if (hi > lo) {
        const double h = 0.5 * (hi - lo), mid = 0.5 * (hi + lo);
        double g = 0.0;
        for (int i = 0; i < 3; ++i) {
          const double u = s * (mid + h * gx[i] - c1), w = s * (c2 - mid - h * gx[i]);
          g += gw[i] * (K == 1 ? (1.0 + u) * (1.0 + w)
                               : (1.0 + u + u * u / 3.0) * (1.0 + w + w * w / 3.0));
        }
        v += E * h * g;
      }
      I2->at(j, l) = v / len;
      I2->at(l, j) = v / len;
    }
  }
}

// One input's integrals for centres c of the family kern (theta, alpha):
// I1[j] = int r(t - c_j) dmu(t) and I2 (N x N; not computed when null), in
// closed form against a uniform measure on [lo, up] (exact) for the Gaussian
// and Matern families, else by the quadrature nodes and weights (summing to
// one).
static void integrals_1d(int kern, double theta, double alpha, const arma::vec& c, bool exact,
                         double lo, double up, const arma::vec& nodes, const arma::vec& wq,
                         double* I1, arma::mat* I2) {
  const bool gauss = kern == 2 || (kern == 1 && alpha == 2.0);  // Gaussian, power exponential
  if (exact && gauss) {
    gauss_uniform(c, theta, lo, up, I1, I2);
  } else if (exact && (kern == 3 || kern == 4)) {
    matern_uniform(c, theta, kern, lo, up, I1, I2);
  } else {
    arma::mat Rq(c.n_elem, nodes.n_elem);
    kernel_corr(kern, arma::mat(c), arma::mat(nodes), 1, &theta, &alpha, Rq, false);
    arma::vec(I1, c.n_elem, false, true) = Rq * wq;
    if (!I2) return;
    Rq.each_row() %= arma::sqrt(wq).t();
    *I2 = Rq * Rq.t();
  }
}

// The Sobol variances of f(z) = sum_j w_j prod_k phi_jk(z_k) over the first
// D inputs from I1 (N x D) and I2[k] (the header's formulas): V, V1[k],
// VT[k]; A (N x D) the weights times a_k = prod_{i != k} I1[, i], for the
// main effects E[f | z_k = t] = sum_j A_jk phi_jk(t).
static void main_weights(const arma::vec& w, const arma::mat& I1, int D, arma::mat& A) {
  A.set_size(w.n_elem, D);
  for (int k = 0; k < D; ++k) {
    arma::vec ak(w.n_elem, arma::fill::ones);
    for (int i = 0; i < D; ++i) if (i != k) ak %= I1.col(i);
    A.col(k) = w % ak;
  }
}

static void sobol_variances(const arma::vec& w, const arma::mat& I1,
                            const std::vector<arma::mat>& I2, int D, double& V, double* V1,
                            double* VT, arma::mat& A) {
  const arma::uword N = w.n_elem;
  const double f0 = arma::dot(w, arma::prod(I1, 1));
  // suffix products pre[k] = I2_k o ... o I2_{D-1} (pre[D]: ones)
  std::vector<arma::mat> pre(D + 1);
  pre[D].ones(N, N);
  for (int k = D - 1; k >= 0; --k) pre[k] = pre[k + 1] % I2[k];
  V = arma::as_scalar(w.t() * pre[0] * w) - f0 * f0;
  arma::mat prefix(N, N, arma::fill::ones);
  main_weights(w, I1, D, A);
  for (int k = 0; k < D; ++k) {
    V1[k] = arma::as_scalar(A.col(k).t() * I2[k] * A.col(k)) - f0 * f0;
    const arma::vec wi = w % I1.col(k);
    VT[k] = V - (arma::as_scalar(wi.t() * (prefix % pre[k + 1]) * wi) - f0 * f0);
    prefix %= I2[k];
  }
}

// f(X) = R(X, Z) w, R the product correlation of family kern at (th, al)
// over X's columns times the levels' correlations C of the categorical
// inputs lev (none: empty): a kernel expansion at the rows of X, 512 at a
// time.
static void expansion_at(int kern, const arma::mat& X, const arma::mat& Z, const arma::vec& w,
                         const arma::vec& th, const arma::vec& al,
                         const std::vector<LevelInput>& lev, const std::vector<arma::mat>& C,
                         arma::vec& out) {
  out.set_size(X.n_rows);
  for (arma::uword r0 = 0; r0 < X.n_rows; r0 += 512) {
    const arma::uword r1 = std::min<arma::uword>(X.n_rows, r0 + 512) - 1;
    const arma::mat Xr = X.rows(r0, r1);
    arma::mat R = corr_matrix(Xr, Z, th, al, kern);
    level_scale(lev, C, Xr, Z, R, false);
    out.subvec(r0, r1) = R * w;
  }
}

// The inputs of the measure: the numeric columns `cols` (0-based, of the
// centres), then each categorical input f of `lev` with its levels'
// probabilities probs[f] (a point mass holds the input at one level). An
// input's columns (swapped together by the sampling estimator).
struct MeasureInputs {
  std::vector<int> cols;
  std::vector<arma::vec> probs;
  std::vector<std::vector<arma::uword> > swap;
  int size() const { return cols.size() + probs.size(); }
};

static MeasureInputs measure_inputs(const Rcpp::IntegerVector& cols, const Rcpp::List& probs,
                                    const std::vector<LevelInput>& lev, int ncol) {
  MeasureInputs mi;
  if ((int) probs.size() != (int) lev.size())
    Rcpp::stop("the measure needs the probabilities of %d categorical inputs", (int) lev.size());
  for (int c : cols) {
    if (c < 0 || c >= ncol) Rcpp::stop("input column %d out of range", c + 1);
    mi.cols.push_back(c);
    mi.swap.push_back(std::vector<arma::uword>(1, c));
  }
  for (size_t f = 0; f < lev.size(); ++f) {
    const arma::vec pr = Rcpp::as<arma::vec>(probs[f]);
    if ((int) pr.n_elem != lev[f].L) Rcpp::stop("categorical input %d needs %d probabilities", (int) f + 1, lev[f].L);
    mi.probs.push_back(pr);
    std::vector<arma::uword> s;
    for (int a = 0; a < lev[f].ncol; ++a) s.push_back(lev[f].col + a);
    mi.swap.push_back(s);
  }
  return mi;
}

// The first-order variance of measure input k, its main effect's squared
// deviation from f0 (effect(k, t, out): the main effect at the points t of
// a numeric input, at every level of a categorical one) integrated by the
// input's quadrature nodes and weights or its levels' probabilities.
template <class Effect>
static double main_variance(const Effect& effect, int k, const MeasureInputs& mi,
                            const arma::mat& nodes, const arma::mat& weights, double f0) {
  arma::vec me;
  const int nc = mi.cols.size();
  if (k >= nc) {
    effect(k, arma::vec(), me);
    return arma::dot(mi.probs[k - nc], arma::square(me - f0));
  }
  const int c = mi.cols[k];
  effect(k, arma::vec(nodes.col(c)), me);
  return arma::dot(weights.col(c), arma::square(me - f0));
}

// G(l, j) = C(l, a_j) for the levels a_j of the rows of Z (categorical input f).
static arma::mat level_columns(const arma::mat& C, const arma::mat& Z, const LevelInput& f) {
  arma::mat G(C.n_rows, Z.n_rows);
  for (arma::uword j = 0; j < Z.n_rows; ++j) G.col(j) = C.col(level_of(Z, j, f));
  return G;
}

// A categorical input's integrals against its levels' probabilities pi:
// I1[j] = sum_l pi_l G(l, j), I2 = G' diag(pi) G (not computed when null).
static void level_integrals(const arma::mat& G, const arma::vec& pi, double* I1, arma::mat* I2) {
  arma::vec(I1, G.n_cols, false, true) = G.t() * pi;
  if (!I2) return;
  arma::mat Gw = G;
  Gw.each_col() %= arma::sqrt(pi);
  *I2 = Gw.t() * Gw;
}

// The Sobol variances of an expansion f too large for the closed form's
// N x N integrals, at O(N D (Q + (D + 2) Nb)) per draw: f0 = E f in closed
// form (from I1, as in sobol_variances()); each first-order variance
//   V_k = int (E[f | z_k = t] - f0)^2 dmu_k(t)
// by input k's quadrature nodes and weights, or its levels' probabilities
// (first(k)); the variance and the totals by sampling (Saltelli et al.
// 2010): with A and B (the first and last Nb rows of AB) independent
// samples of the measure, A_B^k the rows of A with input k's columns
// (swap[k]) from B and g = f - f0,
//   V    = mean of g^2 over the 2 Nb points of A and B,
//   VT_k = mean of (g(A) - g(A_B^k))^2 / 2              (Jansen 1999);
// sd1[k], sdT[k] the sampling's standard errors of V_k / V (through V) and
// of VT_k / V (the Jansen terms' sd over sqrt(Nb), over V).
static void sobol_sampled(const std::function<void(const arma::mat&, arma::vec&)>& f,
                          const std::function<double(int)>& first, double f0,
                          const std::vector<std::vector<arma::uword> >& swap,
                          const arma::mat& AB, double& V, double* V1, double* VT,
                          double* sd1, double* sdT) {
  const arma::uword Nb = AB.n_rows / 2;
  const arma::mat A = AB.rows(0, Nb - 1), B = AB.rows(Nb, 2 * Nb - 1);
  arma::vec fA, fB, fk;
  f(A, fA);
  f(B, fB);
  fA -= f0;
  fB -= f0;
  const arma::vec g2 = arma::join_cols(arma::square(fA), arma::square(fB));
  V = arma::mean(g2);
  const double Vs = std::max(V, 1e-300), sdV = arma::stddev(g2) / std::sqrt(2.0 * Nb);
  arma::mat Ak = A;
  for (size_t k = 0; k < swap.size(); ++k) {
    V1[k] = first(k);
    sd1[k] = V1[k] / Vs * sdV / Vs;
    for (arma::uword c : swap[k]) Ak.col(c) = B.col(c);
    f(Ak, fk);
    for (arma::uword c : swap[k]) Ak.col(c) = A.col(c);
    const arma::vec tT = 0.5 * arma::square(fA - (fk - f0));
    VT[k] = arma::mean(tT);
    sdT[k] = arma::stddev(tT) / std::sqrt((double) Nb) / Vs;
  }
}

// The points per sample of `samples` (2 Nb rows per draw of M, D columns;
// none: 0, the closed form), checked.
static int sample_count(const arma::mat& samples, int M, int D) {
  const int Nb = samples.n_rows / std::max(2 * M, 1);
  if (samples.n_rows > 0 && (Nb < 2 || (int) samples.n_rows != 2 * Nb * M ||
                             (int) samples.n_cols != D))
    Rcpp::stop("the samples must be %d draws x 2 Nb rows and %d columns", M, D);
  return Nb;
}

// The rows of the main effects: G grid values per numeric input, one per
// level of a categorical input.
static int main_rows(const MeasureInputs& mi, int G) {
  int r = G * mi.cols.size();
  for (const arma::vec& pr : mi.probs) r += pr.n_elem;
  return r;
}

// Per draw (rows of phis): the Sobol variances of the simulator's posterior
// mean over the inputs of the measure (cols, probs: MeasureInputs; a
// categorical input's integrals are the probability-weighted sums over its
// levels of the level correlation C[l, a_j]), and its main effects at the
// grid values (and at each level); with support points (S rows per draw:
// rows d S .. d S + S - 1 of `support`, scaled) those of a conditional
// sample path through them. exact[k]: column k's measure is uniform on
// [lower[k], upper[k]] (closed form where the family allows); otherwise
// nodes[, k] and weights[, k] (weights summing to one). grid: G x D values
// (scaled) for the main effects. samples: none (0 rows) for the closed
// form, else 2 Nb rows per draw (A then B, sobol_sampled(); a categorical
// input's indicator columns hold the levels drawn), and sd1, sdT the
// sampling errors; the main effects need the one-dimensional integrals I1
// alone either way. Columns of neither the numeric inputs nor the
// categorical ones have correlation parameter 0 (an output's indicators
// under independent outputs): they add nothing.
// [[Rcpp::export(.fbc_sobol_c)]]
Rcpp::List fbc_sobol(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                     const arma::vec& ys, const arma::mat& phis, double nugget,
                     const Rcpp::List& model, const Rcpp::LogicalVector& exact,
                     const arma::vec& lower, const arma::vec& upper, const arma::mat& nodes,
                     const arma::mat& weights, const arma::mat& grid,
                     const arma::mat& support, const arma::mat& samples,
                     const Rcpp::IntegerVector& cols, const Rcpp::List& probs) {
  std::unique_ptr<Posterior> pp = make_posterior(Xf, yf, Xs, ys, nugget, model);
  SchurPosterior* sp = dynamic_cast<SchurPosterior*>(pp.get());
  if (!sp) Rcpp::stop("the Sobol indices need one simulator GP");
  Posterior& post = *pp;
  const int kern = Rcpp::as<int>(model["kernS"]);
  const int D = post.p + post.q, M = phis.n_rows, G = grid.n_rows;
  if ((int) exact.size() != D || (int) nodes.n_cols != D || (int) weights.n_cols != D ||
      (int) grid.n_cols != D || (int) lower.n_elem != D || (int) upper.n_elem != D)
    Rcpp::stop("the measure must have %d inputs", D);
  const MeasureInputs mi = measure_inputs(cols, probs, post.levels, D);
  const int nd = mi.size(), nc = mi.cols.size();
  arma::vec V(M);
  arma::mat V1(nd, M), VT(nd, M), sd1(nd, M, arma::fill::zeros), sdT(nd, M, arma::fill::zeros);
  arma::mat main(main_rows(mi, G), M);
  arma::mat Z, I1, A, Rg;
  arma::vec w;
  std::vector<arma::mat> I2(nd), C, Gl(mi.probs.size());
  const int S = support.n_rows / std::max(M, 1);
  if (S > 0 && ((int) support.n_rows != S * M || (int) support.n_cols != D))
    Rcpp::stop("the support points must be %d draws x S rows and %d columns", M, D);
  const int Nb = sample_count(samples, M, D);
  arma::mat Pd;
  for_each_draw(post, phis, [&](arma::uword d) {
    if (S > 0) Pd = support.rows(d * S, d * S + S - 1);
    sp->simMean(Z, w, S > 0 ? &Pd : nullptr);
    if (!post.levels.empty()) level_corr(post.levels, post.phi.memptr() + post.iRhoS, C);
    I1.set_size(Z.n_rows, nd);
    for (int k = 0; k < nc; ++k) {
      const int c = mi.cols[k];
      integrals_1d(kern, post.phi[post.iThetaS + c], post.phi[post.iAlphaS + c], Z.col(c),
                   exact[c], lower[c], upper[c], nodes.col(c), weights.col(c), I1.colptr(k),
                   Nb > 0 ? nullptr : &I2[k]);
    }
    for (size_t f = 0; f < mi.probs.size(); ++f) {
      Gl[f] = level_columns(C[f], Z, post.levels[f]);
      level_integrals(Gl[f], mi.probs[f], I1.colptr(nc + f), Nb > 0 ? nullptr : &I2[nc + f]);
    }
    // E[f | z_k = t] = sum_j A_jk r_k(t - Z_jk) at the values t; at each
    // level l of a categorical input, sum_j A_jk C[l, a_j]
    auto effect = [&](int k, const arma::vec& t, arma::vec& out) {
      if (k >= nc) { out = Gl[k - nc] * A.col(k); return; }
      const int c = mi.cols[k];
      const double theta = post.phi[post.iThetaS + c], alpha = post.phi[post.iAlphaS + c];
      Rg.set_size(t.n_elem, Z.n_rows);
      kernel_corr(kern, arma::mat(t), arma::mat(Z.col(c)), 1, &theta, &alpha, Rg, false);
      out = Rg * A.col(k);
    };
    if (Nb > 0) {
      const arma::vec th = post.phi.subvec(post.iThetaS, post.iThetaS + D - 1);
      const arma::vec al = post.phi.subvec(post.iAlphaS, post.iAlphaS + D - 1);
      const double f0 = arma::dot(w, arma::prod(I1, 1));
      main_weights(w, I1, nd, A);
      sobol_sampled([&](const arma::mat& X, arma::vec& f) {
                      expansion_at(kern, X, Z, w, th, al, post.levels, C, f);
                    },
                    [&](int k) { return main_variance(effect, k, mi, nodes, weights, f0); },
                    f0, mi.swap, samples.rows(2 * Nb * d, 2 * Nb * (d + 1) - 1), V[d],
                    V1.colptr(d), VT.colptr(d), sd1.colptr(d), sdT.colptr(d));
    } else {
      sobol_variances(w, I1, I2, nd, V[d], V1.colptr(d), VT.colptr(d), A);
    }
    arma::vec me;
    int at = 0;
    for (int k = 0; k < nd; ++k) {
      effect(k, k < nc ? arma::vec(grid.col(mi.cols[k])) : arma::vec(), me);
      main.col(d).subvec(at, at + me.n_elem - 1) = me;
      at += me.n_elem;
    }
    return true;
  });
  return Rcpp::List::create(Rcpp::Named("V") = V, Rcpp::Named("V1") = V1,
                            Rcpp::Named("VT") = VT, Rcpp::Named("sd1") = sd1,
                            Rcpp::Named("sdT") = sdT, Rcpp::Named("main") = main);
}

// The calibrated prediction's mean zeta(x) = E[eta(x, kappa) + delta(x) | y]
// per draw over the experimental inputs of the measure (cols, probs as in
// fbc_sobol(); every categorical input is experimental): muB plus two
// kernel expansions, the simulator's (simMean(): centres Z, weights w times
// the correlation prod_{k >= p} rS(kappa_k - Z_jk) of their calibration
// coordinates) and the bias's (centres Xu, weights wb, the bias family and
// parameters, its levels' correlations rhoB). Its Sobol variances in closed
// form as the simulator's: per input, the blocks of I2 within each
// expansion in closed form (integrals_1d()), the cross block by the
// quadrature nodes (r_S(t - c_j) r_B(t - u_l) against the measure), or for
// a categorical input the probability-weighted sums over its levels of
// C_S[l, a_j] C_B[l, b_l]. Measure: the first p columns of exact, lower,
// upper, nodes, weights; grid: G x p values for the main effects. With
// `share` points (b x p) also predict()'s conditional means and variances
// there (types mean, simulator and, with a bias, bias) for the variance
// shares. samples: as in fbc_sobol() (p columns), the variances by
// sampling the two expansions' sum instead of their N x N integrals.
// [[Rcpp::export(.fbc_sobol_pred_c)]]
Rcpp::List fbc_sobol_pred(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                          const arma::vec& ys, const arma::mat& phis, double nugget,
                          const Rcpp::List& model, const Rcpp::LogicalVector& exact,
                          const arma::vec& lower, const arma::vec& upper,
                          const arma::mat& nodes, const arma::mat& weights,
                          const arma::mat& grid, const arma::mat& share,
                          const arma::mat& samples, const Rcpp::IntegerVector& cols,
                          const Rcpp::List& probs) {
  std::unique_ptr<Posterior> pp = make_posterior(Xf, yf, Xs, ys, nugget, model);
  SchurPosterior* sp = dynamic_cast<SchurPosterior*>(pp.get());
  if (!sp) Rcpp::stop("the Sobol indices need one simulator GP");
  Posterior& post = *pp;
  const int kS = Rcpp::as<int>(model["kernS"]), kB = Rcpp::as<int>(model["kernB"]);
  const int p = post.p, D = p + post.q, M = phis.n_rows, G = grid.n_rows;
  const int b = share.n_rows;
  if (p < 1) Rcpp::stop("the prediction needs an experimental input");
  if ((int) grid.n_cols != p || (int) share.n_cols != p) Rcpp::stop("grid and share need %d columns", p);
  const MeasureInputs mi = measure_inputs(cols, probs, post.levels, p);
  const int nd = mi.size(), nc = mi.cols.size(), F = mi.probs.size();
  const int ns = sample_count(samples, M, p);
  const bool sampled = ns > 0;
  arma::vec V(M);
  arma::mat V1(nd, M), VT(nd, M), main(main_rows(mi, G), M);
  arma::mat sd1(nd, M, arma::fill::zeros), sdT(nd, M, arma::fill::zeros);
  arma::mat mean(b, M), vmean(b, M), vsim(b, M), vbias(b, M, arma::fill::zeros);
  arma::mat Z, I1, A, Rg, Rs, Rb;
  arma::vec w, wb, ws;
  std::vector<arma::mat> I2(nd), CS, CB, Gl(F);
  for_each_draw(post, phis, [&](arma::uword d) {
    sp->simMean(Z, w, nullptr, &wb);
    const arma::uword Ns = Z.n_rows, Nb = wb.n_elem, N = Ns + Nb;
    const arma::mat Zx = Z.cols(0, p - 1);
    arma::mat Xu;
    if (Nb > 0) Xu = Zx.rows(Ns - Nb, Ns - 1);  // the distinct field rows
    if (F > 0) {
      level_corr(post.levels, post.phi.memptr() + post.iRhoS, CS);
      if (Nb > 0) level_corr(post.levels, post.phi.memptr() + post.iRhoB, CB);
    }
    // the simulator's weights times its calibration coordinates' correlations
    ws = w;
    for (int k = p; k < D; ++k) {
      const double theta = post.phi[post.iThetaS + k], alpha = post.phi[post.iAlphaS + k];
      arma::mat kap(1, 1);
      kap[0] = post.phi[post.iKappa + k - p];
      arma::mat r(Ns, 1);
      kernel_corr(kS, arma::mat(Z.col(k)), kap, 1, &theta, &alpha, r, false);
      ws %= r.col(0);
    }
    const arma::vec wall = arma::join_cols(ws, wb);
    I1.set_size(N, nd);
    arma::vec i1b;
    arma::mat i2b;
    for (int k = 0; k < nc; ++k) {
      const int c = mi.cols[k];
      const double tS = post.phi[post.iThetaS + c], aS = post.phi[post.iAlphaS + c];
      if (!sampled) I2[k].set_size(N, N);
      arma::mat i2s;
      arma::vec i1s(Ns);
      integrals_1d(kS, tS, aS, Z.col(c), exact[c], lower[c], upper[c], nodes.col(c),
                   weights.col(c), i1s.memptr(), sampled ? nullptr : &i2s);
      I1.col(k).head(Ns) = i1s;
      if (!sampled) I2[k].submat(0, 0, Ns - 1, Ns - 1) = i2s;
      if (Nb > 0) {
        const double tB = post.phi[post.iThetaB + c], aB = post.phi[post.iAlphaB + c];
        const arma::vec u = Xu.col(c);
        i1b.set_size(Nb);
        integrals_1d(kB, tB, aB, u, exact[c], lower[c], upper[c], nodes.col(c), weights.col(c),
                     i1b.memptr(), sampled ? nullptr : &i2b);
        I1.col(k).tail(Nb) = i1b;
        if (sampled) continue;
        I2[k].submat(Ns, Ns, N - 1, N - 1) = i2b;
        Rs.set_size(Ns, nodes.n_rows);
        Rb.set_size(Nb, nodes.n_rows);
        kernel_corr(kS, arma::mat(Z.col(c)), arma::mat(nodes.col(c)), 1, &tS, &aS, Rs, false);
        kernel_corr(kB, arma::mat(u), arma::mat(nodes.col(c)), 1, &tB, &aB, Rb, false);
        Rs.each_row() %= weights.col(c).t();
        const arma::mat X = Rs * Rb.t();
        I2[k].submat(0, Ns, Ns - 1, N - 1) = X;
        I2[k].submat(Ns, 0, N - 1, Ns - 1) = X.t();
      }
    }
    for (int f = 0; f < F; ++f) {
      Gl[f] = level_columns(CS[f], Zx, post.levels[f]);
      if (Nb > 0) Gl[f] = arma::join_rows(Gl[f], level_columns(CB[f], Xu, post.levels[f]));
      level_integrals(Gl[f], mi.probs[f], I1.colptr(nc + f), sampled ? nullptr : &I2[nc + f]);
    }
    // E[zeta - muB | x_k = t]: the two expansions' main effects at the
    // values t (at each level of a categorical input)
    auto effect = [&](int k, const arma::vec& t, arma::vec& out) {
      if (k >= nc) { out = Gl[k - nc] * A.col(k); return; }
      const int c = mi.cols[k];
      const double tS = post.phi[post.iThetaS + c], aS = post.phi[post.iAlphaS + c];
      Rg.set_size(t.n_elem, Ns);
      kernel_corr(kS, arma::mat(t), arma::mat(Z.col(c)), 1, &tS, &aS, Rg, false);
      out = Rg * A.col(k).head(Ns);
      if (Nb > 0) {
        const double tB = post.phi[post.iThetaB + c], aB = post.phi[post.iAlphaB + c];
        Rg.set_size(t.n_elem, Nb);
        kernel_corr(kB, arma::mat(t), arma::mat(Xu.col(c)), 1, &tB, &aB, Rg, false);
        out += Rg * A.col(k).tail(Nb);
      }
    };
    if (sampled) {
      const arma::vec thS = post.phi.subvec(post.iThetaS, post.iThetaS + p - 1);
      const arma::vec alS = post.phi.subvec(post.iAlphaS, post.iAlphaS + p - 1);
      arma::vec thB, alB;
      if (Nb > 0) {
        thB = post.phi.subvec(post.iThetaB, post.iThetaB + p - 1);
        alB = post.phi.subvec(post.iAlphaB, post.iAlphaB + p - 1);
      }
      arma::vec fb;
      const double f0 = arma::dot(wall, arma::prod(I1, 1));
      main_weights(wall, I1, nd, A);
      sobol_sampled([&](const arma::mat& X, arma::vec& f) {
                      expansion_at(kS, X, Zx, ws, thS, alS, post.levels, CS, f);
                      if (Nb > 0) {
                        expansion_at(kB, X, Xu, wb, thB, alB, post.levels, CB, fb);
                        f += fb;
                      }
                    },
                    [&](int k) { return main_variance(effect, k, mi, nodes, weights, f0); },
                    f0, mi.swap, samples.rows(2 * ns * d, 2 * ns * (d + 1) - 1), V[d],
                    V1.colptr(d), VT.colptr(d), sd1.colptr(d), sdT.colptr(d));
    } else {
      sobol_variances(wall, I1, I2, nd, V[d], V1.colptr(d), VT.colptr(d), A);
    }
    arma::vec me;
    int at = 0;
    for (int k = 0; k < nd; ++k) {
      effect(k, k < nc ? arma::vec(grid.col(mi.cols[k])) : arma::vec(), me);
      main.col(d).subvec(at, at + me.n_elem - 1) = me + (post.biasMean ? post.phi[post.iMuB] : 0.0);
      at += me.n_elem;
    }
    if (b > 0) {
      post.condition(share, PT_MEAN, mean.colptr(d), vmean.colptr(d));
      arma::vec junk(b);
      if (post.bias) {
        post.condition(share, PT_SIMULATOR, junk.memptr(), vsim.colptr(d));
        post.condition(share, PT_BIAS, junk.memptr(), vbias.colptr(d));
      } else {
        vsim.col(d) = vmean.col(d);
      }
    }
    return true;
  });
  return Rcpp::List::create(Rcpp::Named("V") = V, Rcpp::Named("V1") = V1,
                            Rcpp::Named("VT") = VT, Rcpp::Named("sd1") = sd1,
                            Rcpp::Named("sdT") = sdT, Rcpp::Named("main") = main,
                            Rcpp::Named("mean") = mean, Rcpp::Named("var") = vmean,
                            Rcpp::Named("var_sim") = vsim, Rcpp::Named("var_bias") = vbias);
}


// The simulator's posterior mean per draw as a kernel expansion (for tests):
// the centres Z and weights w of each draw; with support points (S rows per
// draw, as in fbc_sobol()) those of a conditional sample path.
// [[Rcpp::export(.fbc_sim_mean_c)]]
Rcpp::List fbc_sim_mean(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                        const arma::vec& ys, const arma::mat& phis, double nugget,
                        const Rcpp::List& model, const arma::mat& support) {
  std::unique_ptr<Posterior> pp = make_posterior(Xf, yf, Xs, ys, nugget, model);
  SchurPosterior* sp = dynamic_cast<SchurPosterior*>(pp.get());
  if (!sp) Rcpp::stop("the simulator's mean needs one simulator GP");
  const int M = phis.n_rows, S = support.n_rows / std::max(M, 1);
  Rcpp::List out(M);
  arma::mat Pd;
  for_each_draw(*pp, phis, [&](arma::uword d) {
    arma::mat Z;
    arma::vec w;
    if (S > 0) Pd = support.rows(d * S, d * S + S - 1);
    sp->simMean(Z, w, S > 0 ? &Pd : nullptr);
    out[d] = Rcpp::List::create(Rcpp::Named("Z") = Z, Rcpp::Named("w") = w);
    return true;
  });
  return out;
}
