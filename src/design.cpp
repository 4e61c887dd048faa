// Design of new simulator runs (propose_runs(), R/propose_runs.R): the
// look-ahead criterion over retained draws phi_s (kappa and every
// hyperparameter, scaled space).
//
// For each draw the simulator's value y* at a candidate input u = (x, t)
// is Gaussian given the data y = (ys, yf): N(mu_s(u), v_s(u)). A run at u
// returning y* reweights the draws by N(y*; mu_s, v_s), exactly. The
// criterion is the expected reduction of kappa's posterior variance (summed
// over the calibration inputs) over fantasised values y*, and a batch is
// chosen greedily, each next point scored with the pending points' values
// fantasised jointly with it (per draw their joint Gaussian).
//
// With a prediction target (target points XT, T > 0) the criterion is the
// expected reduction of the calibrated prediction's integrated posterior
// predictive variance instead: zeta(x) = eta(x, kappa) + delta(x) (predict(
// type = "mean")) averaged over the T points. Per draw zeta(XT), the
// candidates' values and the pending points' are jointly Gaussian given the
// data, so a fantasised run both reweights the draws and moves each draw's
// predictive mean and variance (target_var()).
//
// Per draw, one dense factor of the joint covariance of y, built by blocks
// (design_system()): the simulator rows' block depends on the simulator's
// hyperparameters only, so draws that share them (the plug-in's particles,
// which differ in kappa alone) share it, and each draw adds its field rows'
// Schur complement, which gives the exact log-likelihood too. The
// conditional at candidates with any calibration input t (not the draw's
// kappa, as Posterior::condition() has it) and their cross-covariances
// come from that factor; the posterior object supplies the parameters'
// layout only.
#include "fbc.h"

