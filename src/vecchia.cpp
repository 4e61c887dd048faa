// The nearest-neighbour (Vecchia) simulator algebra: an approximation of the
// joint Gaussian of y = (yf, ys) by a directed acyclic graph (Vecchia 1988;
// Datta et al. 2016; Katzfuss and Guinness 2021), exact when every node
// conditions on all its predecessors.
//
// Nodes, in order: the m simulator runs in a maximin ordering of their
// inputs scaled by w (Guinness 2018; Katzfuss, Guinness and Lawrence 2022),
// then the nu distinct field latents f_j = eta(x_j, kappa). In correlation
// units (Ds = Rs + nugget I on the runs, no nugget on the latents; with the
// simulator's own noise the runs are the unique inputs' means and Ds = Rs +
// nugget I + diag(r_i / n_i) / sigma2S, runDiag()):
//   run s_i | its <= k nearest earlier runs N_i:
//     ys_i = b_i' ys_N + e_i, e_i ~ N(0, d_i),
//     log|Ds| ~ sum log d_i,  ys' Ds^-1 ys ~ sum e_i^2 / d_i,
//     Ds^-1 ~ U U',  U[s_i, s_i] = d_i^-1/2, U[N_i, s_i] = -b_i d_i^-1/2;
//   latent f_j | its k nearest runs N_j at the current kappa (scaled
//   distance) and its <= kf nearest earlier latents F_j:
//     f_j = a_j' ys_N + c_j' f_F + e_j, e_j ~ N(0, g_j),
//   so with M = I - C (C[j, F_j] = c_j, strictly lower) and h_j = a_j' ys_N:
//     wz = E(f | ys) = M^-1 h,   Q = cov(f | ys) = M^-1 diag(g) M^-T,
//   which is all the Schur complement needs (model.cpp). A new point is one
//   more latent after the field latents (simCondition()).
// Each conditional is read off the Cholesky factor L of the joint
// correlation of [conditioning set, node]: its last row l and last diagonal
// entry give the variance (L_ss^2) and the coefficients (L_-s^-T l).
// Ordering and the runs' neighbours are computed once (in R, through
// .vecchia_order() and .vecchia_neighbours()) and handed over with the model;
// the field latents' neighbours among the runs follow kappa.
//
// Threads (Model::threads, OpenMP): the runs' and the field latents'
// conditionals are independent, so each thread computes some of them in its
// own workspace (Work) into per-node slots, which one thread then sums in
// node order: the same operations in the same order as one thread, so the
// same numbers for any number of threads. No R API, R RNG or BLAS call
// inside a parallel region (the conditionals' factors are small_chol()).
#include "fbc.h"
#include <algorithm>
#include <limits>
#ifdef _OPENMP
#include <omp.h>
#endif
#if defined(_OPENMP) && !defined(_WIN32)
#include <pthread.h>
// GCC's OpenMP runtime cannot start threads in a process forked from one
// that ran threads (the child waits for threads it does not have): such a
// child (future's multicore plan, parallel::mclapply()) runs one thread.
static bool teamRan = false, forkedAfterTeam = false;
static void on_fork_child() { forkedAfterTeam = forkedAfterTeam || teamRan; }
static const int atforkSet = pthread_atfork(nullptr, nullptr, on_fork_child);
#endif

static inline int thread_id() {
#ifdef _OPENMP
  return omp_get_thread_num();
#else
  return 0;
#endif
}

// Whether this build has OpenMP (else calibrate(threads =) runs one thread).
// [[Rcpp::export(.has_openmp)]]
bool has_openmp() {
#ifdef _OPENMP
  return true;
#else
  return false;
#endif
}

// Squared scaled distance between row a of X and the point y (first K
// columns).
static inline double scaled_d2(const arma::mat& X, arma::uword a, const double* y,
                               const arma::vec& w, int K) {
  double s = 0.0;
  for (int k = 0; k < K; ++k) {
    const double d = w[k] * (X.at(a, k) - y[k]);
    s += d * d;
  }
  return s;
}

// The k nearest rows of X (among rows[0 .. nr - 1], or the first nr when
// rows is null) to the point y, scaled by w: into out (nearest first, ties
// to the lower row; fewer when there are fewer rows). `cand` is a workspace.
static void nearest(const arma::mat& X, const int* rows, int nr, const double* y,
                    const arma::vec& w, int K, int k,
                    std::vector<std::pair<double, int> >& cand, std::vector<int>& out) {
  cand.resize(nr);
  for (int r = 0; r < nr; ++r) {
    const int a = rows ? rows[r] : r;
    cand[r] = std::make_pair(scaled_d2(X, a, y, w, K), a);
  }
  const int kk = std::min(k, nr);
  std::partial_sort(cand.begin(), cand.begin() + kk, cand.end());
  out.resize(kk);
  for (int r = 0; r < kk; ++r) out[r] = cand[r].second;
}

