// Design of new simulator runs (propose_runs(), R/propose_runs.R): the
// look-ahead criterion over retained draws phi_s (kappa and every
// hyperparameter, scaled space). Per draw the simulator's value y* at a
// candidate input u = (x, t) is Gaussian given the data, N(mu_s(u), v_s(u)),
// so a run at u returning y* reweights the draws by N(y*; mu_s, v_s),
// exactly. The criterion is the expected reduction, over fantasised values
// y*, of kappa's posterior variance (summed over the calibration inputs) or
// entropy, or with target points XT of the calibrated prediction's
// integrated variance (zeta(x) = eta(x, kappa) + delta(x), predict(type =
// "mean"), moved by each fantasised run too: target_var()). A batch is
// chosen greedily, each next point scored with the pending points' values
// fantasised jointly with it. Every draw's conditionals, log-likelihood and
// prior covariances are the model's own posterior's
// (Posterior::runConditional(), runPrior()): this file holds the criterion.
#include "fbc.h"

namespace {

// The draws' conditionals at the candidates U (Nc rows), per draw s
// (RunConditional): A's slice s (kept for a batch or runs of several
// values), mu, v (Nc x S, muT = mu'), ll, the variances' floors (1e-12 of
// the smallest prior variance), with T targets mT, VT (T x S), CTU (T x Nc
// x S); post and phis: the pending points' priors (prior_cov()).
struct DesignSystems {
  std::unique_ptr<Posterior> post;
  arma::mat phis, noise;  // noise: each candidate's run noise variance per draw (or empty)
  arma::cube A, CTU;
  arma::mat mu, muT, v, mT, VT;
  arma::vec ll, floor;
  int T = 0;
};

// Every draw's conditionals (rows of phis) at the candidates U and the
// targets XT (T x p; none for kappa's criterion); keepA: every draw's A.
DesignSystems design_systems(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                             const arma::vec& ys, const arma::mat& phis, const arma::mat& U,
                             const arma::mat& XT, double nugget, const Rcpp::List& model,
                             bool keepA) {
  const int p = Xf.n_cols, q = Xs.n_cols - Xf.n_cols;
  const Model mod = read_model(model, p, q);
  if (!mod.emulator) Rcpp::stop("the look-ahead handles simulator runs (a simulator GP)");
  if (!mod.source.empty() && XT.n_rows > 0) Rcpp::stop("a prediction target needs one bias");
  if (U.n_cols != (arma::uword)(p + q) || (XT.n_rows > 0 && XT.n_cols != (arma::uword)p))
    Rcpp::stop("U must have %d columns, XT %d", p + q, p);
  DesignSystems sys;
  sys.post = make_posterior(Xf, yf, Xs, ys, nugget, mod);
  Posterior& post = *sys.post;
  if (phis.n_cols != (arma::uword)post.d) Rcpp::stop("phis must have %d columns", post.d);
  const int S = phis.n_rows, Nc = U.n_rows, T = XT.n_rows;
  sys.phis = phis;
  sys.T = T;
  sys.mu.set_size(Nc, S); sys.v.set_size(Nc, S); sys.ll.set_size(S); sys.floor.zeros(S);
  if (T > 0) { sys.mT.set_size(T, S); sys.VT.set_size(T, S); }
  RunConditional rc;
  for (int s = 0; s < S; ++s) {
    // from the last draw by a move of the parameters that differ (the
    // plug-in's particles: kappa alone), its factors updated, not redone
    const arma::vec ph = phis.row(s).t();
    std::vector<int> idx;
    for (int j = 0; j < post.d && s > 0; ++j) if (ph[j] != post.phi[j]) idx.push_back(j);
    bool ok = s > 0 && (idx.empty() || std::isfinite(post.propose(idx, ph.elem(arma::conv_to<arma::uvec>::from(idx)))));
    if (ok && !idx.empty()) post.accept(); else if (s > 0 && !idx.empty()) post.reject();
    if (!ok && !post.init(ph))
      Rcpp::stop("The covariance matrix of draw %d is not positive definite.", s + 1);
    sys.ll[s] = post.logLik();
    if (Nc + T > 0) {
      post.runConditional(U, XT, rc);
      if (s == 0) {
        sys.A.set_size(rc.A.n_rows, Nc, keepA ? S : 0);
        if (T > 0) sys.CTU.set_size(T, Nc, S);
      }
      if (keepA) sys.A.slice(s) = rc.A;
      sys.mu.col(s) = rc.mu; sys.v.col(s) = rc.v;
      if (Nc > 0) sys.floor[s] = 1e-12 * rc.v0.min() / (1.0 + nugget);
      if (T > 0) { sys.mT.col(s) = rc.mT; sys.VT.col(s) = rc.VT; sys.CTU.slice(s) = rc.CTU; }
    }
    if (s % 100 == 99) Rcpp::checkUserInterrupt();
  }
  sys.muT = sys.mu.t();
  return sys;
}

// Draw s's prior covariance of the simulator's values at rows X and Y.
void prior_cov(const DesignSystems& sys, int s, const arma::mat& X, const arma::mat& Y,
               arma::mat& out) {
  sys.post->runPrior(sys.phis.row(s).t(), X, Y, out);
}

// The greedy look-ahead's state: S draws, Nr runs of K values each (rows
// r K .. r K + K - 1 of the Nc candidates), J fantasies. kap (S x q) kappa,
// ksq |kappa_s|^2, base (S x J) the log-weights given the pending points'
// fantasies YP (J x k), P the pending candidates; with pending points the
// conditional means' terms (cond_means(); s fastest) Bk[s + S (c + Nc i)]
// and Dk[s + S (i + k j)]; per run r and draw s the factor of its values'
// covariance LK[(r S + s) K^2 ..] and its log-determinant / 2 ldK[r S + s];
// eK (S x K) a fantasy's standardised residuals. With T targets: their
// means MT[s + S (t + T j)], variances VTP (S x T), covariances with the
// candidates CP[s + S (t + T c)]; gK, vK: run_target_terms().
struct LookAhead {
  int S, Nc, J, T = 0, K = 1, Nr = 0;
  bool entropy = false;
  arma::mat kap, base, YP, VTP;
  arma::vec ksq, Lbuf, wbuf;
  std::vector<double> MT, CP, Bk, Dk, mbuf, LK, ldK, eK, gK, vK;
  std::vector<int> P;
};

// The sum over s of a_s b_s.
double dot_sum(const double* a, const double* b, int S) {
  double out = 0.0;
  for (int s = 0; s < S; ++s) out += a[s] * b[s];
  return out;
}

// Sum over kappa's columns of its variance under the weights
// w_s = exp(L_s - mx) / sum (mx = max L): sum_s w_s |k_s|^2 -
// sum_k (sum_s w_s k_sk)^2 (the weights and every sum in one pass over
// the draws, each sum in the draws' order).
double weighted_var(LookAhead& la, const double* L, double mx) {
  const int S = la.S, q = la.kap.n_cols;
  double sw = 0.0, swk = 0.0, mk[16] = {0.0};  // q <= 16 (design_look_ahead())
  for (int s = 0; s < S; ++s) {
    const double w = std::exp(L[s] - mx);
    sw += w; swk += w * la.ksq[s];
    for (int k = 0; k < q; ++k) mk[k] += w * la.kap(s, k);
  }
  double out = swk / sw;
  for (int k = 0; k < q; ++k) {
    const double m = mk[k] / sw;
    out -= m * m;
  }
  return out;
}

// The calibrated prediction's variance averaged over the T targets under
// the weights w_s = exp(L_s - mx), in fantasy j given the pending points;
// after a run m_st = MT_stj + g_st'e_s, v_st = vK_st, before it MT, VTP:
//   (1 / T) sum_t [sum_s w_s (v_st + m_st^2) / sum w - (sum_s w_s m_st / sum w)^2].
double target_var(LookAhead& la, const double* L, double mx, int j, bool run) {
  const int S = la.S;
  double* w = la.wbuf.memptr(), sw = 0.0, out = 0.0;
  for (int s = 0; s < S; ++s) sw += (w[s] = std::exp(L[s] - mx));
  for (int t = 0; t < la.T; ++t) {
    const double* mt = la.MT.data() + (size_t)S * (t + (size_t)la.T * j);
    const double* v = run ? la.vK.data() + (size_t)S * t : la.VTP.colptr(t);
    double a1 = 0.0, a2 = 0.0;
    for (int s = 0; s < S; ++s) {
      double ms = mt[s];
      for (int i = 0; run && i < la.K; ++i)
        ms += la.gK[s + (size_t)S * (t + (size_t)la.T * i)] * la.eK[s + (size_t)S * i];
      a1 += w[s] * (v[s] + ms * ms);
      a2 += w[s] * ms;
    }
    out += a1 / sw - (a2 / sw) * (a2 / sw);
  }
  return out / la.T;
}

// Kappa's entropy under the weights w_s = exp(L_s - mx) of the plug-in's
// kappa values (a grid or a uniform sample: up to a constant, kappa's):
//   -sum_s p_s log p_s = log sum w - sum_s w_s (L_s - mx) / sum w.
double weighted_entropy(LookAhead& la, const double* L, double mx) {
  double sw = 0.0, swl = 0.0;
  for (int s = 0; s < la.S; ++s) {
    const double l = L[s] - mx, w = std::exp(l);
    sw += w;
    if (w > 0.0) swl += w * l;  // (an underflowed weight: 0, not 0 x -inf)
  }
  return std::log(sw) - swl / sw;
}

// The criterion's value: the targets' variance, or kappa's entropy
// (la.entropy) or variance.
double crit_value(LookAhead& la, const double* L, double mx, int j, bool run) {
  if (la.T > 0) return target_var(la, L, mx, j, run);
  return la.entropy ? weighted_entropy(la, L, mx) : weighted_var(la, L, mx);
}

// Draw s's targets given the data and the pending points (SPP, ScP from
// pending_conditionals(); CT = CTU_s, CTP its pending columns):
//   BT = CTP SPP^-1,  VTP = VT - diag(BT CTP'),  MT(:, j) = mT + BT (YP(j, :)' - mu_P),
//   CP = CT - BT ScP'  (without pending points VTP = VT, MT = mT, CP = CT).
void pending_targets(const DesignSystems& sys, const arma::mat& SPP, const arma::mat& ScP,
                     const arma::uvec& Pu, int s, LookAhead& la) {
  const int k = Pu.n_elem, T = la.T, S = la.S;
  const arma::mat& CT = sys.CTU.slice(s);
  arma::vec vt = sys.VT.col(s);
  arma::mat DT(T, la.J, arma::fill::zeros), CPs;
  if (k > 0) {
    const arma::mat CTP = CT.cols(Pu);
    const arma::mat BT = arma::solve(SPP, CTP.t()).t();
    vt -= arma::sum(BT % CTP, 1);
    arma::vec muP(k);
    for (int i = 0; i < k; ++i) muP[i] = sys.mu(Pu[i], s);
    DT = BT * (la.YP.t() - arma::repmat(muP, 1, la.J));
    CPs = CT - BT * ScP.t();
  }
  const arma::mat& C = k > 0 ? CPs : CT;
  for (int t = 0; t < T; ++t) {
    la.VTP(s, t) = vt[t];
    for (int j = 0; j < la.J; ++j) la.MT[s + (size_t)S * (t + (size_t)T * j)] = sys.mT(t, s) + DT(t, j);
    for (int c = 0; c < la.Nc; ++c) la.CP[s + (size_t)S * (t + (size_t)T * c)] = C(t, c);
  }
}

// In-place lower Cholesky factor of the K x K symmetric a (column-major,
// lower triangle read) with each pivot floored at fl (a single value's
// variance's floor, DesignSystems::floor); returns sum log diag.
double chol_floor(double* a, int K, double fl) {
  double ld = 0.0;
  for (int j = 0; j < K; ++j) {
    double d = a[j + K * j];
    for (int l = 0; l < j; ++l) d -= a[j + K * l] * a[j + K * l];
    const double ljj = std::sqrt(std::max(d, fl));
    a[j + K * j] = ljj;
    ld += std::log(ljj);
    for (int i = j + 1; i < K; ++i) {
      double x = a[i + K * j];
      for (int l = 0; l < j; ++l) x -= a[i + K * l] * a[j + K * l];
      a[i + K * j] = x / ljj;
    }
  }
  return ld;
}

// Draw s's covariance of each run's K values given the data and the k
// pending points (B, ScP: pending_conditionals()), rows a != b of one run
//   Sigma_ab = C0_ab - A_a'A_b - B_a ScP_b'   (C0 the prior: the first run's,
// a run's rows differing in the output alone), its diagonal the rows'
// variances cv, and its factor (chol_floor()) in la.LK, la.ldK.
void run_covariances(const DesignSystems& sys, const arma::mat& U, const arma::vec& cv,
                     const arma::mat& B, const arma::mat& ScP, int k, int s, LookAhead& la) {
  const int K = la.K, S = la.S;
  arma::mat C0;
  if (K > 1) prior_cov(sys, s, U.rows(0, K - 1), U.rows(0, K - 1), C0);
  for (int r = 0; r < la.Nr; ++r) {
    double* L = la.LK.data() + (size_t)K * K * ((size_t)r * S + s);
    for (int l = 0; l < K; ++l) {
      L[l + K * l] = cv[r * K + l];
      for (int i = l + 1; i < K; ++i) {
        const int a = r * K + i, b = r * K + l;
        double x = C0(i, l) - dot_sum(sys.A.slice(s).colptr(a), sys.A.slice(s).colptr(b), sys.A.n_rows);
        for (int p = 0; p < k; ++p) x -= B(a, p) * ScP(b, p);
        L[i + K * l] = x;
      }
    }
    la.ldK[(size_t)r * S + s] = chol_floor(L, K, sys.floor[s]);
  }
}

// Per draw, the candidates' values given the data and the pending points'
// fantasised values: with A_P the pending columns of A,
//   SPP = C0(U_P, U_P) (nugget on its diagonal) - A_P'A_P,
//   ScP = C0(U, U_P) - A'A_P (a pending candidate's rows: SPP),
//   B = ScP SPP^-1,  cv = v - diag(B ScP'),  M(:, j) = mu + B (YP(j, :)' - mu_P),
// cv floored (sys.floor); B and D = YP' - mu_P are kept (Bk, Dk) and M
// formed where it is used (cond_means()). Without pending points M is mu.
void pending_conditionals(const DesignSystems& sys, const arma::mat& U, double nugget,
                          LookAhead& la) {
  const int k = la.P.size();
  const arma::uvec Pu = arma::conv_to<arma::uvec>::from(la.P);
  const arma::mat UP = U.rows(Pu);
  const int S = la.S, Nc = la.Nc;
  arma::mat SPP(k, k), ScP(la.Nc, k), B;
  la.Bk.resize((size_t)S * Nc * k);
  la.Dk.resize((size_t)S * k * la.J);
  for (int s = 0; s < la.S; ++s) {
    arma::vec cv = sys.v.col(s);
    if (k > 0) {
      const arma::mat& As = sys.A.slice(s);
      const arma::mat AP = As.cols(Pu);
      prior_cov(sys, s, UP, UP, SPP);
      SPP.diag() *= 1.0 + nugget;
      if (!sys.noise.is_empty())  // a pending run's value: its own noise too
        for (int i = 0; i < k; ++i) SPP(i, i) += sys.noise(la.P[i], s);
      SPP -= AP.t() * AP;
      prior_cov(sys, s, U, UP, ScP);
      ScP -= As.t() * AP;
      for (int i = 0; i < k; ++i) ScP.row(la.P[i]) = SPP.row(i);
      B = arma::solve(SPP, ScP.t()).t();
      cv -= arma::sum(B % ScP, 1);
      // B and D = YP' - mu_P kept with the draws innermost, for
      // cond_means()
      for (int i = 0; i < k; ++i) {
        double* bs = la.Bk.data() + s + (size_t)S * Nc * i;
        for (int c = 0; c < Nc; ++c) bs[(size_t)S * c] = B(c, i);
        const double muP = sys.mu(la.P[i], s);
        for (int j = 0; j < la.J; ++j) la.Dk[s + (size_t)S * (i + (size_t)k * j)] = la.YP(j, i) - muP;
      }
    }
    if (la.T > 0) pending_targets(sys, SPP, ScP, Pu, s, la);
    run_covariances(sys, U, cv, B, ScP, k, s, la);
  }
}

// The draws' conditional means at candidate c in fantasy j (S values):
// mu(c, s) without pending points, else
//   M_s(c, j) = mu(c, s) + sum_i B_s(c, i) D_s(i, j)
// computed here into `buf` (the draws innermost), not stored for every
// candidate and fantasy (S x Nc x J).
inline const double* cond_means(const DesignSystems& sys, const LookAhead& la, int c, int j,
                                double* buf) {
  if (la.P.empty()) return sys.muT.colptr(c);
  const int S = la.S, k = la.P.size();
  const double* mu = sys.muT.colptr(c);
  std::copy(mu, mu + S, buf);
  for (int i = 0; i < k; ++i) {
    const double* b = la.Bk.data() + (size_t)S * (c + (size_t)la.Nc * i);
    const double* dy = la.Dk.data() + (size_t)S * (i + (size_t)k * j);
    for (int s = 0; s < S; ++s) buf[s] += b[s] * dy[s];
  }
  return buf;
}

// Run r's K rows' conditional means in fantasy j (cond_means(), S each,
// into la.mbuf's K slices): mus[i] for row r K + i.
void run_means(const DesignSystems& sys, LookAhead& la, int r, int j, const double** mus) {
  for (int i = 0; i < la.K; ++i)
    mus[i] = cond_means(sys, la, r * la.K + i, j, la.mbuf.data() + (size_t)la.S * i);
}

// x <- L^-1 x in place (L K x K lower triangular, column-major); returns
// |x|^2 after.
inline double solve_small(const double* L, int K, double* x) {
  double ss = 0.0;
  for (int i = 0; i < K; ++i) {
    for (int l = 0; l < i; ++l) x[i] -= L[i + K * l] * x[l];
    x[i] /= L[i + K * i];
    ss += x[i] * x[i];
  }
  return ss;
}

// L_s = b_s + the log-density of run r's values y (K) under draw s, the
// normal's constant left out (b may be L; returns the largest L_s):
//   -|e_s|^2 / 2 - sum log diag LK_rs,  e_s = LK_rs^-1 (y - M_s) (kept in la.eK).
double run_log_density(LookAhead& la, int r, const double* const* mus, const double* y,
                       const double* b, double* L) {
  const int K = la.K, S = la.S;
  const double* ld = la.ldK.data() + (size_t)r * S;
  double e[16], mx = R_NegInf;  // K <= 16 (design_look_ahead())
  for (int s = 0; s < S; ++s) {
    const double* Ls = la.LK.data() + (size_t)K * K * ((size_t)r * S + s);
    double ss;
    if (K == 1) {  // (one value: the scoring's inner loop)
      e[0] = (y[0] - mus[0][s]) / Ls[0];
      ss = e[0] * e[0];
      la.eK[s] = e[0];
    } else {
      for (int i = 0; i < K; ++i) e[i] = y[i] - mus[i][s];
      ss = solve_small(Ls, K, e);
      for (int i = 0; i < K; ++i) la.eK[s + (size_t)S * i] = e[i];
    }
    L[s] = b[s] - 0.5 * ss - ld[s];
    mx = std::max(mx, L[s]);
  }
  return mx;
}

// target_var()'s terms of run r (K values), which no fantasy changes: per
// draw and target g_st = LK_rs^-1 CP_st(r) (CP_st(r) the target's
// covariances with the run's K values) and v_st = max(VTP_st - |g_st|^2, 0),
// in la.gK (S x T x K) and la.vK (S x T).
void run_target_terms(LookAhead& la, int r) {
  const int K = la.K, S = la.S, T = la.T;
  for (int t = 0; t < T; ++t)
    for (int s = 0; s < S; ++s) {
      const double* Ls = la.LK.data() + (size_t)K * K * ((size_t)r * S + s);
      double g[16];
      for (int i = 0; i < K; ++i) g[i] = la.CP[s + (size_t)S * (t + (size_t)T * (r * K + i))];
      const double gg = solve_small(Ls, K, g);
      for (int i = 0; i < K; ++i) la.gK[s + (size_t)S * (t + (size_t)T * i)] = g[i];
      la.vK[s + (size_t)S * t] = std::max(la.VTP(s, t) - gg, 0.0);
    }
}

// Each run's gain given the pending points: fantasy j of run r is y =
// M_src[j](r, j) + LK_r,src[j] z_j (z_j: Z's K deviates of row j), the draws
// reweighted by its normal density (run_log_density()):
//   gain(r) = mean_j Var_{base(:, j)}(kappa) - mean_j Var_{base(:, j) + log N}(kappa)
// (or the criterion's other value, crit_value()); Y (Nc x J) the fantasies.
void score_runs(const DesignSystems& sys, LookAhead& la, const int* src, const arma::mat& Z,
                int col, arma::vec& gain, arma::mat& Y) {
  const int K = la.K, S = la.S, J = la.J;
  double before = 0.0;
  for (int j = 0; j < J; ++j) {
    const double* b = la.base.colptr(j);
    before += crit_value(la, b, *std::max_element(b, b + S), j, false);
  }
  before /= J;
  double* L = la.Lbuf.memptr();
  const double* mus[16];
  double y[16];
  for (int r = 0; r < la.Nr; ++r) {
    if (la.T > 0) run_target_terms(la, r);
    double after = 0.0;
    for (int j = 0; j < J; ++j) {
      run_means(sys, la, r, j, mus);
      const int sr = src[j];
      const double* Ls = la.LK.data() + (size_t)K * K * ((size_t)r * S + sr);
      for (int i = 0; i < K; ++i) {
        double x = mus[i][sr];
        for (int l = 0; l <= i; ++l) x += Ls[i + K * l] * Z(j, col + l);
        y[i] = x;
        Y(r * K + i, j) = x;
      }
      const double mx = run_log_density(la, r, mus, y, la.base.colptr(j), L);
      after += crit_value(la, L, mx, j, true);
    }
    gain[r] = before - after / J;
  }
}

// A look-ahead in progress: the systems, the state, the inputs the steps
// read (U, the deviates Z, `order`: empty = greedy), the steps' results.
struct LookAheadRun {
  DesignSystems sys;
  LookAhead la;
  arma::mat U, Z, Y, scores;
  arma::vec lw, gain, best, success;
  arma::uvec kept;
  std::vector<int> order, s0, chosen;
  double variance = 0.0, nugget = 0.0;
  int n = 0, step = 0;
};

// Runs a look-ahead's steps up to `upto`: each picks the best run (or
// order[step]), whose fantasised values then reweight the draws.
void look_ahead_steps(LookAheadRun& run, int upto) {
  const DesignSystems& sys = run.sys;
  LookAhead& la = run.la;
  const int K = la.K;
  const double* mus[16];
  for (; run.step < upto; ++run.step) {
    const int step = run.step;
    pending_conditionals(sys, run.U, run.nugget, la);
    if (step == 0) run.variance = crit_value(la, run.lw.memptr(), run.lw.max(), 0, false);
    score_runs(sys, la, run.s0.data(), run.Z, step * K, run.gain, run.Y);
    if (run.success.n_elem) run.gain %= run.success;  // a run's gain if it succeeds
    for (int c : la.P) run.gain[c / K] = R_NegInf;
    run.scores.col(step) = run.gain;
    const int b = run.order.size() > 0 ? run.order[step] - 1 : (int)run.gain.index_max();
    run.chosen[step] = b + 1;
    run.best[step] = run.gain[b];
    for (int j = 0; j < la.J; ++j) {
      run_means(sys, la, b, j, mus);
      double y[16];
      for (int i = 0; i < K; ++i) y[i] = run.Y(b * K + i, j);
      run_log_density(la, b, mus, y, la.base.colptr(j), la.base.colptr(j));
    }
    for (int i = 0; i < K; ++i) {
      la.P.push_back(b * K + i);
      la.YP.insert_cols(la.YP.n_cols, run.Y.row(b * K + i).t());
    }
    Rcpp::checkUserInterrupt();
  }
}
// (the list of the steps run)
Rcpp::List look_ahead_result(const LookAheadRun& run) {
  const int k = run.step;
  return Rcpp::List::create(
      Rcpp::Named("chosen") = Rcpp::IntegerVector(run.chosen.begin(), run.chosen.begin() + k),
      Rcpp::Named("gain") = Rcpp::NumericVector(run.best.begin(), run.best.begin() + k),
      Rcpp::Named("variance") = run.variance,
      Rcpp::Named("scores") = arma::mat(run.scores.cols(0, k - 1)),
      Rcpp::Named("kept") = Rcpp::IntegerVector(run.kept.begin(), run.kept.end()) + 1);
}

}  // namespace