namespace {

// The draws' conditionals at the candidates U (Nc rows): A_s = L_s^-1
// Cov_s(y, eta(U)) (N x Nc, N = m + G: the runs and the field's distinct
// inputs, field_groups(); slice s; kept for every draw only when a batch
// or several outputs need them, else no slices), the means mu and variances v (Nc x S),
// the log-likelihoods ll, the simulator variances s2S and the kernel's
// parameters per draw (thS, alS: (p + q) x S; rhoS: the levels' partial
// correlations, level_count() x S). With T target points: the
// predictive means mT and variances VT of zeta(XT) (T x S) and their
// covariances with the candidates' values CTU (T x Nc x S), given the data.
//
// With independent outputs (outputs = "independent", K of them) the data's
// covariance is block diagonal over the outputs, each block its output's
// system at its parameters (design_systems_outputs()): a candidate's
// column of A holds its output's rows (its runs and field groups; zeros
// below, to the largest output's count), so two candidates' columns meet
// (A_a'A_b) only within an output (same_output(); between outputs the
// product is 0); mu, v, mT, VT from its output's system, CTU zero
// between outputs, ll the sum; the kernel's parameters and s2S per draw
// and output (column or entry s + S o), outU each candidate's output.
struct DesignSystems {
  arma::cube A, CTU;
  arma::mat mu, muT, v, thS, alS, rhoS, mT, VT;  // muT = mu' (S x Nc)
  arma::vec ll, s2S;
  int T = 0, blocks = 1;
  std::vector<int> outU;
};

// Whether candidates a and b (columns of A) share an output: their columns'
// product A_a'A_b is a term of their covariance given the data (always
// with one output or shared outputs; DesignSystems).
inline bool same_output(const DesignSystems& sys, int a, int b) {
  return sys.outU.empty() || sys.outU[a] == sys.outU[b];
}


// The candidates' conditional means and variances from A (N x Nc) and the
// residual r: mu_c = sum_i A_ic r_i, v_c = v0 - sum_i A_ic^2.
void design_moments(const arma::mat& A, const arma::vec& r, double v0, double* mu, double* v) {
  for (arma::uword c = 0; c < A.n_cols; ++c) {
    const double* a = A.colptr(c);
    double ar = 0.0, aa = 0.0;
    for (arma::uword i = 0; i < A.n_rows; ++i) { ar += a[i] * r[i]; aa += a[i] * a[i]; }
    mu[c] = ar;
    v[c] = v0 - aa;
  }
}


// The simulator GP's correlation Rs(X, Y) (d input columns) at thetaS th
// and alphaS al, times the categorical inputs' level correlations
// C_f[a_f(x), a_f(y)] (from rhoS rho; their indicator columns have thetaS
// 0, src/levels.cpp); lower: the lower triangle only.
void sim_corr(const Model& mod, int d, const double* th, const double* al, const double* rho,
              const arma::mat& X, const arma::mat& Y, arma::mat& out, bool lower) {
  kernel_corr(mod.kernS, X, Y, d, th, al, out, lower);
  level_scale(mod.levels, rho, X, Y, out, lower);
}

// The same at the current draw post.phi.
void sim_corr(const Posterior& post, const Model& mod, const arma::mat& X, const arma::mat& Y,
              arma::mat& out, bool lower) {
  const double* phi = post.phi.memptr();
  sim_corr(mod, post.p + post.q, phi + post.iThetaS, phi + post.iAlphaS, phi + post.iRhoS, X, Y,
           out, lower);
}

// The bias GP's correlation Rb(X, Y) over the experimental inputs at the
// current draw, times the levels' correlations (rhoB) and, with a bias per
// data set (srcX, srcY the rows' data sets; null without), the data sets'
// D[srcX_i, srcY_j] (rhoD), as SchurPosterior::biasLevels() has them.
void bias_corr(const Posterior& post, const Model& mod, const arma::mat& X, const int* srcX,
               const arma::mat& Y, const int* srcY, arma::mat& out, bool lower) {
  const double* phi = post.phi.memptr();
  kernel_corr(mod.kernB, X, Y, post.p, phi + post.iThetaB, phi + post.iAlphaB, out, lower);
  level_scale(mod.levels, phi + post.iRhoB, X, Y, out, lower);
  if (srcX) source_scale(mod.sourceL, phi + post.iRhoD, srcX, srcY, out, lower);
}

// The simulator rows' part of a draw's system, which depends on the
// simulator's hyperparameters (s2S, thetaS, alphaS, rhoS) only and so is shared by
// draws that have the same (the plug-in's particles differ in kappa alone):
//   L1 = chol(s2S (Rs(Xs, Xs) + nugget I)),  r1 = L1^-1 ys,
//   A1 = L1^-1 s2S Rs(Xs, U),  mu1 = A1' r1,  naa1 = -diag(A1' A1),
//   ld1 = sum log diag L1,  rr1 = r1' r1;  key: the hyperparameters they are for.
struct SimBlock {
  arma::mat L, A;
  arma::vec r, mu, naa, key;
  double ld = 0.0, rr = 0.0;
};


// The field rows grouped by input and measurement-error group: rows at the
// same experimental input (replicates) share eta(x, kappa) and the bias,
// and those of one noise group k (a data set) also their variance s2E_k, so
// the data enter the conditionals only through each group's mean, measured
// with variance s2E_k(g) / r_g (r_g rows), and the likelihood factorises as
//   log N(yf, ys) = log N(ybar, ys)
//                   - (sum_k [SS_k / s2E_k + (n_k - G_k) log s2E_k] + (n - G) log 2 pi + sum_g log r_g) / 2
// with SS_k the squared deviations of group k's rows from their group's
// mean, n_k its rows and G_k its groups. With a bias per data set
// (`source`) the rows of one data set share its bias, so a group is also
// within one data set. X: the G groups' inputs in order of appearance,
// noise their noise groups and src their data sets (0-based; src empty
// without), ybar their means, invr 1 / r_g; ss and extra (n_k - G_k) per
// noise group.
struct FieldGroups {
  arma::mat X;
  arma::vec ybar, invr, ss, extra;
  std::vector<int> noise, src, first;  // first: each group's first row
  double logr = 0.0;
  int n = 0;
};

FieldGroups field_groups(const arma::mat& Xf, const arma::vec& yf, const std::vector<int>& noise,
                         const std::vector<int>& source) {
  const arma::uword n = Xf.n_rows;
  const int K = noise.empty() ? 1 : *std::max_element(noise.begin(), noise.end()) + 1;
  std::vector<int> key = noise;  // (noise group, data set) as one number
  if (!source.empty()) {
    key.resize(n);
    for (arma::uword i = 0; i < n; ++i) key[i] = source[i] * K + (noise.empty() ? 0 : noise[i]);
  }
  std::vector<int> of;
  const std::vector<int> first = group_rows(Xf, key, of);
  const arma::uword G = first.size();
  FieldGroups f;
  f.n = n;
  f.first = first;
  f.X = Xf.rows(arma::conv_to<arma::uvec>::from(first));
  f.noise.resize(G);
  for (arma::uword g = 0; g < G; ++g) f.noise[g] = noise.empty() ? 0 : noise[first[g]];
  if (!source.empty()) {
    f.src.resize(G);
    for (arma::uword g = 0; g < G; ++g) f.src[g] = source[first[g]];
  }
  f.ybar.zeros(G);
  arma::vec r(G, arma::fill::zeros);
  for (arma::uword i = 0; i < n; ++i) { f.ybar[of[i]] += yf[i]; r[of[i]] += 1.0; }
  f.ybar /= r;
  f.ss.zeros(K);
  f.extra.zeros(K);
  for (arma::uword i = 0; i < n; ++i) {
    const int k = f.noise[of[i]];
    f.ss[k] += (yf[i] - f.ybar[of[i]]) * (yf[i] - f.ybar[of[i]]);
    f.extra[k] += 1.0;
  }
  for (arma::uword g = 0; g < G; ++g) f.extra[f.noise[g]] -= 1.0;
  f.invr = 1.0 / r;
  f.logr = arma::accu(arma::log(r));
  return f;
}

// One draw's workspace: Xk = (Xf, kappa) (n x (p + q)), W = L1^-1 s2S
// Rs(Xs, Xk) (m x n) and its transpose Wt, the field block S (n x n; its
// factor L2 after design_system()), the bias correlation Rb (n x n), A2
// (n x Nc), the residual r2 (n), the moments' field parts mu2, v2; for
// targets Tk = (XT, kappa) (T x (p + q)), K1 (m x T), K2 (n x T), RbT
// (n x T) and RTU (T x Nc).
struct SystemWork {
  arma::mat Xk, W, Wt, S, Rb, A2, Tk, K1, K2, RbT, RTU;
  arma::vec r2, mu2, v2;
};

// The S-GaSP bias (Gu and Wang 2018) is the bias GP scaled on the sampler's
// distinct field inputs XU (distinct within a data set with a bias per
// data set), its discretization points: Rz = R - R (R + c I)^-1 R on them,
// c = nu / lambdaZ (Posterior::biasModel()), and at new inputs
// Posterior::biasModelCross(). The look-ahead's field groups (split further
// by noise group) take their rows of it: group g is XU's row uOf[g]. RU, B,
// Wz: workspaces; KT (nu x T), rT (T): the cross-correlation and variance
// at the targets.
struct SgaspBias {
  bool on = false;
  arma::mat XU, RU, B, Wz, KT;
  arma::vec rT;
  std::vector<int> srcU, uOf;
};

SgaspBias sgasp_bias(const Posterior& post, const Model& mod, const arma::mat& Xf,
                     const FieldGroups& fg) {
  SgaspBias z;
  z.on = post.sgasp && post.bias;
  if (!z.on) return z;
  std::vector<int> of;
  const std::vector<int> first = group_rows(Xf, mod.source, of);
  z.XU = Xf.rows(arma::conv_to<arma::uvec>::from(first));
  if (!mod.source.empty())
    for (int i : first) z.srcU.push_back(mod.source[i]);
  for (int i : fg.first) z.uOf.push_back(of[i]);
  z.RU.set_size(first.size(), first.size());
  return z;
}

// The bias correlation of the field groups (lower triangle of Rb): the bias
// GP's kernel, times the data sets' correlation D[src_g, src_h] with a bias
// per data set, and for the S-GaSP scaled on XU (sgasp_bias()). False if
// the S-GaSP's matrix is not positive definite.
bool field_bias_corr(const Posterior& post, const Model& mod, const FieldGroups& fg,
                     SgaspBias& z, arma::mat& Rb) {
  if (!z.on) {
    const int* src = fg.src.empty() ? nullptr : fg.src.data();
    bias_corr(post, mod, fg.X, src, fg.X, src, Rb, true);
    return true;
  }
  const int* src = z.srcU.empty() ? nullptr : z.srcU.data();
  bias_corr(post, mod, z.XU, src, z.XU, src, z.RU, true);
  if (!post.biasModel(z.RU, z.B, z.Wz)) return false;
  const int n = fg.X.n_rows;
  for (int j = 0; j < n; ++j)
    for (int i = j; i < n; ++i) {
      const int a = z.uOf[i], b = z.uOf[j];
      Rb(i, j) = a >= b ? z.RU(a, b) : z.RU(b, a);
    }
  return true;
}

// The shared block for the current draw's simulator hyperparameters
// (recomputed only when they differ from the last draw's). False if the
// simulator block is not positive definite.
bool sim_block(const Posterior& post, const Model& mod, const arma::mat& Xs,
               const arma::vec& ys, const arma::mat& U, double nugget, SimBlock& sb) {
  const arma::vec& phi = post.phi;
  const int m = post.m, d = post.p + post.q, nl = level_count(mod.levels);
  arma::vec key(2 * d + 1 + nl);
  key[0] = phi[post.iSigma2S];
  for (int k = 0; k < d; ++k) {
    key[1 + k] = phi[post.iThetaS + k];
    key[1 + d + k] = phi[post.iAlphaS + k];
  }
  for (int k = 0; k < nl; ++k) key[1 + 2 * d + k] = phi[post.iRhoS + k];
  if (sb.key.n_elem == key.n_elem && arma::all(sb.key == key)) return true;
  sb.key.reset();
  const double s2S = key[0];
  sb.L.set_size(m, m);
  sim_corr(post, mod, Xs, Xs, sb.L, true);
  sb.L *= s2S;
  for (int i = 0; i < m; ++i) sb.L(i, i) *= 1.0 + nugget;
  if (!chol_lower(sb.L)) return false;
  sb.r = ys;
  solve_lower(sb.L, sb.r);
  sb.rr = arma::dot(sb.r, sb.r);
  sb.ld = 0.0;
  for (int i = 0; i < m; ++i) sb.ld += std::log(sb.L(i, i));
  sb.A.set_size(m, U.n_rows);
  sim_corr(post, mod, Xs, U, sb.A, false);
  sb.A *= s2S;
  solve_lower(sb.L, sb.A);
  sb.mu.set_size(U.n_rows);
  sb.naa.set_size(U.n_rows);
  design_moments(sb.A, sb.r, 0.0, sb.mu.memptr(), sb.naa.memptr());
  sb.key = key;
  return true;
}

// One draw's target part (sb, W, S = L2, r2, A2 from design_system()):
//   K1 = L1^-1 s2S Rs(Xs, Tk),  K2 = L2^-1 (s2S Rs(Xk, Tk) + s2B Rb(Xf, XT) - W' K1),
//   mT = muB + K1' r1 + K2' r2,  VT = s2S + s2B - diag(K1'K1 + K2'K2)   (predict()'s type "mean"),
//   CTU = s2S Rs(Tk, U) - K1' A1 - K2' A2;
// for the S-GaSP Rb(Xf, XT) is its cross-correlation and the s2B of VT s2B rz(XT)
// (sgasp_bias()).
void design_targets(const Posterior& post, const Model& mod, const arma::mat& Xs,
                    const arma::mat& Xf, const arma::mat& XT, const arma::mat& U,
                    const SimBlock& sb, SgaspBias& z, SystemWork& w, DesignSystems& out,
                    arma::uword s) {
  const arma::vec& phi = post.phi;
  const int p = post.p, q = post.q;
  const double s2S = phi[post.iSigma2S];
  for (int k = 0; k < q; ++k) w.Tk.col(p + k).fill(phi[post.iKappa + k]);
  sim_corr(post, mod, Xs, w.Tk, w.K1, false);
  w.K1 *= s2S;
  solve_lower(sb.L, w.K1);
  sim_corr(post, mod, w.Xk, w.Tk, w.K2, false);
  w.K2 *= s2S;
  double s2B = 0.0;
  if (post.bias) {
    s2B = phi[post.iSigma2B];
    if (!z.on) {
      bias_corr(post, mod, Xf, nullptr, XT, nullptr, w.RbT, false);
    } else {
      z.KT.set_size(z.XU.n_rows, XT.n_rows);  // (biasModelCross() writes over it)
      bias_corr(post, mod, z.XU, nullptr, XT, nullptr, z.KT, false);
      post.biasModelCross([&]() {
        arma::mat R(z.XU.n_rows, z.XU.n_rows);
        bias_corr(post, mod, z.XU, nullptr, z.XU, nullptr, R, false);
        return R;
      }, z.KT, z.rT);
      for (arma::uword t = 0; t < XT.n_rows; ++t)
        for (arma::uword g = 0; g < Xf.n_rows; ++g) w.RbT(g, t) = z.KT(z.uOf[g], t);
    }
    w.K2 += s2B * w.RbT;
  }
  w.K2 -= w.W.t() * w.K1;
  solve_lower(w.S, w.K2);
  const double muB = post.biasMean ? phi[post.iMuB] : 0.0;
  out.mT.col(s) = muB + w.K1.t() * sb.r + w.K2.t() * w.r2;
  if (!z.on) {
    out.VT.col(s) = (s2S + s2B) - arma::sum(arma::square(w.K1), 0).t() -
                    arma::sum(arma::square(w.K2), 0).t();
  } else {
    out.VT.col(s) = (s2S + s2B * z.rT) - arma::sum(arma::square(w.K1), 0).t() -
                    arma::sum(arma::square(w.K2), 0).t();
  }
  sim_corr(post, mod, w.Tk, U, w.RTU, false);
  out.CTU.slice(s) = s2S * w.RTU - w.K1.t() * sb.A - w.K2.t() * w.A2;
}

// One draw's system, the simulator rows' block sb (sim_block()) and the
// field groups' Schur complement (fg, field_groups(): Xf below is fg.X, yf
// the groups' means, R = diag(1 / r_g)). With Xk = (Xf, kappa) and prior
// mean mu0 = (0, muB) the joint covariance of y = (ys, yf) is
//   C = [ s2S (Rs(Xs,Xs) + nugget I)   s2S Rs(Xs,Xk)                      ]
//       [ .                  s2S Rs(Xk,Xk) + s2B Rb(Xf,Xf) + s2E R        ],
// L = chol(C) = [L1 0; W' L2] with W = L1^-1 s2S Rs(Xs, Xk),
//   L2 = chol(s2S Rs(Xk,Xk) + s2B Rb + s2E R - W'W),  r2 = L2^-1 (yf - muB - W' r1)
//   (s2E R: diag(s2E_k(g) / r_g), group g's noise variance over its rows;
//   with a bias per data set Rb(g, h) carries the factor D[src_g, src_h]),
//   A = L^-1 s2S Rs(Z, U) = [A1; A2],  A2 = L2^-1 (s2S Rs(Xk, U) - W' A1),
//   mu = A' r = mu1 + A2' r2,  v = s2S (1 + nugget) - diag(A1'A1) - diag(A2'A2),
//   ll = log N(ys, every field row) = -((m + n) log 2 pi + 2 (ld1 + sum log diag L2)
//        + r1'r1 + r2'r2 + sum_k [SS_k / s2E_k + (n_k - G_k) log s2E_k] + sum_g log r_g) / 2.
// False if C is not positive definite.
bool design_system(const Posterior& post, const Model& mod, const FieldGroups& fg,
                   const arma::mat& Xs, const arma::vec& ys,
                   const arma::mat& U, const arma::mat& XT, double nugget, SimBlock& sb,
                   SgaspBias& z, SystemWork& w, DesignSystems& out, arma::uword s) {
  if (!sim_block(post, mod, Xs, ys, U, nugget, sb)) return false;
  const arma::vec& phi = post.phi;
  const arma::mat& Xf = fg.X;
  const int m = post.m, n = Xf.n_rows, p = post.p, q = post.q, N = m + n;
  const double s2S = phi[post.iSigma2S];
  const double* s2E = phi.memptr() + post.iSigma2E;  // one per noise group
  for (int k = 0; k < q; ++k) w.Xk.col(p + k).fill(phi[post.iKappa + k]);
  const double* thS = phi.memptr() + post.iThetaS;
  const double* alS = phi.memptr() + post.iAlphaS;
  sim_corr(post, mod, Xs, w.Xk, w.W, false);
  w.W *= s2S;
  solve_lower(sb.L, w.W);
  sim_corr(post, mod, w.Xk, w.Xk, w.S, true);
  w.S *= s2S;
  if (post.bias) {
    if (!field_bias_corr(post, mod, fg, z, w.Rb)) return false;
    const double s2B = phi[post.iSigma2B];
    for (int j = 0; j < n; ++j)
      for (int i = j; i < n; ++i) w.S(i, j) += s2B * w.Rb(i, j);
  }
  for (int i = 0; i < n; ++i) w.S(i, i) += s2E[fg.noise[i]] * fg.invr[i];
  syrk_lower(w.W, -1.0, 1.0, w.S);
  w.Wt = w.W.t();
  if (!chol_lower(w.S)) return false;
  const double muB = post.biasMean ? phi[post.iMuB] : 0.0;
  w.r2 = fg.ybar - muB - w.W.t() * sb.r;
  solve_lower(w.S, w.r2);
  double ld2 = 0.0;
  for (int i = 0; i < n; ++i) ld2 += std::log(w.S(i, i));
  double quad = (m + fg.n) * LOG_2PI + 2.0 * (sb.ld + ld2) + sb.rr + arma::dot(w.r2, w.r2);
  // the replicates' deviations from their groups' means, per noise group
  for (arma::uword k = 0; k < fg.ss.n_elem; ++k) {
    quad += fg.ss[k] / s2E[k];
    quad += fg.extra[k] * std::log(s2E[k]);
  }
  out.ll[s] = -0.5 * (quad + fg.logr);
  const int Nc = U.n_rows;
  if (Nc > 0) {
    sim_corr(post, mod, w.Xk, U, w.A2, false);
    w.A2 *= s2S;
    w.A2 -= w.Wt * sb.A;
    solve_lower(w.S, w.A2);
    design_moments(w.A2, w.r2, 0.0, w.mu2.memptr(), w.v2.memptr());
    const double v0 = s2S * (1.0 + nugget);
    double* mu = out.mu.colptr(s);
    double* v = out.v.colptr(s);
    for (int c = 0; c < Nc; ++c) {
      mu[c] = sb.mu[c] + w.mu2[c];
      v[c] = v0 + sb.naa[c] + w.v2[c];
    }
    // (kept: every draw's slice, a single draw's too)
    if (out.A.n_slices > 0) {
      out.A.slice(s).rows(0, m - 1) = sb.A;
      out.A.slice(s).rows(m, N - 1) = w.A2;
    }
  }
  if (out.T > 0) design_targets(post, mod, Xs, Xf, XT, U, sb, z, w, out, s);
  out.s2S[s] = s2S;
  std::copy(thS, thS + p + q, out.thS.colptr(s));
  std::copy(alS, alS + p + q, out.alS.colptr(s));
  std::copy(phi.memptr() + post.iRhoS, phi.memptr() + post.iRhoS + out.rhoS.n_rows, out.rhoS.colptr(s));
  return true;
}

// Every draw's system (rows of phis) at the candidates U (and the target
// points XT, T x p, none for kappa's criterion) for one simulator GP (mod:
// the model of the data, its algebra dense), the simulator rows' block
// shared by consecutive draws with the same simulator hyperparameters;
// keepA: every draw's A (a batch's pending points need them). post: the
// dense posterior of these data (its layout; its phi set to each draw's);
// fg: the field's groups (system_field_groups()).
DesignSystems block_systems(Posterior& post, const FieldGroups& fg, const arma::mat& Xf,
                            const arma::mat& Xs, const arma::vec& ys, const arma::mat& phis,
                            const arma::mat& U, const arma::mat& XT, double nugget,
                            const Model& mod, bool keepA) {
  const int p = Xf.n_cols, q = Xs.n_cols - Xf.n_cols;
  if (phis.n_cols != (arma::uword)post.d) Rcpp::stop("phis must have %d columns", post.d);
  const int m = Xs.n_rows, n = fg.X.n_rows, N = m + n, S = phis.n_rows, Nc = U.n_rows;
  const int T = XT.n_rows;
  DesignSystems out;
  out.T = T;
  out.A.set_size(N, Nc, keepA ? S : 0);
  out.mu.set_size(Nc, S);
  out.v.set_size(Nc, S);
  out.thS.set_size(p + q, S);
  out.alS.set_size(p + q, S);
  out.rhoS.set_size(level_count(mod.levels), S);
  out.ll.set_size(S);
  out.s2S.set_size(S);
  SimBlock sb;
  SgaspBias z = sgasp_bias(post, mod, Xf, fg);
  SystemWork w;
  w.Xk.set_size(n, p + q);
  w.Xk.cols(0, p - 1) = fg.X;
  w.W.set_size(m, n);
  w.Wt.set_size(n, m);
  w.S.set_size(n, n);
  w.Rb.set_size(n, n);
  w.A2.set_size(n, Nc);
  w.mu2.set_size(Nc);
  w.v2.set_size(Nc);
  if (T > 0) {
    out.mT.set_size(T, S);
    out.VT.set_size(T, S);
    out.CTU.set_size(T, Nc, S);
    w.Tk.set_size(T, p + q);
    w.Tk.cols(0, p - 1) = XT;
    w.K1.set_size(m, T);
    w.K2.set_size(n, T);
    w.RbT.set_size(n, T);
    w.RTU.set_size(T, Nc);
  }
  for (int s = 0; s < S; ++s) {
    post.phi = phis.row(s).t();
    if (!design_system(post, mod, fg, Xs, ys, U, XT, nugget, sb, z, w, out, s))
      Rcpp::stop("The covariance matrix of draw %d is not positive definite.", s + 1);
    if (s % 100 == 99) Rcpp::checkUserInterrupt();
  }
  return out;
}

// The field's groups (field_groups()) for block_systems(), the data sets
// and noise groups checked against the field's rows and post's sigma2E.
FieldGroups system_field_groups(const Posterior& post, const arma::mat& Xf, const arma::vec& yf,
                                const Model& mod) {
  if (!mod.source.empty() && mod.source.size() != Xf.n_rows)
    Rcpp::stop("the data sets must give one per field row");
  const int K = mod.noise.empty() ? 1 : *std::max_element(mod.noise.begin(), mod.noise.end()) + 1;
  if (post.layout.length_of("sigma2E") != K || (!mod.noise.empty() && mod.noise.size() != Xf.n_rows))
    Rcpp::stop("the noise groups must give one group per field row and sigma2E one variance per group");
  return field_groups(Xf, yf, mod.noise, mod.source);
}

// The rows of X whose output (the output's indicator columns, f) is o.
arma::uvec output_rows(const arma::mat& X, const LevelInput& f, int o) {
  std::vector<arma::uword> r;
  for (arma::uword i = 0; i < X.n_rows; ++i)
    if (level_of(X, i, f) == o) r.push_back(i);
  return arma::uvec(r);
}

// block_systems() with independent outputs: each output's system from its
// rows and its parameters (OutputsPosterior's blocks, their posteriors
// dense as mod's algebra is), put together as DesignSystems describes.
DesignSystems design_systems_outputs(const arma::mat& Xf, const arma::vec& yf,
                                     const arma::mat& Xs, const arma::vec& ys,
                                     const arma::mat& phis, const arma::mat& U,
                                     const arma::mat& XT, double nugget, const Model& mod,
                                     bool keepA) {
  std::unique_ptr<Posterior> pp = make_posterior(Xf, yf, Xs, ys, nugget, mod);
  OutputsPosterior& op = dynamic_cast<OutputsPosterior&>(*pp);
  if (phis.n_cols != (arma::uword)op.d) Rcpp::stop("phis must have %d columns", op.d);
  const int K = mod.nOutputs(), S = phis.n_rows, Nc = U.n_rows, T = XT.n_rows;
  // A's rows: the largest output's runs and field groups (block_systems()'
  // m + n), so that each block is placed as it is made and freed (A is the
  // bulk: the peak is the assembled A and one block's)
  int N = 0;
  std::vector<FieldGroups> fgs;
  for (int o = 0; o < K; ++o) {
    fgs.push_back(system_field_groups(op.block(o), op.blockXf(o), op.blockYf(o), op.blockModel(o)));
    N = std::max(N, (int)(op.blockXs(o).n_rows + fgs[o].X.n_rows));
  }
  DesignSystems out;
  out.T = T;
  out.blocks = K;
  out.A.zeros(N, Nc, keepA ? S : 0);
  out.mu.set_size(Nc, S);
  out.v.set_size(Nc, S);
  out.ll.zeros(S);
  out.s2S.set_size(S * K);
  out.outU.assign(Nc, 0);
  if (T > 0) {
    out.mT.set_size(T, S);
    out.VT.set_size(T, S);
    out.CTU.zeros(T, Nc, S);
  }
  for (int o = 0; o < K; ++o) {
    const arma::uvec uo = output_rows(U, mod.outputs, o), to = output_rows(XT, mod.outputs, o);
    const arma::mat ph = phis.cols(arma::conv_to<arma::uvec>::from(op.blockMap(o)));
    const DesignSystems bo = block_systems(op.block(o), fgs[o], op.blockXf(o),
                                           op.blockXs(o), op.blockYs(o), ph, U.rows(uo),
                                           XT.rows(to), nugget, op.blockModel(o), keepA);
    const int No = bo.A.n_rows;
    if (No > N) Rcpp::stop("output %d's system has %d rows, not at most %d", o + 1, No, N);
    if (o == 0) {
      out.thS.set_size(bo.thS.n_rows, S * K);
      out.alS.set_size(bo.alS.n_rows, S * K);
      out.rhoS.set_size(bo.rhoS.n_rows, S * K);
    }
    for (arma::uword c : uo) out.outU[c] = o;
    out.mu.rows(uo) = bo.mu;
    out.v.rows(uo) = bo.v;
    out.ll += bo.ll;
    out.s2S.subvec(S * o, S * o + S - 1) = bo.s2S;
    out.thS.cols(S * o, S * o + S - 1) = bo.thS;
    out.alS.cols(S * o, S * o + S - 1) = bo.alS;
    out.rhoS.cols(S * o, S * o + S - 1) = bo.rhoS;
    if (keepA && uo.n_elem > 0)
      for (int s = 0; s < S; ++s)
        for (arma::uword k = 0; k < uo.n_elem; ++k)
          out.A.slice(s).col(uo[k]).rows(0, No - 1) = bo.A.slice(s).col(k);
    if (T > 0 && to.n_elem > 0) {
      out.mT.rows(to) = bo.mT;
      out.VT.rows(to) = bo.VT;
      for (int s = 0; s < S; ++s)
        out.CTU.slice(s).submat(to, uo) = bo.CTU.slice(s);
    }
  }
  return out;
}

// Every draw's system (block_systems(); with independent outputs
// design_systems_outputs()) on the dense algebra; mod: the model read.
DesignSystems design_systems(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                             const arma::vec& ys, const arma::mat& phis, const arma::mat& U,
                             const arma::mat& XT, double nugget, const Rcpp::List& model,
                             Model& mod, bool keepA) {
  const int p = Xf.n_cols, q = Xs.n_cols - Xf.n_cols;
  mod = read_model(model, p, q);
  if (!mod.emulator) Rcpp::stop("the look-ahead handles simulator runs (a simulator GP)");
  mod.algebra = ALG_DENSE;
  if (!mod.source.empty() && XT.n_rows > 0)
    Rcpp::stop("a prediction target needs one bias, not one per data set");
  if (U.n_cols != (arma::uword)(p + q)) Rcpp::stop("U must have %d columns", p + q);
  if (XT.n_rows > 0 && XT.n_cols != (arma::uword)p) Rcpp::stop("XT must have %d columns", p);
  DesignSystems out;
  if (mod.nOutputs() > 1) {
    out = design_systems_outputs(Xf, yf, Xs, ys, phis, U, XT, nugget, mod, keepA);
  } else {
    std::unique_ptr<Posterior> post = make_posterior(Xf, yf, Xs, ys, nugget, mod);
    out = block_systems(*post, system_field_groups(*post, Xf, yf, mod), Xf, Xs, ys, phis, U, XT,
                        nugget, mod, keepA);
  }
  out.muT = out.mu.t();
  return out;
}

// w_s = exp(L_s - mx) for s < S (L_s <= mx).
void exp_weights(const double* L, double mx, int S, double* w) {
  for (int s = 0; s < S; ++s) w[s] = std::exp(L[s] - mx);
}

// The greedy look-ahead's state: S draws, Nc candidates, J fantasies.
// kap (S x q) kappa, ksq (S) |kappa_s|^2, base (S x J) the draws'
// log-weights given the pending points' fantasies, YP (J x k) those values,
// P the pending candidates; per step, with pending points, the terms of
// the conditional means given them (cond_means()), s fastest: B's
// Bk[s + S (c + Nc i)] and the fantasies' deviations Dk[s + S (i + k j)];
// the standard deviations sd, their inverses and logs (S x Nc), mbuf a
// draw's means. With T targets, given
// the pending points: the targets' means MT[s + S (t + T j)], variances
// VTP (S x T) and covariances with the candidates CP[s + S (t + T c)];
// tb, tv (S x T) target_terms() of the candidate scored.
//
// With several outputs (K > 1) a run gives K values, the candidates' rows
// r K .. r K + K - 1 (Nr = Nc / K runs, the same inputs but the output):
// per run r and draw s the lower Cholesky factor of the K values'
// covariance given the data and the pending points, LK[(r S + s) K^2 ..]
// (column-major), and its sum log diag ldK[r S + s]; eK (S x K) a
// fantasy's standardised residuals L_s^-1 (y - M_s); with targets gK
// (S x T x K) and vK (S x T), run_target_terms() of the run scored.
// `entropy`: without targets the criterion is kappa's entropy, not its
// variance (crit_value()).
struct LookAhead {
  int S, Nc, J, T = 0, K = 1, Nr = 0;
  bool entropy = false;
  arma::mat kap, base, YP, sd, isd, lsd, VTP;
  arma::vec ksq, Lbuf, wbuf;
  std::vector<double> MT, CP, Bk, Dk, mbuf, tb, tv, LK, ldK, eK, gK, vK;
  std::vector<int> P;
};

// The sum over s of a_s b_s (b null: of a_s).
double dot_sum(const double* a, const double* b, int S) {
  double out = 0.0;
  for (int s = 0; s < S; ++s) out += b ? a[s] * b[s] : a[s];
  return out;
}

// Sum over kappa's columns of its variance under the weights
// w_s = exp(L_s - mx) / sum (mx = max L): sum_s w_s |k_s|^2 -
// sum_k (sum_s w_s k_sk)^2.
double weighted_var(LookAhead& la, const double* L, double mx) {
  const int q = la.kap.n_cols, S = la.S;
  double* w = la.wbuf.memptr();
  exp_weights(L, mx, S, w);
  double sum[18];  // q <= 16
  sum[0] = dot_sum(w, nullptr, S);
  sum[1] = dot_sum(w, la.ksq.memptr(), S);
  for (int k = 0; k < q; ++k) sum[2 + k] = dot_sum(w, la.kap.colptr(k), S);
  const double sw = sum[0];
  double out = sum[1] / sw;
  for (int k = 0; k < q; ++k) {
    const double mk = sum[2 + k] / sw;
    out -= mk * mk;
  }
  return out;
}

// The calibrated prediction's variance averaged over the T targets under
// the weights w_s = exp(L_s - mx), in fantasy j given the pending points;
// with a run at candidate c returning y (draw means mu_s there): per draw
// b = CP_stc / cv_sc (cv = sd^2), m_st = MT_stj + b (y - mu_s),
// v_st = max(VTP_st - b CP_stc, 0); without a run (c < 0) m = MT, v = VTP;
// after run c of K > 1 values m_st = MT_stj + g_st'e_s, v_st = vK_st (e_s
// from run_log_density(), g and vK from run_target_terms(); y, mu unused).
//   (1 / T) sum_t [sum_s w_s (v_st + m_st^2) / sum w - (sum_s w_s m_st / sum w)^2].
double target_var(LookAhead& la, const double* L, double mx, int j, int c, double y,
                  const double* mu) {
  const int S = la.S;
  double* w = la.wbuf.memptr();
  exp_weights(L, mx, S, w);
  double sw = 0.0;
  for (int s = 0; s < S; ++s) sw += w[s];
  double out = 0.0;
  for (int t = 0; t < la.T; ++t) {
    const double* mt = la.MT.data() + (size_t)S * (t + (size_t)la.T * j);
    const double* vt = la.VTP.colptr(t);
    double a1 = 0.0, a2 = 0.0;
    if (c < 0) {
      for (int s = 0; s < S; ++s) { a1 += w[s] * (vt[s] + mt[s] * mt[s]); a2 += w[s] * mt[s]; }
    } else if (la.K > 1) {
      const double* v = la.vK.data() + (size_t)S * t;
      for (int s = 0; s < S; ++s) {
        double ms = mt[s];
        for (int i = 0; i < la.K; ++i)
          ms += la.gK[s + (size_t)S * (t + (size_t)la.T * i)] * la.eK[s + (size_t)S * i];
        a1 += w[s] * (v[s] + ms * ms);
        a2 += w[s] * ms;
      }
    } else {
      // b and v for candidate c (target_terms(), the same in every fantasy)
      const double* b = la.tb.data() + (size_t)S * t;
      const double* v = la.tv.data() + (size_t)S * t;
      for (int s = 0; s < S; ++s) {
        const double ms = mt[s] + b[s] * (y - mu[s]);
        a1 += w[s] * (v[s] + ms * ms);
        a2 += w[s] * ms;
      }
    }
    out += a1 / sw - (a2 / sw) * (a2 / sw);
  }
  return out / la.T;
}

// target_var()'s terms of candidate c, which no fantasy changes (computed
// once for its J fantasies): b_st = CP_stc / cv_sc, v_st = max(VTP_st -
// b_st CP_stc, 0), in la.tb and la.tv (s fastest).
void target_terms(LookAhead& la, int c) {
  const int S = la.S;
  const double* isd = la.isd.colptr(c);
  for (int t = 0; t < la.T; ++t) {
    const double* cp = la.CP.data() + (size_t)S * (t + (size_t)la.T * c);
    const double* vt = la.VTP.colptr(t);
    double* b = la.tb.data() + (size_t)S * t;
    double* v = la.tv.data() + (size_t)S * t;
    for (int s = 0; s < S; ++s) {
      b[s] = cp[s] * isd[s] * isd[s];
      v[s] = std::max(vt[s] - b[s] * cp[s], 0.0);
    }
  }
}

// Kappa's entropy under the weights w_s = exp(L_s - mx), the draws being
// the plug-in's kappa values (a grid or a uniform sample: the entropy of
// their normalised weights p_s = w_s / sum w is kappa's differential
// entropy up to a constant):
//   -sum_s p_s log p_s = log sum w - sum_s w_s (L_s - mx) / sum w.
double weighted_entropy(LookAhead& la, const double* L, double mx) {
  const int S = la.S;
  double* w = la.wbuf.memptr();
  exp_weights(L, mx, S, w);
  double sw = 0.0, swl = 0.0;
  for (int s = 0; s < S; ++s) {
    sw += w[s];
    if (w[s] > 0.0) swl += w[s] * (L[s] - mx);  // (exp_weights()' underflow: 0, not 0 x -inf)
  }
  return std::log(sw) - swl / sw;
}

// The criterion's value: the targets' variance, or kappa's entropy
// (la.entropy) or variance.
double crit_value(LookAhead& la, const double* L, double mx, int j, int c, double y,
                  const double* mu) {
  if (la.T > 0) return target_var(la, L, mx, j, c, y, mu);
  return la.entropy ? weighted_entropy(la, L, mx) : weighted_var(la, L, mx);
}

// Draw s's prior covariance of the simulator's values at rows X and Y of
// the candidates: s2S Rs(X, Y); with independent outputs (sys.blocks K >
// 1; oX, oY the rows' outputs) output o's s2S_o Rs_o between two rows of
// output o, 0 between outputs.
void prior_cov(const DesignSystems& sys, const Model& mod, int s, const arma::mat& X,
               const int* oX, const arma::mat& Y, const int* oY, arma::mat& out) {
  const int q = X.n_cols;
  if (sys.blocks == 1) {
    sim_corr(mod, q, sys.thS.colptr(s), sys.alS.colptr(s), sys.rhoS.colptr(s), X, Y, out, false);
    out *= sys.s2S[s];
    return;
  }
  const int S = sys.s2S.n_elem / sys.blocks;
  arma::mat R;
  out.zeros(X.n_rows, Y.n_rows);
  for (int o = 0; o < sys.blocks; ++o) {
    // the kernel between output o's rows of X and of Y only
    std::vector<arma::uword> io, jo;
    for (arma::uword i = 0; i < X.n_rows; ++i) if (oX[i] == o) io.push_back(i);
    for (arma::uword j = 0; j < Y.n_rows; ++j) if (oY[j] == o) jo.push_back(j);
    if (io.empty() || jo.empty()) continue;
    const arma::uvec ri(io), rj(jo);
    const int so = s + S * o;
    R.set_size(ri.n_elem, rj.n_elem);
    sim_corr(mod, q, sys.thS.colptr(so), sys.alS.colptr(so), sys.rhoS.colptr(so), X.rows(ri),
             Y.rows(rj), R, false);
    out.submat(ri, rj) = sys.s2S[so] * R;
  }
}

// The smallest simulator variance of draw s (of its outputs' with
// independent outputs): the scale of the conditional variances' floor.
double min_s2S(const DesignSystems& sys, int s) {
  const int S = sys.s2S.n_elem / sys.blocks;
  double x = sys.s2S[s];
  for (int o = 1; o < sys.blocks; ++o) x = std::min(x, sys.s2S[s + S * o]);
  return x;
}

// Per draw, the candidates' values given the data and the pending points'
// fantasised values: with A_P the pending columns of A,
//   SPP = s2S (Rs(U_P, U_P) + nugget I) - A_P'A_P,
//   ScP = s2S Rs(U, U_P) - A'A_P (a pending candidate's rows: SPP),
// (the columns' products within an output only, same_output()),
//   B = ScP SPP^-1,  cv = v - diag(B ScP'),  M(:, j) = mu + B (YP(j, :)' - mu_P),
// cv floored at 1e-12 s2S; B and D = YP' - mu_P are kept (Bk, Dk) and M
// formed where it is used (cond_means()). Without pending points M is mu.
// With targets (CT = CTU_s, CTP its pending columns):
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
// lower triangle read) with each pivot floored at fl (as a single value's
// variance is: cv >= 1e-12 s2S); returns sum log diag.
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

// Draw s's covariance of each run's K values given the data and the
// pending points (B, ScP from pending_conditionals(); k pending points),
// rows a != b of one run:
//   Sigma_ab = C0_ab - A_a'A_b - B_a ScP_b'   (C0 = s2S Rs(U_a, U_b), prior_cov();
//   A_a'A_b within an output only, same_output()),
// its diagonal the rows' variances cv (pending_conditionals()' own), and
// its factor (chol_floor()) in la.LK, la.ldK. A run's rows differ in the
// output alone (checked in design_look_ahead()), so Rs among them is the
// first run's.
void run_covariances(const DesignSystems& sys, const arma::mat& U, const Model& mod,
                     const arma::vec& cv, const arma::mat& B, const arma::mat& ScP, int k, int s,
                     LookAhead& la) {
  const int K = la.K, S = la.S;
  const arma::mat& As = sys.A.slice(s);
  const int N = As.n_rows;
  arma::mat C0(K, K);
  const int* o0 = sys.outU.empty() ? nullptr : sys.outU.data();
  prior_cov(sys, mod, s, U.rows(0, K - 1), o0, U.rows(0, K - 1), o0, C0);
  const double fl = 1e-12 * min_s2S(sys, s);
  for (int r = 0; r < la.Nr; ++r) {
    double* L = la.LK.data() + (size_t)K * K * ((size_t)r * S + s);
    for (int l = 0; l < K; ++l) {
      L[l + K * l] = cv[r * K + l];
      for (int i = l + 1; i < K; ++i) {
        const int a = r * K + i, b = r * K + l;
        double x = C0(i, l);
        if (same_output(sys, a, b)) x -= dot_sum(As.colptr(a), As.colptr(b), N);
        for (int p = 0; p < k; ++p) x -= B(a, p) * ScP(b, p);
        L[i + K * l] = x;
      }
    }
    la.ldK[(size_t)r * S + s] = chol_floor(L, K, fl);
  }
}

void pending_conditionals(const DesignSystems& sys, const arma::mat& U, const Model& mod,
                          double nugget, LookAhead& la) {
  const int k = la.P.size();
  const arma::uvec Pu = arma::conv_to<arma::uvec>::from(la.P);
  const arma::mat UP = U.rows(Pu);
  // the rows' outputs (independent outputs; prior_cov())
  std::vector<int> outP(k);
  for (int i = 0; i < k && !sys.outU.empty(); ++i) outP[i] = sys.outU[la.P[i]];
  const int* oU = sys.outU.empty() ? nullptr : sys.outU.data();
  const int* oP = sys.outU.empty() ? nullptr : outP.data();
  const int S = la.S, Nc = la.Nc;
  arma::mat SPP(k, k), ScP(la.Nc, k), B, Sinv;
  la.Bk.resize((size_t)S * Nc * k);
  la.Dk.resize((size_t)S * k * la.J);
  for (int s = 0; s < la.S; ++s) {
    const double s2S = sys.s2S[s];
    arma::vec cv = sys.v.col(s);
    if (k > 0) {
      const arma::mat& As = sys.A.slice(s);
      const arma::mat AP = As.cols(Pu);
      prior_cov(sys, mod, s, UP, oP, UP, oP, SPP);
      SPP.diag() *= 1.0 + nugget;
      // one GP: BLAS's A_P'A_P (the picks bit-identical to before the
      // outputs' path); independent outputs: only products within an
      // output, the columns of two outputs holding different rows
      if (sys.outU.empty()) {
        SPP -= AP.t() * AP;
      } else {
        for (int i = 0; i < k; ++i)
          for (int j = 0; j <= i; ++j)
            if (same_output(sys, la.P[i], la.P[j])) {
              const double x = dot_sum(AP.colptr(i), AP.colptr(j), AP.n_rows);
              SPP(i, j) -= x;
              if (j < i) SPP(j, i) -= x;
            }
      }
      prior_cov(sys, mod, s, U, oU, UP, oP, ScP);
      // (N-long dot products: BLAS dgemm's per-call cost was a tenth of a
      // batch's look-ahead)
      const int N = As.n_rows;
      for (int i = 0; i < k; ++i)
        for (int c = 0; c < la.Nc; ++c)
          if (same_output(sys, c, la.P[i])) ScP(c, i) -= dot_sum(As.colptr(c), AP.colptr(i), N);
      for (int i = 0; i < k; ++i) ScP.row(la.P[i]) = SPP.row(i);
      B = arma::solve(SPP, ScP.t()).t();  // ScP SPP^-1
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
    if (la.K > 1) {
      // (runs: their factors; the rows' sd are score_candidates()' alone)
      run_covariances(sys, U, mod, cv, B, ScP, k, s, la);
      continue;
    }
    for (int c = 0; c < la.Nc; ++c) {
      la.sd(s, c) = std::sqrt(std::max(cv[c], 1e-12 * s2S));
      la.isd(s, c) = 1.0 / la.sd(s, c);
      la.lsd(s, c) = std::log(la.sd(s, c));
    }
  }
}

// The draws' conditional means at candidate c in fantasy j (S values):
// mu(c, s) without pending points, else
//   M_s(c, j) = mu(c, s) + sum_i B_s(c, i) D_s(i, j)
// computed here into `buf` (the draws innermost). Stored for every
// candidate and fantasy (S x Nc x J, 4 MB with 35 draws), M's writes
// were most of a batch's look-ahead.
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

// Each candidate's gain given the pending points: fantasy j of candidate c
// is Y(c, j) = M_src[j](c, j) + sd_src[j](c) z_j (z common to every
// candidate); the draws are reweighted by N(Y; M_s(c, j), sd_s(c)^2), the
// normal's constant left out (it cancels):
//   gain(c) = mean_j Var_{base(:, j)}(kappa) - mean_j Var_{base(:, j) + log N}(kappa)
// (with targets the prediction's variance, target_var(), before and after).
void score_candidates(const DesignSystems& sys, LookAhead& la, const int* src,
                      const double* z, arma::vec& gain, arma::mat& Y) {
  double before = 0.0;
  for (int j = 0; j < la.J; ++j) {
    const double* b = la.base.colptr(j);
    before += crit_value(la, b, *std::max_element(b, b + la.S), j, -1, 0.0, nullptr);
  }
  before /= la.J;
  double* L = la.Lbuf.memptr();
  for (int c = 0; c < la.Nc; ++c) {
    double after = 0.0;
    if (la.T > 0) target_terms(la, c);
    for (int j = 0; j < la.J; ++j) {
      const double* mu = cond_means(sys, la, c, j, la.mbuf.data());
      const double* isd = la.isd.colptr(c);
      const double* lsd = la.lsd.colptr(c);
      const int r = src[j];
      const double y = mu[r] + la.sd(r, c) * z[j];
      Y(c, j) = y;
      const double* b = la.base.colptr(j);
      double mx = R_NegInf;
      for (int s = 0; s < la.S; ++s) {
        const double e = (y - mu[s]) * isd[s];
        L[s] = b[s] - 0.5 * e * e - lsd[s];
        mx = std::max(mx, L[s]);
      }
      after += crit_value(la, L, mx, j, c, y, mu);
    }
    gain[c] = before - after / la.J;
  }
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

// Adds to L (S) the log-density of run r's values y (K) under each draw,
// the normal's constant left out:
//   L_s += -|e_s|^2 / 2 - sum log diag LK_rs,  e_s = LK_rs^-1 (y - M_s)
// (mus from run_means()); e_s kept in la.eK (S x K) for the targets.
void run_log_density(LookAhead& la, int r, const double* const* mus, const double* y, double* L) {
  const int K = la.K, S = la.S;
  double e[16];  // K <= 16 (design_look_ahead())
  for (int s = 0; s < S; ++s) {
    const double* Ls = la.LK.data() + (size_t)K * K * ((size_t)r * S + s);
    for (int i = 0; i < K; ++i) e[i] = y[i] - mus[i][s];
    const double ss = solve_small(Ls, K, e);
    for (int i = 0; i < K; ++i) la.eK[s + (size_t)S * i] = e[i];
    L[s] += -0.5 * ss - la.ldK[(size_t)r * S + s];
  }
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

// score_candidates() for runs of K values (K > 1): fantasy j of run r is
// y = M_src[j](r, j) + LK_r,src[j] z_j (z_j: Z's K deviates of row j, common
// to every run), the draws reweighted by its K-variate normal density
// (run_log_density()); gain(r) as there, over the Nr runs; Y (Nc x J) the
// fantasised values by row.
void score_runs(const DesignSystems& sys, LookAhead& la, const int* src, const arma::mat& Z,
                int col, arma::vec& gain, arma::mat& Y) {
  const int K = la.K, S = la.S, J = la.J;
  double before = 0.0;
  for (int j = 0; j < J; ++j) {
    const double* b = la.base.colptr(j);
    before += crit_value(la, b, *std::max_element(b, b + S), j, -1, 0.0, nullptr);
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
      const double* b = la.base.colptr(j);
      std::copy(b, b + S, L);
      run_log_density(la, r, mus, y, L);
      const double mx = *std::max_element(L, L + S);
      after += crit_value(la, L, mx, j, r, 0.0, nullptr);
    }
    gain[r] = before - after / J;
  }
}

// Look-aheads alive (design_look_ahead_live(): each is freed on return
// or on release, not left to R's garbage collector).
static int lookAheadsAlive = 0;

// A look-ahead in progress (design_look_ahead()): the systems, the state,
// the inputs the steps read (U, the deviates Z, `order`: 0 = greedy) and
// the results of the `step` steps run so far. Not copied (one per count).
struct LookAheadRun {
  LookAheadRun() { ++lookAheadsAlive; }
  ~LookAheadRun() { --lookAheadsAlive; }
  LookAheadRun(const LookAheadRun&) = delete;
  LookAheadRun& operator=(const LookAheadRun&) = delete;
  Model mod;
  DesignSystems sys;
  LookAhead la;
  arma::mat U, Z, Y, scores;
  arma::vec lw, gain, best;
  arma::uvec kept;
  std::vector<int> order, s0, chosen;
  double variance = 0.0, nugget = 0.0;
  int n = 0, step = 0;
};

// Runs a look-ahead's steps up to `upto` (greedy: each picks the candidate
// of largest gain given the pending ones, or order[step]; its fantasised
// values then reweight the draws in each fantasy).
void look_ahead_steps(LookAheadRun& run, int upto) {
  const DesignSystems& sys = run.sys;
  LookAhead& la = run.la;
  const int K = la.K;
  const double* mus[16];
  for (; run.step < upto; ++run.step) {
    const int step = run.step;
    pending_conditionals(sys, run.U, run.mod, run.nugget, la);
    if (step == 0) run.variance = crit_value(la, run.lw.memptr(), run.lw.max(), 0, -1, 0.0, nullptr);
    if (K == 1) score_candidates(sys, la, run.s0.data(), run.Z.colptr(step), run.gain, run.Y);
    else score_runs(sys, la, run.s0.data(), run.Z, step * K, run.gain, run.Y);
    for (int c : la.P) run.gain[c / K] = R_NegInf;
    run.scores.col(step) = run.gain;
    const int b = run.order.size() > 0 ? run.order[step] - 1 : (int)run.gain.index_max();
    run.chosen[step] = b + 1;
    run.best[step] = run.gain[b];
    for (int j = 0; j < la.J; ++j) {
      if (K > 1) {
        run_means(sys, la, b, j, mus);
        double y[16];
        for (int i = 0; i < K; ++i) y[i] = run.Y(b * K + i, j);
        run_log_density(la, b, mus, y, la.base.colptr(j));
        continue;
      }
      const double* mu = cond_means(sys, la, b, j, la.mbuf.data());
      for (int s = 0; s < la.S; ++s) {
        const double e = (run.Y(b, j) - mu[s]) * la.isd(s, b);
        la.base(s, j) += -0.5 * e * e - la.lsd(s, b);
      }
    }
    for (int i = 0; i < K; ++i) {
      la.P.push_back(b * K + i);
      la.YP.insert_cols(la.YP.n_cols, run.Y.row(b * K + i).t());
    }
    Rcpp::checkUserInterrupt();
  }
}

// design_look_ahead()'s list of the steps run.
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
// draw (design_system()); with target points XT (T x p) their predictive
// means mT and variances VT (T x S).
// [[Rcpp::export(.design_systems)]]
Rcpp::List design_systems_r(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                            const arma::vec& ys, const arma::mat& phis, const arma::mat& U,
                            const arma::mat& XT, double nugget, const Rcpp::List& model) {
  Model mod;
  DesignSystems sys = design_systems(Xf, yf, Xs, ys, phis, U, XT, nugget, model, mod, false);
  return Rcpp::List::create(Rcpp::Named("mu") = sys.mu, Rcpp::Named("v") = sys.v,
                            Rcpp::Named("ll") = sys.ll, Rcpp::Named("mT") = sys.mT,
                            Rcpp::Named("VT") = sys.VT);
}

// The greedy look-ahead: n points chosen one at a time, each maximising
// the expected reduction of kappa's weighted posterior variance (or, with
// target points XT, T x p, of the calibrated prediction's integrated
// variance there) given the pending points (score_candidates()). Base log-weights lw0 (+ ll with
// `plugin`), normalised w; fantasy j comes from draw src[j], the first s
// with sum_{r <= s} w_r >= usrc[j] (usrc uniforms: the draws by w), with the
// normal deviate Z(j, step) in each step; after a pick the base
// log-weights gain its log-densities. With `order` (1-based, n distinct
// candidates) step k takes candidate order[k] instead of the best: the
// gains of given points in a given order. With `plugin` and prune > 0 the
// draws whose weight lw0 + ll is under exp(-prune) of the largest are left
// out first (the two largest always kept): they add nothing but their cost.
// With `outputs` K > 1 the candidates are runs of K rows each (U's rows
// r K .. r K + K - 1, alike but for the output's columns), a pick a run,
// scored with its K values fantasised jointly (score_runs(); step k's
// deviates Z's columns k K .. k K + K - 1) and pending as K points.
// With `entropy` (and no targets) the criterion is the expected reduction
// of kappa's entropy (weighted_entropy(), for the plug-in's kappa values).
// Returns the picks (1-based), their gains, the current variance (or
// entropy), every candidate's gain per step (scores, Nc x n) and the draws
// scored (kept, 1-based). With `steps` < n only the first steps are run
// and the list holds the look-ahead in progress too (`state`, for
// design_look_ahead_resume(): the same results as running all n at once),
// the picks and scores those of the steps run.
// [[Rcpp::export(.design_look_ahead)]]
Rcpp::List design_look_ahead(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                             const arma::vec& ys, const arma::mat& phis, const arma::mat& U,
                             const arma::mat& kappa, const arma::vec& lw0, bool plugin,
                             const arma::vec& usrc, const arma::mat& Z, const arma::mat& XT,
                             double nugget, const Rcpp::List& model,
                             const Rcpp::IntegerVector& order, double prune, int outputs,
                             bool entropy, int steps) {
  const int K = outputs;
  if (K < 1 || K > 16 || U.n_rows % K != 0 || Z.n_cols % K != 0)
    Rcpp::stop("outputs must be 1 to 16, dividing U's rows and Z's columns");
  const int n = Z.n_cols / K, Nr = U.n_rows / K;
  if (steps < 1) Rcpp::stop("steps must be 1 or more");
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
  if (kappa.n_rows != phis.n_rows || kappa.n_cols > 16 || lw0.n_elem != phis.n_rows)
    Rcpp::stop("kappa and lw0 must have a row per draw (at most 16 calibration inputs)");
  if (phis.n_rows < 1) Rcpp::stop("phis must have a draw");
  if ((int)usrc.n_elem != (int)Z.n_rows) Rcpp::stop("usrc must have %d uniforms", (int)Z.n_rows);
  // (owned by R from here: freed if a step is interrupted)
  Rcpp::XPtr<LookAheadRun> xp(new LookAheadRun, true);
  LookAheadRun& run = *xp;
  run.U = U;
  run.Z = Z;
  run.order.assign(order.begin(), order.end());
  run.n = n;
  run.kept = arma::regspace<arma::uvec>(0, phis.n_rows - 1);
  Model& mod = run.mod;
  if (plugin && prune > 0 && phis.n_rows > 2) {
    // the likelihoods alone first (no candidates, no targets)
    const arma::vec lw = lw0 + design_systems(Xf, yf, Xs, ys, phis, arma::mat(0, U.n_cols),
                                              arma::mat(0, Xf.n_cols), nugget, model, mod,
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
  run.nugget = nugget;
  run.sys = design_systems(Xf, yf, Xs, ys, ph, U, XT, nugget, model, mod, n > 1 || K > 1);
  LookAhead& la = run.la;
  la.S = ph.n_rows; la.Nc = U.n_rows; la.J = Z.n_rows; la.T = run.sys.T; la.K = K; la.Nr = Nr;
  la.entropy = entropy;
  la.kap = kap;
  la.ksq = arma::sum(arma::square(kap), 1);
  run.lw = plugin ? arma::vec(lwk + run.sys.ll) : lwk;
  const arma::vec cw = arma::cumsum(arma::exp(run.lw - run.lw.max()));
  run.s0.resize(la.J);
  for (int j = 0; j < la.J; ++j) {
    int s = 0;
    while (s < la.S - 1 && cw[s] < usrc[j] * cw[la.S - 1]) ++s;
    run.s0[j] = s;
  }
  la.base = arma::repmat(run.lw, 1, la.J);
  la.YP.set_size(la.J, 0);
  la.sd.set_size(la.S, la.Nc);
  la.isd.set_size(la.S, la.Nc);
  la.lsd.set_size(la.S, la.Nc);
  la.Lbuf.set_size(la.S);
  la.mbuf.resize((size_t)la.S * K);  // cond_means()'s (run_means()': K of them)
  la.wbuf.set_size(la.S);
  if (la.T > 0) {
    la.VTP.set_size(la.S, la.T);
    la.MT.resize((size_t)la.S * la.T * la.J);
    la.CP.resize((size_t)la.S * la.T * la.Nc);
    la.tb.resize((size_t)la.S * la.T);  // target_terms()'s
    la.tv.resize((size_t)la.S * la.T);
  }
  if (K > 1) {
    la.LK.resize((size_t)K * K * la.S * Nr);
    la.ldK.resize((size_t)la.S * Nr);
    la.eK.resize((size_t)la.S * K);
    if (la.T > 0) {
      la.gK.resize((size_t)la.S * la.T * K);
      la.vK.resize((size_t)la.S * la.T);
    }
  }
  run.gain.set_size(Nr);
  run.best.set_size(n);
  run.Y.set_size(la.Nc, la.J);
  run.scores.set_size(Nr, n);
  run.chosen.assign(n, 0);
  look_ahead_steps(run, std::min(steps, n));
  Rcpp::List out = look_ahead_result(run);
  if (run.step < n) out["state"] = xp;
  else xp.release();  // (finished: freed now, not at R's next collection)
  return out;
}

// The rest of a look-ahead begun with design_look_ahead(steps < n): its
// results as design_look_ahead()'s with every step run.
// [[Rcpp::export(.design_look_ahead_resume)]]
Rcpp::List design_look_ahead_resume(SEXP state) {
  Rcpp::XPtr<LookAheadRun> xp(state);
  if (xp.get() == nullptr) Rcpp::stop("state is a look-ahead already finished");
  look_ahead_steps(*xp, xp->n);
  Rcpp::List out = look_ahead_result(*xp);
  xp.release();  // (its systems' memory back now, not at the next collection)
  return out;
}

// Frees a look-ahead in progress (design_look_ahead(steps < n)) now, not at
// R's next garbage collection: its systems are as large as a look-ahead's.
// [[Rcpp::export(.design_look_ahead_release)]]
void design_look_ahead_release(SEXP state) {
  Rcpp::XPtr<LookAheadRun> xp(state);
  xp.release();
}

// The number of look-aheads alive (for tests: 0 after pick_runs()).
// [[Rcpp::export(.design_look_ahead_live)]]
int design_look_ahead_live() { return lookAheadsAlive; }