// Maximin ordering of the rows of X scaled by w (Guinness 2018): first the
// row nearest the centre of the scaled design, then each time the row
// farthest from all rows taken so far (ties to the lower index). O(m^2 K)
// time, O(m) memory. 1-based row numbers.
// [[Rcpp::export(.vecchia_order)]]
Rcpp::IntegerVector vecchia_order(const arma::mat& X, const arma::vec& w) {
  const int m = X.n_rows, K = X.n_cols;
  std::vector<double> centre(K), mind(m, R_PosInf);
  for (int k = 0; k < K; ++k) centre[k] = arma::mean(X.col(k));
  std::vector<char> taken(m, 0);
  Rcpp::IntegerVector out(m);
  int first = 0;
  double best = R_PosInf;
  for (int a = 0; a < m; ++a) {
    const double d = scaled_d2(X, a, centre.data(), w, K);
    if (d < best) { best = d; first = a; }
  }
  int cur = first;
  std::vector<double> y(K);
  for (int t = 0; t < m; ++t) {
    out[t] = cur + 1;
    taken[cur] = 1;
    for (int k = 0; k < K; ++k) y[k] = X.at(cur, k);
    int next = -1;
    double far = -1.0;
    for (int a = 0; a < m; ++a) {
      if (taken[a]) continue;
      const double d = scaled_d2(X, a, y.data(), w, K);
      if (d < mind[a]) mind[a] = d;
      if (mind[a] > far) { far = mind[a]; next = a; }
    }
    cur = next;
    if (t % 256 == 255) Rcpp::checkUserInterrupt();
  }
  return out;
}

// For the rows of X in the order `ord` (1-based), the k nearest earlier
// rows of each in the scaled distance (an m x k matrix of 1-based row
// numbers, nearest first; 0 where a row has fewer than k earlier ones).
// O(m^2 K / 2) time.
// [[Rcpp::export(.vecchia_neighbours)]]
Rcpp::IntegerMatrix vecchia_neighbours(const arma::mat& X, const Rcpp::IntegerVector& ord,
                                       const arma::vec& w, int k) {
  const int m = X.n_rows, K = X.n_cols;
  if (ord.size() != m) Rcpp::stop("the ordering must have %d entries", m);
  Rcpp::IntegerMatrix out(m, k);
  std::vector<int> prev(m);
  for (int i = 0; i < m; ++i) prev[i] = ord[i] - 1;
  std::vector<double> y(K);
  std::vector<std::pair<double, int> > cand;
  std::vector<int> nb;
  for (int i = 1; i < m; ++i) {
    const int s = prev[i];
    for (int c = 0; c < K; ++c) y[c] = X.at(s, c);
    nearest(X, prev.data(), i, y.data(), w, K, k, cand, nb);
    for (size_t r = 0; r < nb.size(); ++r) out(i, r) = nb[r] + 1;
    if (i % 256 == 255) Rcpp::checkUserInterrupt();
  }
  return out;
}