// The draws' conditionals at candidates (scaled): mean and variance of the
// simulator's value given the data (Nc x S) and the log-likelihood of each
// draw; with target points XT (T x p) their predictive means mT and
// variances VT (T x S).
// [[Rcpp::export(.design_systems)]]
Rcpp::List design_systems_r(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                            const arma::vec& ys, const arma::mat& phis, const arma::mat& U,
                            const arma::mat& XT, double nugget, const Rcpp::List& model) {
  DesignSystems sys = design_systems(Xf, yf, Xs, ys, phis, U, XT, nugget, model, false);
  return Rcpp::List::create(Rcpp::Named("mu") = sys.mu, Rcpp::Named("v") = sys.v,
                            Rcpp::Named("ll") = sys.ll, Rcpp::Named("mT") = sys.mT,
                            Rcpp::Named("VT") = sys.VT);
}

// The greedy look-ahead: n points chosen one at a time, each maximising the criterion's expected
// reduction given the pending points (score_runs()). Base log-weights lw0 (+ ll with `plugin`),
// normalised w; fantasy j comes from draw src[j], the first s with sum_{r <= s} w_r >= usrc[j],
// with the normal deviates Z(j, step K ..) in each step. With `order` (1-based, n distinct
// candidates) step k takes order[k] instead of the best. With `plugin` and prune > 0 the draws
// whose weight lw0 + ll is under exp(-prune) of the largest are left out first (the two largest
// kept). With `outputs` K > 1 the candidates are runs of K rows each (U's rows r K .. r K + K - 1,
// alike but for the output's columns). `entropy`: kappa's entropy, not its variance. Returns
// the picks (1-based), their gains, the current variance (or entropy), every run's gain per step
// (scores, Nr x n) and the draws scored (kept, 1-based); with `steps` < n only the first steps,
// and the look-ahead in progress (`state`, for design_look_ahead_resume(): the same results as
// all n at once). `success` (empty, or each run's probability of not failing) multiplies the
// gains. `noise` (empty, or candidates x draws): a stochastic simulator's noise variance of a
// run at each candidate under each draw, added to its value's variance (a replicate at a run's
// input is then a candidate like any other).
// [[Rcpp::export(.design_look_ahead)]]
Rcpp::List design_look_ahead(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                             const arma::vec& ys, const arma::mat& phis, const arma::mat& U,
                             const arma::mat& kappa, const arma::vec& lw0, bool plugin,
                             const arma::vec& usrc, const arma::mat& Z, const arma::mat& XT,
                             double nugget, const Rcpp::List& model,
                             const Rcpp::IntegerVector& order, double prune, int outputs,
                             bool entropy, int steps, const arma::vec& success,
                             const arma::mat& noise) {
  const int K = outputs;
  if (K < 1 || K > 16 || U.n_rows % K != 0 || Z.n_cols % K != 0)
    Rcpp::stop("outputs must be 1 to 16, dividing U's rows and Z's columns");
  const int n = Z.n_cols / K, Nr = U.n_rows / K;
  if (steps < 1 || (success.n_elem && (int)success.n_elem != Nr) ||
      (!noise.is_empty() && (noise.n_rows != U.n_rows || noise.n_cols != phis.n_rows || K > 1)))
    Rcpp::stop("steps must be 1 or more, success and noise empty or one per run (noise: x draws)");
  // a run's rows differ as the first run's do (run_covariances())
  for (int r = 1; r < Nr && K > 1; ++r)
    for (int i = 1; i < K; ++i)
      if (arma::any(arma::abs((U.row(r * K + i) - U.row(r * K)) - (U.row(i) - U.row(0))) > 1e-12))
        Rcpp::stop("a run's rows must differ in the output alone");
  if (order.size() > 0) {
    if (order.size() != n) Rcpp::stop("order must have %d candidates", n);
    for (int k = 0; k < n; ++k) {
      if (order[k] < 1 || order[k] > Nr) Rcpp::stop("order must index the candidates");
      for (int i = 0; i < k; ++i)
        if (order[i] == order[k]) Rcpp::stop("order must not repeat a candidate");
    }
  }
  if (phis.n_rows < 1 || kappa.n_rows != phis.n_rows || lw0.n_elem != phis.n_rows ||
      kappa.n_cols < 1 || kappa.n_cols > 16)
    Rcpp::stop("kappa (1 to 16 columns) and lw0 must have a row per draw, and phis a draw");
  if ((int)usrc.n_elem != (int)Z.n_rows) Rcpp::stop("usrc must have %d uniforms", (int)Z.n_rows);
  Rcpp::XPtr<LookAheadRun> xp(new LookAheadRun, true);  // (R's now: freed if interrupted)
  LookAheadRun& run = *xp;
  run.U = U; run.Z = Z; run.n = n; run.nugget = nugget; run.success = success;
  run.order.assign(order.begin(), order.end());
  run.kept = arma::regspace<arma::uvec>(0, phis.n_rows - 1);
  if (plugin && prune > 0 && phis.n_rows > 2) {
    // the likelihoods alone first (no candidates, no targets)
    const arma::vec lw = lw0 + design_systems(Xf, yf, Xs, ys, phis, arma::mat(0, U.n_cols),
                                              arma::mat(0, Xf.n_cols), nugget, model,
                                              false).ll;
    const arma::uvec top = arma::stable_sort_index(lw, "descend");
    const double lo = lw[top[0]] - prune;
    std::vector<arma::uword> keep;
    for (arma::uword s = 0; s < lw.n_elem; ++s)
      if (lw[s] >= lo || s == top[0] || s == top[1]) keep.push_back(s);
    run.kept = arma::uvec(keep);
  }
  const arma::mat ph = phis.rows(run.kept), kap = kappa.rows(run.kept);
  const arma::vec lwk = lw0.elem(run.kept);
  run.sys = design_systems(Xf, yf, Xs, ys, ph, U, XT, nugget, model, n > 1 || K > 1);
  if (!noise.is_empty()) run.sys.v += (run.sys.noise = noise.cols(run.kept));  // (a run's value: eta + noise)
  LookAhead& la = run.la;
  la.S = ph.n_rows; la.Nc = U.n_rows; la.J = Z.n_rows; la.T = run.sys.T; la.K = K; la.Nr = Nr;
  la.entropy = entropy; la.kap = kap; la.ksq = arma::sum(arma::square(kap), 1);
  run.lw = plugin ? arma::vec(lwk + run.sys.ll) : lwk;
  const arma::vec cw = arma::cumsum(arma::exp(run.lw - run.lw.max()));
  run.s0.resize(la.J);
  for (int j = 0; j < la.J; ++j) {
    int s = 0;
    while (s < la.S - 1 && cw[s] < usrc[j] * cw[la.S - 1]) ++s;
    run.s0[j] = s;
  }
  la.base = arma::repmat(run.lw, 1, la.J);
  la.YP.set_size(la.J, 0); la.Lbuf.set_size(la.S); la.wbuf.set_size(la.S);
  la.mbuf.resize((size_t)la.S * K);  // run_means()' K slices
  la.LK.resize((size_t)K * K * la.S * Nr); la.ldK.resize((size_t)la.S * Nr);
  la.eK.resize((size_t)la.S * K);
  if (la.T > 0) {
    la.VTP.set_size(la.S, la.T); la.vK.resize((size_t)la.S * la.T);
    la.MT.resize((size_t)la.S * la.T * la.J); la.CP.resize((size_t)la.S * la.T * la.Nc);
    la.gK.resize((size_t)la.S * la.T * K);
  }
  run.gain.set_size(Nr); run.best.set_size(n); run.Y.set_size(la.Nc, la.J);
  run.scores.set_size(Nr, n); run.chosen.assign(n, 0);
  look_ahead_steps(run, std::min(steps, n));
  Rcpp::List out = look_ahead_result(run);
  if (run.step < n) out["state"] = xp;
  else xp.release();  // (finished: freed now, not at R's next collection)
  return out;
}

// The rest of a look-ahead begun with design_look_ahead(steps < n).
// [[Rcpp::export(.design_look_ahead_resume)]]
Rcpp::List design_look_ahead_resume(SEXP state) {
  Rcpp::XPtr<LookAheadRun> xp(state);
  if (xp.get() == nullptr) Rcpp::stop("state is a look-ahead already finished");
  look_ahead_steps(*xp, xp->n);
  Rcpp::List out = look_ahead_result(*xp);
  xp.release();  // (its systems' memory back now, not at the next collection)
  return out;
}

// Frees a look-ahead in progress now, not at R's next garbage collection.
// [[Rcpp::export(.design_look_ahead_release)]]
void design_look_ahead_release(SEXP state) {
  Rcpp::XPtr<LookAheadRun> xp(state);
  xp.release();
}