VecchiaPosterior::VecchiaPosterior(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                                   const arma::vec& ys, double nugget, const Model& model)
  : SchurPosterior(Xf, yf, Xs, ys, nugget, model), vd_(model.vecchia) {
  const int K = p + q;
  if ((int) vd_.ord.size() != m || (int) vd_.nbr.size() != m * vd_.k || (int) vd_.w.n_elem != K)
    Rcpp::stop("the Vecchia design does not fit the simulator runs");
  const int smax = vd_.k + vd_.kf + 1;
#ifdef _OPENMP
  nt_ = std::max(1, model.threads);
#ifndef _WIN32
  if (forkedAfterTeam) nt_ = 1;
  if (nt_ > 1) teamRan = true;
#endif
#endif
  ws_.resize(nt_);
  const size_t nemax = (size_t) smax * (smax + 1) / 2;
  for (Work& w : ws_) {
    w.Kw.set_size(smax + 1, smax);  // a row more: runsPass()'s L^-1 y
    w.Xg.set_size(smax, K);
    w.rhs.set_size(smax);
    w.Gw.resize(nemax * K);
    w.Cw.resize(nemax);
    w.Ww.resize(nemax);
    w.x.resize(K);
    w.rid.resize(smax);
  }
  runLd_.resize(m);
  runZz_.resize(m);
  cacheRuns();
  // each field latent's earlier latents: the kf nearest in the scaled
  // experimental inputs (they share kappa)
  nbrL_.resize(nu_);
  std::vector<std::pair<double, int> > cand;
  const arma::vec wx = vd_.w.head(p);
  for (int j = 1; j < nu_; ++j) {
    const arma::rowvec y = Xu_.row(j);
    nearest(Xu_, nullptr, j, y.memptr(), wx, p, vd_.kf, cand, nbrL_[j]);
  }
  // each latent's earlier latents by index: (latent, place in nbrL_[j])
  rowL_.resize(nu_);
  for (int j = 0; j < nu_; ++j) {
    for (size_t l = 0; l < nbrL_[j].size(); ++l) rowL_[j].emplace_back(nbrL_[j][l], (int) l);
    std::sort(rowL_[j].begin(), rowL_[j].end());
  }
  for (int b = 0; b < 2; ++b) { nbrF_.b[b].assign((size_t) nu_ * vd_.k, -1); }
  // the experimental part of every field latent's distance to every run,
  // summed in scaled_d2()'s order, so fieldNeighbours() adds the kappa part
  // and finds the same neighbours as nearest(); per latent the runs sorted
  // by it (O(nu m) memory: the cross terms' share, 12 bytes each)
  xOrd_.resize((size_t) m * nu_);
  xD2_.resize((size_t) m * nu_);
  const int nt = nt_;
#ifdef _OPENMP
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
#endif
  for (int j = 0; j < nu_; ++j) {
    Work& w = ws_[thread_id()];
    std::vector<int> all;
    for (int d = 0; d < p; ++d) w.x[d] = Xu_.at(j, d);
    nearest(Xs_, nullptr, m, w.x.data(), vd_.w, p, m, w.cand, all);  // all m, sorted (cand)
    for (int r = 0; r < m; ++r) {
      xD2_[(size_t) j * m + r] = w.cand[r].first;
      xOrd_[(size_t) j * m + r] = w.cand[r].second;
    }
  }
  dt_.set_size(m, q);
}

std::string VecchiaPosterior::algebra() const {
  return "Vecchia (k = " + std::to_string(vd_.k) + ")";
}

// The per-dimension distance values of every run's conditioning set
// (kernel_dist_tri() of gatherRun()'s rows, runG_ from runOff_[i]): they
// never change. m (k + 1) (k + 2) / 2 (p + q) doubles (m = 1000, k = 20:
// 7.4 MB; m = 20,000, k = 10: 53 MB); none above the option
// FBC.vecchia_cache_mb (default 16; 0: never), where the conditionals
// compute them on the fly (the same numbers). Measured (RESULTS-vecchia.md):
// 3-8% less CPU at m = 1000, k = 20; 5-9% more at m = 20,000, k = 10, where
// reading the cache costs more than recomputing.
void VecchiaPosterior::cacheRuns() {
  const int K = p + q, k = vd_.k;
  runC_.assign(m, 0);
  runOff_.assign(m + 1, 0);
  for (int i = 0; i < m; ++i) {
    const int* nb = vd_.nbr.data() + (size_t) i * k;
    int c = 0;
    while (c < k && nb[c] >= 0) ++c;
    runC_[i] = c;
    runOff_[i + 1] = runOff_[i] + (size_t) (c + 1) * (c + 2) / 2 * K;
  }
  double mb = 16;
  SEXP opt = Rf_GetOption1(Rf_install("FBC.vecchia_cache_mb"));
  if (opt != R_NilValue) {
    mb = Rf_length(opt) == 1 && Rf_isNumeric(opt) ? Rf_asReal(opt) : R_NaN;
    if (!(mb >= 0)) Rcpp::stop("option FBC.vecchia_cache_mb must be one number >= 0 (megabytes)");
  }
  runG_.clear();
  if (!(runOff_[m] * sizeof(double) <= mb * 1048576.0)) return;
  runG_.resize(runOff_[m]);
  for (int i = 0; i < m; ++i) {
    const int c = gatherRun(ws_[0], i);
    kernel_dist_tri(kernS_, ws_[0].Xg, c + 1, K, runG_.data() + runOff_[i]);
  }
}

// The levels' correlations levelC_ at phi's rhoS, recomputed only when
// they moved; before the conditionals (which read levelC_) of a pass.
void VecchiaPosterior::syncLevels() {
  const int nz = level_count(levels);
  if (nz && (levelZ_.n_elem != (arma::uword) nz ||
             arma::any(levelZ_ != phi.subvec(iRhoS, iRhoS + nz - 1)))) {
    levelZ_ = phi.subvec(iRhoS, iRhoS + nz - 1);
    level_corr(levels, levelZ_.memptr(), levelC_);
  }
}

// The conditional of the node in the last of the s rows of w.Xg given the
// others (the first `runs` of them simulator runs w.rid, with runDiag()): the
// factor of their joint correlation in w.Kw, coefficients into w.rhs[0 ..
// s-2] (when `coef`), returns the conditional variance (NaN when the factor
// fails even with a jitter on the latents). G: the rows' per-dimension
// distance values (kernel_dist_tri(); null: computed here from w.Xg). y (s
// values, or null): L^-1 y into row s of w.Kw. Reads only phi and levelC_
// (syncLevels()), so threads may call it, each with its own w.
double VecchiaPosterior::conditional(Work& w, int s, int runs, bool coef, const double* G,
                                     const double* y) const {
  const int K = p + q, lda = w.Kw.n_rows;
  const double* thetaS = phi.memptr() + iThetaS;
  const double* alphaS = phi.memptr() + iAlphaS;
  const size_t ne = (size_t) s * (s + 1) / 2;
  if (!G) {
    kernel_dist_tri(kernS_, w.Xg, s, K, w.Gw.data());
    G = w.Gw.data();
  }
  kernel_corr_flat(kernS_, G, ne, K, thetaS, alphaS, w.Cw.data(), w.Ww.data());
  for (double jitter = 0.0; jitter < 1e-3; jitter = jitter == 0.0 ? 1e-10 : 100 * jitter) {
    const double* r = w.Cw.data();
    for (int j = 0; j < s; ++j) {
      std::memcpy(w.Kw.colptr(j) + j, r, (s - j) * sizeof(double));
      r += s - j;
    }
    level_scale(levels, levelC_, w.Xg, w.Xg, w.Kw, true, s);
    for (int i = 0; i < s; ++i) w.Kw.at(i, i) += i < runs ? runDiag(w.rid[i]) : jitter;
    if (y) for (int j = 0; j < s; ++j) w.Kw.at(s, j) = y[j];
    if (!small_chol(w.Kw.memptr(), s, lda, y ? s + 1 : s)) continue;
    if (coef) {
      for (int l = 0; l < s - 1; ++l) w.rhs[l] = w.Kw.at(s - 1, l);
      small_back(w.Kw.memptr(), s - 1, lda, w.rhs.memptr());
    }
    const double d = w.Kw.at(s - 1, s - 1);
    return d * d;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

// log|Ds| and ys' Ds^-1 ys over the runs' conditionals (those of the last
// simPreview() when it was at the same correlation parameters).
bool VecchiaPosterior::simUpdate(const Touch& t, double& ldDs, double& zz) {
  if (!t.simCorr) return true;
  if (previewSet_) {
    previewSet_ = false;
    if (arma::all(simKey() == previewKey_)) {
      if (!previewOk_) return false;
      ldDs = previewLd_; zz = previewZz_;
      return true;
    }
  }
  return runsPass(ldDs, zz);
}

// What the runs' conditionals depend on in phi: the simulator GP's
// correlation parameters thetaS, alphaS, rhoS and, with the simulator's own
// noise, sigma2S and the noise variance (sigma2R, or the latent gR).
arma::vec VecchiaPosterior::simKey() const {
  const int K = p + q, nz = level_count(levels);
  const int nr = !simNoise ? 0 : latent ? 1 + m : 2;
  arma::vec key(2 * K + nz + nr);
  for (int d = 0; d < K; ++d) { key[d] = phi[iThetaS + d]; key[K + d] = phi[iAlphaS + d]; }
  for (int z = 0; z < nz; ++z) key[2 * K + z] = phi[iRhoS + z];
  if (nr) {
    double* r = key.memptr() + 2 * K + nz;
    r[0] = phi[iSigma2S];
    if (latent) for (int i = 0; i < m; ++i) r[1 + i] = phi[iG + i];
    else r[1] = phi[iSigma2R];
  }
  return key;
}

// zz (and log|Ds|) at phi[idx] = values, phi left as it was; kept for the
// propose() of the same values that follows (simUpdate()).
bool VecchiaPosterior::simPreview(const std::vector<int>& idx, const arma::vec& values,
                                  double& zz, bool& ok) {
  arma::vec old(idx.size());
  for (size_t i = 0; i < idx.size(); ++i) { old[i] = phi[idx[i]]; phi[idx[i]] = values[i]; }
  previewKey_ = simKey();
  previewOk_ = runsPass(previewLd_, previewZz_);
  previewSet_ = true;
  for (size_t i = 0; i < idx.size(); ++i) phi[idx[i]] = old[i];
  ok = previewOk_;
  zz = previewOk_ ? previewZz_ : NA_REAL;
  return true;
}

// The runs' conditionals at phi: log|Ds| ~ sum log d_i, zz ~ sum e_i^2 / d_i
// (the terms in parallel, the sums in run order).
bool VecchiaPosterior::runsPass(double& ldDs, double& zz) {
  const int k = vd_.k, nt = nt_;
  const bool gather = runG_.empty() || !levels.empty();
  syncLevels();
#ifdef _OPENMP
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
#endif
  for (int i = 0; i < m; ++i) {
    Work& w = ws_[thread_id()];
    const int* nb = vd_.nbr.data() + (size_t) i * k;
    const int c = gather ? gatherRun(w, i) : runC_[i];
    for (int r = 0; r < c; ++r) { w.rhs[r] = ys_[nb[r]]; w.rid[r] = nb[r]; }
    w.rhs[c] = ys_[vd_.ord[i]];
    w.rid[c] = vd_.ord[i];
    // z = L^-1 [ys_N; ys_s] in row c + 1 of Kw: its last entry is e / sqrt(d)
    const double v = conditional(w, c + 1, c + 1, false, runDist(i), w.rhs.memptr());
    const double z = w.Kw.at(c + 1, c);
    runLd_[i] = v > 0 ? std::log(v) : std::numeric_limits<double>::quiet_NaN();
    runZz_[i] = z * z;
  }
  double ld = 0.0, qq = 0.0;
  for (int i = 0; i < m; ++i) {
    if (std::isnan(runLd_[i])) return false;
    ld += runLd_[i];
    qq += runZz_[i];
  }
  ldDs = ld; zz = qq;
  return true;
}

// Gathers run i's conditioning system into w.Xg: its earlier neighbours,
// then the run itself (the i-th in the maximin order); returns the number
// of neighbours c (c + 1 rows).
int VecchiaPosterior::gatherRun(Work& w, int i) const {
  const int K = p + q, k = vd_.k;
  const int* nb = vd_.nbr.data() + (size_t) i * k;
  int c = 0;
  for (; c < k && nb[c] >= 0; ++c) {
    for (int d = 0; d < K; ++d) w.Xg.at(c, d) = Xs_.at(nb[c], d);
    w.rid[c] = nb[c];
  }
  const int s = vd_.ord[i];
  for (int d = 0; d < K; ++d) w.Xg.at(c, d) = Xs_.at(s, d);
  w.rid[c] = s;
  return c;
}

// The field latents' nearest runs at kappa (into nbrF, nu x k): the same
// runs, in the same order, as nearest() of each latent (x_j, kappa), but
// with the distances' experimental part dx2 precomputed (xD2_, each
// latent's runs in its ascending order xOrd_) and the kappa part computed
// once per run for all latents:
//   d2(j, i) = dx2(i, j) + sum_d (w_d (t_id - kappa_d))^2,
// added in scaled_d2()'s order; the k smallest in the order (d2, run
// index). The latent's neighbours at the previous kappa (prev) bound the
// k-th smallest d2 at the new one by the largest of their new d2, T: only
// runs with dx2 <= T can have d2 <= T (the kappa part is >= 0), so the
// scan of the sorted dx2 stops there and only runs with d2 <= T are sorted
// (every run when prev has none). Latents in parallel.
void VecchiaPosterior::fieldNeighbours(std::vector<int>& nbrF, const std::vector<int>& prev) {
  const int k = vd_.k, kk = std::min(k, m), nt = nt_;
  for (int d = 0; d < q; ++d) {
    const double wd = vd_.w[p + d], kap = phi[iKappa + d];
    double* out = dt_.colptr(d);
    for (int i = 0; i < m; ++i) { const double e = wd * (Xs_.at(i, p + d) - kap); out[i] = e * e; }
  }
  auto d2 = [this](double s2, int i) {
    for (int d = 0; d < q; ++d) s2 += dt_.at(i, d);
    return s2;
  };
  const double inf = std::numeric_limits<double>::infinity();
#ifdef _OPENMP
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
#endif
  for (int j = 0; j < nu_; ++j) {
    Work& w = ws_[thread_id()];
    std::vector<std::pair<double, int> >& cand = w.cand;
    const int* oj = xOrd_.data() + (size_t) j * m;
    const double* vj = xD2_.data() + (size_t) j * m;
    const int* pj = prev.data() + (size_t) j * k;
    double T = inf;
    if (kk > 0 && pj[kk - 1] >= 0) {
      for (int d = 0; d < p; ++d) w.x[d] = Xu_.at(j, d);
      T = -inf;
      for (int r = 0; r < kk; ++r)
        T = std::max(T, d2(scaled_d2(Xs_, pj[r], w.x.data(), vd_.w, p), pj[r]));
    }
    cand.clear();
    for (int r = 0; r < m && !(vj[r] > T); ++r) {
      const double s2 = d2(vj[r], oj[r]);
      if (!(s2 > T)) cand.emplace_back(s2, oj[r]);
    }
    if ((int) cand.size() < kk) {  // NaN distances: every run
      cand.clear();
      for (int r = 0; r < m; ++r) cand.emplace_back(d2(vj[r], oj[r]), oj[r]);
    }
    std::partial_sort(cand.begin(), cand.begin() + kk, cand.end());
    for (int r = 0; r < k; ++r) nbrF[(size_t) j * k + r] = r < kk ? cand[r].second : -1;
  }
}

// Gathers [runs nb (its first c entries); latents L; the point x] into w.Xg
// (latents and the point at kappa); returns the number of rows.
int VecchiaPosterior::gather(Work& w, const int* nb, int c, const std::vector<int>& L,
                             const double* x) const {
  const int K = p + q;
  arma::mat& Xg = w.Xg;
  int r = 0;
  for (int a = 0; a < c; ++a, ++r) {
    for (int d = 0; d < K; ++d) Xg.at(r, d) = Xs_.at(nb[a], d);
    w.rid[r] = nb[a];
  }
  for (int l : L) {
    for (int d = 0; d < p; ++d) Xg.at(r, d) = Xu_.at(l, d);
    for (int d = 0; d < q; ++d) Xg.at(r, p + d) = phi[iKappa + d];
    ++r;
  }
  for (int d = 0; d < p; ++d) Xg.at(r, d) = x[d];
  for (int d = 0; d < q; ++d) Xg.at(r, p + d) = phi[iKappa + d];
  return r + 1;
}

// wz = M^-1 h and Q = M^-1 diag(g) M^-T (lower) from the latents'
// conditionals at the current state (see the top), in parallel;
// latentSolve() does the algebra.
void VecchiaPosterior::simCross(const Touch& t, const arma::mat&, arma::mat& Q, arma::vec& wz) {
  std::vector<int>& nbrF = t.cChange ? nbrF_.alt() : nbrF_.cur();
  if (t.cChange) fieldNeighbours(nbrF, nbrF_.cur());
  const int k = vd_.k, nt = nt_;
  hL_.set_size(nu_);
  gL_.set_size(nu_);
  cL_.resize(nbrL_.size());
  syncLevels();
#ifdef _OPENMP
#pragma omp parallel for num_threads(nt) schedule(static) if (nt > 1)
#endif
  for (int j = 0; j < nu_; ++j) {
    Work& w = ws_[thread_id()];
    const int* nb = nbrF.data() + (size_t) j * k;
    int c = 0;
    while (c < k && nb[c] >= 0) ++c;
    const std::vector<int>& L = nbrL_[j];
    for (int d = 0; d < p; ++d) w.x[d] = Xu_.at(j, d);
    const int s = gather(w, nb, c, L, w.x.data());
    double v = conditional(w, s, c, true);
    if (!(v >= 0)) v = 0.0;
    gL_[j] = v;
    double hj = 0.0;
    for (int a = 0; a < c; ++a) hj += w.rhs[a] * ys_[nb[a]];
    hL_[j] = hj;
    cL_[j].resize(L.size());
    for (size_t l = 0; l < L.size(); ++l) cL_[j][l] = -w.rhs[c + l];  // M[j, L[l]]
  }
  latentSolve(Q, wz);
}

// With M = I - C unit lower triangular (row j: M[j, L_j] = cL_[j], L_j =
// nbrL_[j]): Mi = M^-1, wz = Mi h, Q = Mi diag(g) Mi' (lower), each entry
// by the operations, in the order, of the reference BLAS's dtrsm (Mi,
// through arma::solve(trimatl(M), I)), dgemv (Mi h) and dgemm ((Mi
// diag(g)) Mi'), leaving out the terms of M's and Mi's zeros (adding a
// zero product changes no sum):
//   Mi[i, j] = 0 - sum_{l in L_i, l >= j, ascending} Mi[l, j] M[i, l]  (i > j),
//   wz[i] = 0 + sum_{j <= i} h[j] Mi[i, j],
//   Q[i, j] = 0 + sum_{l <= j} Mi[j, l] (Mi[i, l] g[l])  (i >= j).
// O(nu^2 kf + nu^3 / 6) instead of O(nu^3 4 / 3) with dense M. The columns
// of Mi and of Q are independent: in parallel.
void VecchiaPosterior::latentSolve(arma::mat& Q, arma::vec& wz) {
  const int nt = nt_;
  Mi_.zeros(nu_, nu_);
#ifdef _OPENMP
#pragma omp parallel for num_threads(nt) schedule(dynamic, 4) if (nt > 1)
#endif
  for (int j = 0; j < nu_; ++j) {
    Mi_.at(j, j) = 1.0;
    for (int i = j + 1; i < nu_; ++i) {
      double b = 0.0;
      for (const std::pair<int, int>& e : rowL_[i]) {
        if (e.first < j) continue;
        const double bk = Mi_.at(e.first, j);
        if (bk != 0.0) b = b - bk * cL_[i][e.second];
      }
      Mi_.at(i, j) = b;
    }
  }
  wz.zeros(nu_);
  for (int j = 0; j < nu_; ++j) {
    const double hj = hL_[j];
    const double* mj = Mi_.colptr(j);
    for (int i = j; i < nu_; ++i) wz[i] = wz[i] + hj * mj[i];
  }
  Ag_.set_size(nu_, nu_);
  for (int l = 0; l < nu_; ++l)
    for (int i = l; i < nu_; ++i) Ag_.at(i, l) = Mi_.at(i, l) * gL_[l];
  Q.set_size(nu_, nu_);
#ifdef _OPENMP
#pragma omp parallel for num_threads(nt) schedule(dynamic, 4) if (nt > 1)
#endif
  for (int j = 0; j < nu_; ++j) {
    double* qj = Q.colptr(j);
    for (int i = j; i < nu_; ++i) qj[i] = 0.0;
    for (int l = 0; l <= j; ++l) {
      const double t = Mi_.at(j, l);
      const double* al = Ag_.colptr(l);
      for (int i = j; i < nu_; ++i) qj[i] = qj[i] + t * al[i];
    }
  }
}

void VecchiaPosterior::simFlip(const Touch& t) {
  if (t.cChange) nbrF_.flip();
}

// New points as further latents after the field latents, each conditioned
// on its k nearest runs and its kf nearest field latents: with coefficients
// a (runs), c (latents F) and variance g,
//   E(eta* | ys) = a' ys_N + c' wz_F,  cov(f, eta* | ys) = Q[, F] c,
//   var(eta* | ys) = c' Q_FF c + g,
// so a = E, b = 1 - var, G = Rs(Xu, x*) - cov (the dense algebra's
// quantities, of which these are the exact values when every node conditions
// on all its predecessors).
void VecchiaPosterior::simCondition(const arma::mat& Xnew, arma::vec& a, arma::vec& b,
                                    arma::mat& G) {
  const int nb = Xnew.n_rows, K = p + q, k = vd_.k;
  const arma::mat Qf = arma::symmatl(curQ());
  const arma::vec& wz = curWz();
  G.set_size(nu_, nb);
  const arma::vec th = phi.subvec(iThetaS, iThetaS + p - 1);
  const arma::vec al = phi.subvec(iAlphaS, iAlphaS + p - 1);
  arma::mat Rx = corr_matrix(Xu_, Xnew, th, al, kernS_);
  level_scale(levels, phi.memptr() + iRhoS, Xu_, Xnew, Rx, false);
  std::vector<double> y(K);
  std::vector<std::pair<double, int> > cand;
  std::vector<int> near, L;
  const arma::vec wx = vd_.w.head(p);
  Work& w = ws_[0];
  syncLevels();
  for (int c = 0; c < nb; ++c) {
    for (int d = 0; d < p; ++d) y[d] = Xnew.at(c, d);
    for (int d = 0; d < q; ++d) y[p + d] = phi[iKappa + d];
    nearest(Xs_, nullptr, m, y.data(), vd_.w, K, k, cand, near);
    nearest(Xu_, nullptr, nu_, y.data(), wx, p, vd_.kf, cand, L);
    const int cr = near.size();
    const int s = gather(w, near.data(), cr, L, y.data());
    double v = conditional(w, s, cr, true);
    if (!(v >= 0)) v = 0.0;
    double mean = 0.0;
    for (int r = 0; r < cr; ++r) mean += w.rhs[r] * ys_[near[r]];
    arma::vec cf(L.size());
    for (size_t l = 0; l < L.size(); ++l) { cf[l] = w.rhs[cr + l]; mean += cf[l] * wz[L[l]]; }
    const arma::uvec F = arma::conv_to<arma::uvec>::from(L);
    const arma::vec cov = Qf.cols(F) * cf;
    const double var = arma::dot(cf, Qf.submat(F, F) * cf) + v;
    a[c] = mean;
    b[c] = 1.0 - var;
    G.col(c) = Rx.col(c) - cov;
  }
}

// Ds^-1 ~ U U' from the runs' conditionals: a = U U' ys, and per fold B
// (Ds^-1)_BB = sum over columns of U of the outer products of their
// entries in B.
void VecchiaPosterior::simHeldout(const std::vector<std::vector<int> >& folds, arma::vec& a,
                                  std::vector<arma::mat>& QBB) {
  const int k = vd_.k;
  std::vector<int> fold(m, -1), at(m, -1);
  QBB.assign(folds.size(), arma::mat());
  for (size_t f = 0; f < folds.size(); ++f) {
    QBB[f].zeros(folds[f].size(), folds[f].size());
    for (size_t r = 0; r < folds[f].size(); ++r) { fold[folds[f][r]] = f; at[folds[f][r]] = r; }
  }
  arma::vec Uty(m, arma::fill::zeros);  // U' ys
  std::vector<std::vector<std::pair<int, double> > > cols(m);
  Work& w = ws_[0];
  syncLevels();
  for (int i = 0; i < m; ++i) {
    const int* nb = vd_.nbr.data() + (size_t) i * k;
    const int c = gatherRun(w, i), s = vd_.ord[i];
    const double v = conditional(w, c + 1, c + 1, true, runDist(i));
    const double sd = std::sqrt(v);
    std::vector<std::pair<int, double> >& col = cols[i];
    col.emplace_back(s, 1.0 / sd);
    for (int r = 0; r < c; ++r) col.emplace_back(nb[r], -w.rhs[r] / sd);
    double u = 0.0;
    for (const auto& e : col) u += e.second * ys_[e.first];
    Uty[i] = u;
    for (const auto& e1 : col)
      for (const auto& e2 : col)
        if (fold[e1.first] >= 0 && fold[e1.first] == fold[e2.first])
          QBB[fold[e1.first]](at[e1.first], at[e2.first]) += e1.second * e2.second;
  }
  a.zeros(m);
  for (int i = 0; i < m; ++i)
    for (const auto& e : cols[i]) a[e.first] += e.second * Uty[i];
}

// Ds^-1 ~ U U' (the runs' conditionals, as simHeldout() has them): W = U' K
// for K = Rs(Xs, Z), wy = U' ys, G = (U' Rs(Xs,Xk))' W.
void VecchiaPosterior::simWhiten(const arma::mat& Z, arma::mat& W, arma::vec& wy, arma::mat& G,
                                 bool haveW) {
  const int k = vd_.k;
  const arma::vec th = phi.subvec(iThetaS, iThetaS + p + q - 1);
  const arma::vec al = phi.subvec(iAlphaS, iAlphaS + p + q - 1);
  arma::mat K;
  if (!haveW) {
    K = corr_matrix(Xs_, Z, th, al, kernS_);
    level_scale(levels, phi.memptr() + iRhoS, Xs_, Z, K, false);
    W.zeros(m, Z.n_rows);
    wy.zeros(m);
  }
  arma::mat Xk(nu_, p + q);
  Xk.cols(0, p - 1) = Xu_;
  for (int d = 0; d < q; ++d) Xk.col(p + d).fill(phi[iKappa + d]);
  arma::mat KB = corr_matrix(Xs_, Xk, th, al, kernS_);
  level_scale(levels, phi.memptr() + iRhoS, Xs_, Xk, KB, false);
  arma::mat WB(m, nu_, arma::fill::zeros);
  Work& w = ws_[0];
  syncLevels();
  for (int i = 0; i < m; ++i) {
    const int* nb = vd_.nbr.data() + (size_t) i * k;
    const int c = gatherRun(w, i), s = vd_.ord[i];
    const double sd = std::sqrt(conditional(w, c + 1, c + 1, true, runDist(i)));
    WB.row(i) = KB.row(s) / sd;
    if (!haveW) { W.row(i) = K.row(s) / sd; wy[i] = ys_[s] / sd; }
    for (int r = 0; r < c; ++r) {
      const double b = w.rhs[r] / sd;
      WB.row(i) -= b * KB.row(nb[r]);
      if (!haveW) { W.row(i) -= b * K.row(nb[r]); wy[i] -= b * ys_[nb[r]]; }
    }
  }
  G = WB.t() * W;
}

// x <- Ds^-1 x with Ds^-1 ~ U U' (the runs' conditionals, as simWhiten()
// has them): u_i = (U' x)_i, then x = U u, O(m k^2) (the simulator's mean as
// a kernel expansion, sensitivity.cpp).
void VecchiaPosterior::simSolve(arma::vec& x) {
  const int k = vd_.k;
  Work& w = ws_[0];
  syncLevels();
  arma::vec out(m, arma::fill::zeros);
  for (int i = 0; i < m; ++i) {
    const int* nb = vd_.nbr.data() + (size_t) i * k;
    const int c = gatherRun(w, i), s = vd_.ord[i];
    const double sd = std::sqrt(conditional(w, c + 1, c + 1, true, runDist(i)));
    double u = x[s];
    for (int r = 0; r < c; ++r) u -= w.rhs[r] * x[nb[r]];
    u /= sd * sd;
    out[s] += u;
    for (int r = 0; r < c; ++r) out[nb[r]] -= w.rhs[r] * u;
  }
  x = out;
}
