// The KOH log-likelihood through its block structure (the field side).
//
// With y = (yf, ys), Ds = Rs(Xs,Xs) + nugget I, Bs = Rs(Xs,Xk),
//   Q = Rs(Xk,Xk) - Bs' Ds^-1 Bs,  wz = Bs' Ds^-1 ys,
//   S = sigma2S Q + sigma2B Rb + sigma2E I   (Schur complement of D in C),
// S = F F' (FieldFactor, field.cpp: chol(S), or with replicated field rows a
// factor on the distinct rows), v = F^-1 (yf - muB - wz); without a bias
// (discrepancy "none") S = sigma2S Q + sigma2E I and v = F^-1 (yf - wz):
//   log L = -0.5 [ (n+m) log 2pi + m log sigma2S + log|Ds| + log|S|
//                  + ys' Ds^-1 ys / sigma2S + v'v ].
// log|Ds|, ys' Ds^-1 ys, Q and wz come from the simulator algebra (dense.cpp,
// kronecker.cpp). Because every field row shares kappa, Bs = diag(c) Rx with
// Rx the correlation over the p experimental inputs and
// c_i = R_cal(xs_i, kappa) over the q calibration inputs, and Rs(Xk,Xk)
// involves the experimental inputs only.
#include "fbc.h"

// The log-likelihood from its pieces (the formula above), for every move,
// the pieces kept in the scratch buffers.
// lpG: the latent log noise variances' GP log prior (0 without them).
double SchurPosterior::loglik(double ldDs, double zz, double ldS, double vv, double lpG) {
  const double s2S = phi[iSigma2S];
  ldDs_.alt() = ldDs; zz_.alt() = zz; ldS_.alt() = ldS; vv_.alt() = vv; lpG_.alt() = lpG;
  double ll = -0.5 * ((n + m) * LOG_2PI + m * std::log(s2S) + ldDs + ldS + zz / s2S + vv);
  if (simNoise) ll += noiseLoglik() + lpG;
  return loglik_.alt() = ll;
}

// The classes the compiled core computes with, one row each (see fbc.h).
// thetaS and alphaS p + q per output with a simulator GP, the bias classes p
// or 1 per output with a bias, muB and lambdaZ one per output with a bias
// in the discrepancy models that have them; the simulator's own noise,
// sigma2R or the input-dependent gR (one per unique run) with its GP's
// muG, sigma2G and thetaG (read_model() checks which goes with which),
// computed by the dense and nearest-neighbour algebras of one emulated output.
std::vector<ClassNeed> class_needs(int p, int q, int K, int e, int b, int G, int lc, int ld,
                                   int u) {
  using P = Posterior;
  const unsigned noise = AK_DENSE | AK_VECCHIA;
  return {{"kappa", q, false, &P::iKappa}, {"thetaS", e * K * (p + q), false, &P::iThetaS},
          {"alphaS", e * K * (p + q), false, &P::iAlphaS}, {"thetaB", K * b * p, false, &P::iThetaB},
          {"alphaB", K * b * p, false, &P::iAlphaB}, {"sigma2S", e * K, false, &P::iSigma2S},
          {"sigma2B", K * b, false, &P::iSigma2B}, {"sigma2E", G, false, &P::iSigma2E},
          {"muB", K * b, true, &P::iMuB}, {"lambdaZ", K * b, true, &P::iLambdaZ},
          {"rhoS", e * K * lc, false, &P::iRhoS}, {"rhoB", K * b * lc, false, &P::iRhoB},
          {"rhoD", K * b * ld, false, &P::iRhoD}, {"sigma2R", 1, true, &P::iSigma2R, noise},
          {"gR", u, true, &P::iG, noise}, {"muG", 1, true, &P::iMuG, noise},
          {"sigma2G", 1, true, &P::iSigma2G, noise}, {"thetaG", p + q, true, &P::iThetaG, noise}};
}

const char* class_outside(const Layout& lay, unsigned kind) {
  for (const ClassNeed& c : class_needs(0, 0, 1, 1, 1, 1, 0, 0, 0))
    if (lay.length_of(c.name) > 0 && (c.algebras & kind) != kind) return c.name;
  return nullptr;
}

// The algebras that compute with each class, by name, for R (classes_outside(),
// R/algebra.R).
// [[Rcpp::export(.class_algebras)]]
Rcpp::List class_algebras() {
  const char* kinds[] = {"dense", "kronecker", "vecchia", "function", "outputs"};
  const std::vector<ClassNeed> need = class_needs(0, 0, 1, 1, 1, 1, 0, 0, 0);
  Rcpp::List out(need.size());
  Rcpp::CharacterVector names(need.size());
  for (size_t c = 0; c < need.size(); ++c) {
    std::vector<std::string> k;
    for (int b = 0; b < 5; ++b) if (need[c].algebras & (1u << b)) k.push_back(kinds[b]);
    out[c] = Rcpp::wrap(k);
    names[c] = need[c].name;
  }
  out.names() = names;
  return out;
}

// Sizes, the layout and the offsets of the classes computed with, looked up
// by name (class_needs()'s rows); the discrepancy model read off the layout
// (see Posterior).
void Posterior::set_sizes(int n_, int m_, int p_, int q_, const Model& model) {
  n = n_; m = m_; p = p_; q = q_;
  const Layout& lay = model.layout;
  layout = lay;
  bias = lay.length_of("sigma2B") > 0;
  sgasp = lay.length_of("lambdaZ") > 0;
  biasMean = lay.length_of("muB") > 0;
  d = lay.d;
  for (const ClassNeed& c : class_needs(0, 0, 1, 1, 1, 1, 0, 0, 0)) this->*c.offset = lay.offset_of(c.name);
  levels = model.levels;
  latent = lay.length_of("gR") > 0;
  simNoise = lay.length_of("sigma2R") > 0 || latent;
  fieldReal = simNoise && !latent && model.fieldRealization;
  if (latent) {
    if ((int) model.repSSWi.size() != m_)
      Rcpp::stop("the input-dependent noise needs a within sum of squares per unique run (%d)", m_);
    repSSWi = arma::vec(model.repSSWi);
    repDfi = arma::vec(model.repCount) - 1.0;
  }
  if (simNoise) {
    if ((int) model.repCount.size() != m_)
      Rcpp::stop("the replicate counts must give one count per unique run (%d)", m_);
    repInv.set_size(m_);
    repLogN = 0.0;
    for (int i = 0; i < m_; ++i) {
      repInv[i] = 1.0 / model.repCount[i];
      repLogN += std::log(model.repCount[i]);
    }
    repSSW = model.repSSW; repDf = model.repDf;
  }
  scaled.clear();
  for (size_t c = 0; c < lay.names.size(); ++c)
    for (int k = 0; lay.scaled[c] && k < lay.length[c]; ++k) scaled.push_back(lay.offset[c] + k);
  phi.zeros(d);
}

// The replicates' within term: the runs at each unique input less their
// mean, -0.5 [sum_i (n_i - 1) log(2 pi r) + SSW / r + sum_i log n_i] (the
// means carry the rest: their noise variance r / n_i is in the simulator
// block; the last sum is the Jacobian from the runs to their means and
// deviations, so that the log-likelihood is that of every run).
// With an input-dependent noise r_i = exp(g_i):
// -0.5 [sum_i (n_i - 1)(log 2 pi + g_i) + sum_i SSW_i exp(-g_i) + sum_i log n_i].
double Posterior::noiseLoglik() const {
  if (!latent) {
    const double r = phi[iSigma2R];
    return -0.5 * (repDf * (LOG_2PI + std::log(r)) + repSSW / r + repLogN);
  }
  double s = repLogN;
  for (int i = 0; i < m; ++i) {
    const double g = phi[iG + i];
    s += repDfi[i] * (LOG_2PI + g) + repSSWi[i] * std::exp(-g);
  }
  return -0.5 * s;
}

void fill_layout(Layout& lay) {
  lay.d = 0;
  const int C = lay.names.size();
  for (int c = 0; c < C; ++c) lay.d += lay.length[c];
  lay.cls.assign(lay.d, -1);
  lay.pos.assign(lay.d, -1);
  for (int c = 0; c < C; ++c)
    for (int k = 0; k < lay.length[c]; ++k) {
      const int j = lay.offset[c] + k;
      if (j < 0 || j >= lay.d || lay.cls[j] >= 0)
        Rcpp::stop("the layout's classes overlap or leave phi");
      lay.cls[j] = c; lay.pos[j] = k;
    }
}

void Posterior::set_field(const arma::mat& Xf, const Model& model) {
  if (!model.noise.empty() && (int) model.noise.size() != n)
    Rcpp::stop("the noise groups must give one group per field row (%d)", n);
  noise_ = model.noise.empty() ? std::vector<int>(n, 0) : model.noise;
  if (!model.source.empty() && (int) model.source.size() != n)
    Rcpp::stop("the field data sets must give one per field row (%d)", n);
  sourceL_ = model.sourceL;
  const std::vector<int> src = model.source.empty() ? std::vector<int>(n, 0) : model.source;
  if (!model.fieldRows.empty() && (int) model.fieldRows.size() != n)
    Rcpp::stop("the field rows' groups must give one group per field row (%d)", n);
  grp_.resize(n);
  std::vector<int> first;  // each group's first row
  for (int i = 0; i < n; ++i) {
    int g = (int) first.size();
    if (!model.fieldRows.empty()) g = model.fieldRows[i];
    else  // (no grouping handed over: equal rows found here)
      for (size_t u = 0; u < first.size() && g == (int) first.size(); ++u)
        if (src[i] == src[first[u]] && arma::all(Xf.row(i) == Xf.row(first[u]))) g = u;
    grp_[i] = g;
    if (g == (int) first.size()) first.push_back(i);
    else if (g < 0 || g > (int) first.size() || src[i] != src[first[g]] ||
             arma::any(Xf.row(i) != Xf.row(first[g])))
      Rcpp::stop("the field rows' groups must be numbered in order and group equal rows");
  }
  nu_ = first.size();
  Xu_.set_size(nu_, p);
  srcU_.resize(nu_);
  for (int u = 0; u < nu_; ++u) { Xu_.row(u) = Xf.row(first[u]); srcU_[u] = src[first[u]]; }
}

SchurPosterior::SchurPosterior(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                               const arma::vec& ys, double nugget, const Model& model)
  : Xf_(Xf), yf_(yf), Xs_(Xs), ys_(ys), nugget_(nugget), kernS_(model.kernS),
    kernB_(model.kernB) {
  set_sizes(Xf.n_rows, Xs.n_rows, Xf.n_cols, Xs.n_cols - Xf.n_cols, model);
  touch_.reset(p + q, p);
  // replicates share their columns of Rs(Xs,Xk), Rs(Xk,Xk) and Rb: those
  // are computed for the nu distinct rows only
  set_field(Xf, model);
  Pfs_.resize(p); Pfb_.resize(p);
  for (int b = 0; b < 2; ++b) {
    for (int k = 0; k < p; ++k) {
      // power matrices only for a family with a smoothness (else P = G)
      if (kernel_has_alpha(kernS_)) Pfs_[k].b[b].zeros(nu_, nu_);
      if (kernel_has_alpha(kernB_)) Pfb_[k].b[b].zeros(nu_, nu_);
    }
    Rkk_.b[b].zeros(nu_, nu_); Q_.b[b].zeros(nu_, nu_); Rb_.b[b].zeros(nu_, nu_);
    wz_.b[b].zeros(nu_);
  }
  M_.zeros(nu_, nu_);
  dv_.zeros(n);
  u_.zeros(n);
  ptrF_.resize(p); ptrB_.resize(p);
  auto dist_cache = [&](int kern, std::vector<arma::mat>& G) {
    G.resize(p);
    for (int k = 0; k < p; ++k) {
      G[k].zeros(nu_, nu_);
      kernel_dist(kern, Xu_.col(k), Xu_.col(k), G[k], true);
    }
  };
  dist_cache(kernS_, Gf_);
  // the bias GP's distance cache, when its family caches another g(d)
  if (kernB_ != kernS_) dist_cache(kernB_, Gfb_);
}

// Add what a move of parameter j touches to t (by j's class in the layout).
void SchurPosterior::add_touch(int j, Touch& t) const {
  const int k = layout.pos[j];
  switch (layout.touch[layout.cls[j]]) {
  case TK_KAPPA:
    t.cChange = t.cross = t.field = true;
    break;
  case TK_SIMPOW:
    t.simPow[k] = 1;
    // fall through
  case TK_SIM:
    t.simCorr = t.cross = t.field = true;
    if (k < p) t.expDim = true; else t.calDim = t.cChange = true;
    break;
  case TK_SIMLEVELS:  // the levels' correlation: as an experimental input's thetaS
    t.simCorr = t.cross = t.field = t.expDim = true;
    break;
  case TK_BIASPOW:
    t.biasPow[k] = 1;
    // fall through
  case TK_BIAS:
    t.biasCorr = t.field = true;
    break;
  case TK_FIELD:
    t.field = true;
    // with the simulator's own noise, Ds holds sigma2R / sigma2S
    if (simNoise && j == iSigma2S) t.simCorr = t.cross = true;
    break;
  case TK_RUNS:
    t.simCorr = t.cross = t.field = true;
    break;
  case TK_LATENT:  // the noise variances of the means and their GP prior
    t.simCorr = t.cross = t.field = t.latentLp = true;
    break;
  case TK_LATENTK:
    t.latentK = true;
    // fall through
  case TK_LATENTHYPER:
    t.latentLp = true;
    break;
  default:  // muB: only the residual moves
    break;
  }
}

bool SchurPosterior::init(const arma::vec& phi0) {
  set_phi(phi0);
  Touch all; all.everything(p + q, p);
  scratch_ = true;
  double ll = evaluate(all);
  scratch_ = false;
  if (!std::isfinite(ll)) return false;
  flip(all);
  return true;
}

double SchurPosterior::propose(const std::vector<int>& idx, const arma::vec& values) {
  saveSet(idx, values);
  touch_.reset(p + q, p);
  for (size_t i = 0; i < idx.size(); ++i) add_touch(idx[i], touch_);
  return evaluate(touch_);
}

// C -> c C: log|Ds| and z'z are unchanged, S -> c S (FieldFactor::scale(),
// log|S| + n log c, v'v / c) and sigma2S -> c sigma2S.
double SchurPosterior::proposeScale(double c) {
  saveScale(c);
  touch_.reset(p + q, p);
  touch_.scale = true;
  const double s2S = phi[iSigma2S];
  // (an input-dependent noise does not scale with the variances)
  if (!(s2S > 0) || !std::isfinite(c) || latent) return R_NegInf;
  return loglik(ldDs_.cur(), zz_.cur(), ldS_.cur() + n * std::log(c), vv_.cur() / c, lpG_.cur());
}

void SchurPosterior::accept() {
  if (touch_.scale) {
    const double c = pendingScale();  // sigma2S comes first
    FS_.alt() = FS_.cur();
    FS_.alt().scale(c);
  }
  flip(touch_);
}

void SchurPosterior::reject() {
  restore();
}

// F^-1 (yf - muB - wz) (S = F F'), each field row's wz its distinct row's.
static arma::vec field_residual(const FieldFactor& FS, const arma::vec& yf, double muB,
                                const arma::vec& wz, const std::vector<int>& grp) {
  arma::vec v(yf.n_elem);
  for (arma::uword i = 0; i < yf.n_elem; ++i) v[i] = yf[i] - muB - wz[grp[i]];
  FS.whiten(v, grp);
  return v;
}

// F^-1 K_F with K_F's rows those of K (a row per distinct field row) at
// each field row's.
static arma::mat field_rows(const FieldFactor& FS, const arma::mat& K, const std::vector<int>& grp) {
  arma::mat H = K.rows(arma::conv_to<arma::uvec>::from(grp));
  FS.whiten(H, grp);
  return H;
}

void Posterior::mub_quadratic(const FieldFactor& FS, const std::vector<int>& grp, arma::vec r,
                              double& aa, double& ab) {
  arma::vec a(r.n_elem, arma::fill::ones);
  FS.whiten(a, grp);
  FS.whiten(r, grp);
  aa = arma::dot(a, a);
  ab = arma::dot(a, r);
}

void SchurPosterior::muBQuadratic(double& aa, double& ab) const {
  arma::vec r(n);
  for (int i = 0; i < n; ++i) r[i] = yf_[i] - 0.0 - wz_.cur()[grp_[i]];
  mub_quadratic(FS_.cur(), grp_, r, aa, ab);
}

// The S-GaSP correlation on the nu distinct field inputs (Gu and Wang 2018,
// the discretized kernel with the field inputs as the discretization
// points; RobustCalibration's Get_R_z_new): from R (lower triangle),
//   Rz = R - R (R + c I)^-1 R,  c = nu / lambda,
// through L = chol(R + c I), W = L^-1 R: Rz = R - W'W (written over R,
// lower triangle). False when R + c I is not positive definite.
static bool sgasp_corr(arma::mat& R, double lambda, arma::mat& B, arma::mat& W) {
  const int nu = R.n_rows;
  if (!(lambda > 0) || !std::isfinite(lambda)) return false;
  R = arma::symmatl(R);
  B = R;
  B.diag() += nu / lambda;
  if (!chol_lower(B)) return false;
  W = R;
  solve_lower(B, W);
  syrk_lower(W, -1.0, 1.0, R);
  return true;
}

// The discrepancy model's computations on the bias GP's correlation R (the
// model is read off the layout, set_sizes()): the KOH bias keeps R; the
// S-GaSP (lambdaZ) scales it. On the nu distinct field inputs (lower
// triangle, in place; B, W workspaces): Rz = sgasp_corr(R). False when it
// is not positive definite.
bool Posterior::biasModel(arma::mat& R, arma::mat& B, arma::mat& W) const {
  return !sgasp || sgasp_corr(R, phi[iLambdaZ], B, W);
}

// At new inputs: K = R(Xu, Xnew) -> the model's cross-correlation, r its
// variance at them (1 for the KOH bias). S-GaSP: the discretized kernel
// Kz(x, x') = R(x, x') - R(x, Xu) (R + c I)^-1 R(Xu, x'), c = nu / lambdaZ,
// so with L = chol(R(Xu, Xu) + c I) (Ruu() gives R(Xu, Xu)) and
// H = L^-1 R(Xu, Xnew):
//   K = R(Xu, Xnew) - R (R + c I)^-1 R(Xu, Xnew) = c L^-T H,
//   r = 1 - colsums(H^2).
void Posterior::biasModelCross(const std::function<arma::mat()>& Ruu, arma::mat& K,
                               arma::vec& r) const {
  r.ones(K.n_cols);
  if (!sgasp) return;
  arma::mat L = Ruu();
  const double c = L.n_rows / phi[iLambdaZ];
  L.diag() += c;
  if (!chol_lower(L)) Rcpp::stop("the S-GaSP correlation is not positive definite");
  solve_lower(L, K);  // H
  r -= arma::sum(arma::square(K), 0).t();
  K = c * arma::solve(arma::trimatu(arma::trimatl(L).t()), K);
}

// out(i, j) *= prod_f C_f[a_f(i), a_f(j)] (rhoB: each categorical input f's
// level correlation) * D[srcX[i], srcY[j]] (rhoD: the field data sets'
// biases' correlation, with a bias per data set); lower: only i >= j.
void SchurPosterior::biasLevels(const arma::mat& X, const int* srcX, const arma::mat& Y,
                                const int* srcY, arma::mat& out, bool lower) const {
  level_scale(levels, phi.memptr() + iRhoB, X, Y, out, lower);
  if (sourceL_) source_scale(sourceL_, phi.memptr() + iRhoD, srcX, srcY, out, lower);
}

// The bias GP's correlation between the distinct field inputs and new
// inputs Xnew (K, nu x b) and at the new inputs themselves (r, b), as the
// discrepancy model has it (biasModelCross()).
void SchurPosterior::biasCross(const arma::mat& Xnew, arma::mat& K, arma::vec& r,
                               const int* source) const {
  const arma::vec thetaB = phi.subvec(iThetaB, iThetaB + p - 1);
  const arma::vec alphaB = phi.subvec(iAlphaB, iAlphaB + p - 1);
  if (sourceL_) {
    if (!source) Rcpp::stop("the bias of a new point needs its field data set");
    for (arma::uword c = 0; c < Xnew.n_rows; ++c)
      if (source[c] < 0 || source[c] >= sourceL_)
        Rcpp::stop("field data set %d of a new point is not one of the %d", source[c] + 1, sourceL_);
  }
  K = corr_matrix(Xu_, Xnew, thetaB, alphaB, kernB_);
  biasLevels(Xu_, srcU_.data(), Xnew, source, K, false);
  biasModelCross([&] {
    arma::mat L = corr_matrix(Xu_, Xu_, thetaB, alphaB, kernB_);
    biasLevels(Xu_, srcU_.data(), Xu_, srcU_.data(), L, false);
    return L;
  }, K, r);
}

// GP conditional of a target with covariance ks = s2S k with ys and kf with
// yf (k = Rs(Xs, xk*), xk* = (x*, kappa)), prior mean mu0 and variance v0,
// through the blocks of C: with a = k' Ds^-1 ys, b = k' Ds^-1 k,
// g = Bs' Ds^-1 k (the algebra's simCondition), h = F^-1 (kf - s2S g),
// v = F^-1 (yf - muB - wz) (S = F F'):
//   mean = mu0 + a + h'v,   var = v0 - s2S b - h'h.
// Targets, by type: 1 field (eta + delta + eps), 2 mean (eta + delta),
// 3 simulator (eta), 4 bias (delta, ks = 0):
//   kf = s2S Rs(Xk, xk*) [types 1-3] + s2B Rb(Xf, x*) [types 1, 2, 4],
// with prior variance s2S [1-3] + s2B rb(x*) [1, 2, 4] + s2E [1].
// Without a bias, s2B = muB = 0: the bias is exactly 0 (mean and variance).
// Under S-GaSP the bias's cross-correlation and variance are the
// discretized kernel's (biasCross()), and its mean is 0.
void SchurPosterior::condition(const arma::mat& Xnew, int type, double* mean, double* var,
                               const int* noise, const int* source) {
  const int b = Xnew.n_rows;
  const double s2S = phi[iSigma2S];
  const double s2B = bias ? phi[iSigma2B] : 0.0, muB = biasMean ? phi[iMuB] : 0.0;
  const bool simPart = type != PT_BIAS, biasPart = type != PT_SIMULATOR && bias;
  const double mu0 = type == PT_SIMULATOR ? 0.0 : muB;
  arma::vec v0(b, arma::fill::zeros);
  if (simPart) v0 += s2S;
  if (type == PT_FIELD) {
    const int G = layout.length_of("sigma2E");
    for (int c = 0; c < b; ++c) {
      const int g = noise ? noise[c] : 0;
      if (g < 0 || g >= G) Rcpp::stop("noise group %d of a new point is not one of the %d", g + 1, G);
      v0[c] += phi[iSigma2E + g] + (fieldReal ? phi[iSigma2R] : 0.0);
    }
  }
  // covariances with the distinct field rows (Rs(Xk, xk*) involves the
  // experimental inputs only: the calibration inputs coincide)
  arma::mat Kf(nu_, b, arma::fill::zeros), G;
  arma::vec a(b, arma::fill::zeros), bb(b, arma::fill::zeros);
  if (simPart) {
    Kf = s2S * corr_matrix(Xu_, Xnew, phi.subvec(iThetaS, iThetaS + p - 1),
                           phi.subvec(iAlphaS, iAlphaS + p - 1), kernS_);
    level_scale(levels, phi.memptr() + iRhoS, Xu_, Xnew, Kf, false);
    simCondition(Xnew, a, bb, G);
    Kf -= s2S * G;
  }
  if (biasPart) {
    arma::mat Kb;
    arma::vec rb;
    biasCross(Xnew, Kb, rb, source);
    Kf += s2B * Kb;
    v0 += s2B * rb;
  }
  const arma::vec v = field_residual(FS_.cur(), yf_, muB, wz_.cur(), grp_);
  const arma::mat H = field_rows(FS_.cur(), Kf, grp_);
  for (int c = 0; c < b; ++c) {
    const double* h = H.colptr(c);
    double hv = 0.0, hh = 0.0;
    for (int k = 0; k < n; ++k) { hv += h[k] * v[k]; hh += h[k] * h[k]; }
    mean[c] = mu0 + a[c] + hv;
    var[c] = v0[c] - s2S * bb[c] - hh;
  }
}

// The Schur complement S(i,j) = s2S Q(g_i,g_j) + s2B Rb(g_i,g_j) +
// sigma2E[noise_i] [i = j] (lower triangles of the distinct-row Q and Rb; no
// Rb without a bias), factored into LS_.alt() with log|S| in `ldS`; false if
// S is not positive definite. A proposal whose S is numerically singular,
// some pivot L_ii^2 below S_PIVOT times S's largest diagonal entry, is
// refused too: its log-likelihood is roundoff (from scratch and updated
// values differed by 2.5 on such draws) and a draw accepted there could
// fail to factor from scratch (predict()). init() factors from scratch
// without the floor (scratch_), so every accepted draw initialises.
bool SchurPosterior::fieldFactor(const arma::mat& Q, const arma::mat* Rb, double s2S,
                                 double s2B, double& ldS) {
  static const double S_PIVOT = 1e-10;
  for (int c = 0; c < nu_; ++c)
    for (int r = c; r < nu_; ++r) M_.at(r, c) = s2S * Q.at(r, c) + (bias ? s2B * Rb->at(r, c) : 0.0);
  for (int j = 0; j < n; ++j) dv_[j] = phi[iSigma2E + noise_[j]] + (fieldReal ? phi[iSigma2R] : 0.0);
  // (on the distinct rows alone with replicated ones)
  if (!FS_.alt().factor(M_, grp_, dv_, nu_ < n, scratch_ ? 0.0 : S_PIVOT)) return false;
  ldS = FS_.alt().logdet;
  return true;
}

// A correlation's per-dimension terms over the experimental inputs into P:
// the distance cache G[k] itself for a family without a smoothness, else
// the power matrix at alpha[k], recomputed (into pow[k].alt()) where redo[k].
static void power_terms(int kern, const std::vector<arma::mat>& G, const double* alpha,
                        const std::vector<char>& redo, std::vector<Buf2<arma::mat> >& pow,
                        std::vector<const arma::mat*>& P) {
  for (size_t k = 0; k < G.size(); ++k) {
    if (!kernel_has_alpha(kern)) { P[k] = &G[k]; continue; }
    if (redo[k]) kernel_term(kern, G[k], alpha[k], pow[k].alt(), true);
    P[k] = redo[k] ? &pow[k].alt() : &pow[k].cur();
  }
}

// Recompute the blocks `t` touches into the scratch buffers, reading the
// current buffers for everything else; returns the new log-likelihood.
double SchurPosterior::evaluate(const Touch& t) {
  const double s2S = phi[iSigma2S];
  const double s2B = bias ? phi[iSigma2B] : 0.0;
  // D = sigma2S Ds is positive definite only for sigma2S > 0 (and sigma2R > 0).
  if (!(s2S > 0)) return R_NegInf;
  if (simNoise && !latent && !(phi[iSigma2R] > 0)) return R_NegInf;
  // the latent noise's GP prior
  double lpG = latent ? lpG_.cur() : 0.0;
  if (latent && t.latentLp && !latentPrior(t, lpG)) return R_NegInf;

  // Simulator block (the algebra's).
  double ldDs = ldDs_.cur(), zz = zz_.cur();
  if (!simUpdate(t, ldDs, zz)) return R_NegInf;

  // Experimental-input part of Rs(Xk,Xk).
  const arma::mat* Rkk = &Rkk_.cur();
  if (t.expDim) {
    power_terms(kernS_, Gf_, phi.memptr() + iAlphaS, t.simPow, Pfs_, ptrF_);
    kernel_combine(kernS_, ptrF_, phi.subvec(iThetaS, iThetaS + p - 1), Rkk_.alt(), true);
    level_scale(levels, phi.memptr() + iRhoS, Xu_, Xu_, Rkk_.alt(), true);
    Rkk = &Rkk_.alt();
  }

  // Q = Rkk - Bs' Ds^-1 Bs (lower) and wz = Bs' Ds^-1 ys.
  const arma::mat* Q = &Q_.cur();
  const arma::vec* wz = &wz_.cur();
  if (t.cross) {
    simCross(t, *Rkk, Q_.alt(), wz_.alt());
    Q = &Q_.alt(); wz = &wz_.alt();
  }

  // Bias correlation Rb over the experimental inputs (none without a bias).
  const arma::mat* Rb = &Rb_.cur();
  if (t.biasCorr && bias) {
    power_terms(kernB_, Gfb_.empty() ? Gf_ : Gfb_, phi.memptr() + iAlphaB, t.biasPow, Pfb_, ptrB_);
    kernel_combine(kernB_, ptrB_, phi.subvec(iThetaB, iThetaB + p - 1), Rb_.alt(), true);
    biasLevels(Xu_, srcU_.data(), Xu_, srcU_.data(), Rb_.alt(), true);
    if (!biasModel(Rb_.alt(), Bz_, Wz_)) return R_NegInf;
    Rb = &Rb_.alt();
  }

  // Schur complement S and its factor (fieldFactor()).
  const FieldFactor* FS = &FS_.cur();
  double ldS = ldS_.cur();
  if (t.field) {
    if (!fieldFactor(*Q, Rb, s2S, s2B, ldS)) return R_NegInf;
    FS = &FS_.alt();
  }

  // Residual of the field block given the simulator block.
  const double muB = biasMean ? phi[iMuB] : 0.0;
  for (int j = 0; j < n; ++j) u_[j] = yf_[j] - muB - (*wz)[grp_[j]];
  FS->whiten(u_, grp_);
  return loglik(ldDs, zz, ldS, arma::dot(u_, u_), lpG);
}

// Make the scratch buffers written by evaluate(t) current.
void SchurPosterior::flip(const Touch& t) {
  simFlip(t);
  for (int k = 0; k < p; ++k) {
    if (t.simPow[k]) Pfs_[k].flip();
    if (t.biasPow[k]) Pfb_[k].flip();
  }
  if (t.expDim) Rkk_.flip();
  if (t.cross) { Q_.flip(); wz_.flip(); }
  if (t.biasCorr) Rb_.flip();
  if (t.field || t.scale) FS_.flip();
  if (t.latentK) { Lg_.flip(); ldG_.flip(); }
  ldDs_.flip(); zz_.flip(); ldS_.flip(); vv_.flip(); loglik_.flip(); lpG_.flip();
}

// s2S Rs(X, Y) over the p + q inputs at ph (the levels' correlations too).
void SchurPosterior::runPrior(const arma::vec& ph, const arma::mat& X, const arma::mat& Y,
                              arma::mat& K) const {
  K = corr_matrix(X, Y, ph.subvec(iThetaS, iThetaS + p + q - 1),
                  ph.subvec(iAlphaS, iAlphaS + p + q - 1), kernS_);
  level_scale(levels, ph.memptr() + iRhoS, X, Y, K, false);
  K *= ph[iSigma2S];
}

// With y = (ys, yf) and C = [D B; B' A] (D = s2S Ds), L = [D^1/2 0; B'D^-1/2 LS]
// (LS the Schur complement's factor) is a square root of C, and for points
// Z with k = Cov(ys, eta(Z)) = s2S Rs(Xs, Z), kf = Cov(yf, .):
//   L^-1 Cov(y, .) = [ sqrt(s2S) W ; LS^-1 (kf - s2S G) ]   (simWhiten()),
//   L^-1 (y - E y) = [ wy / sqrt(s2S) ; LS^-1 (yf - muB - wz) ];
// kf = s2S Rs(Xk, Z) for the simulator's values, plus s2B Rb(Xf, x)
// (biasCross()) for the targets' zeta. Means: the products of the two.
void SchurPosterior::runConditional(const arma::mat& U, const arma::mat& XT,
                                    RunConditional& out) {
  const double s2S = phi[iSigma2S], rs = std::sqrt(s2S);
  const double s2B = bias ? phi[iSigma2B] : 0.0, muB = biasMean ? phi[iMuB] : 0.0;
  arma::mat Xk(nu_, p + q);
  Xk.cols(0, p - 1) = Xu_;
  for (int k = 0; k < q; ++k) Xk.col(p + k).fill(phi[iKappa + k]);
  const arma::vec v = field_residual(FS_.cur(), yf_, muB, wz_.cur(), grp_);
  arma::vec wy;
  auto root = [&](const arma::mat& Z, const arma::mat* Kb, arma::mat& W, bool haveW,
                  arma::mat& A) {
    arma::mat G, R;
    simWhiten(Z, W, wy, G, haveW);
    runPrior(phi, Xk, Z, R);
    R -= s2S * G;
    if (Kb) R += s2B * *Kb;
    A = arma::join_cols(rs * W, field_rows(FS_.cur(), R, grp_));
  };
  // the runs' part at the candidates (runW_, runWy_) depends on the
  // simulator's correlation parameters alone: kept from the last call
  // while they and the candidates are the same (the plug-in's particles
  // differ in kappa alone)
  const int nl = level_count(levels);
  arma::vec key(2 * (p + q) + nl);
  for (int k = 0; k < p + q; ++k) { key[k] = phi[iThetaS + k]; key[p + q + k] = phi[iAlphaS + k]; }
  for (int k = 0; k < nl; ++k) key[2 * (p + q) + k] = phi[iRhoS + k];
  const bool have = runKey_.n_elem == key.n_elem && arma::all(runKey_ == key) &&
                    runU_.n_rows == U.n_rows && runU_.n_cols == U.n_cols && arma::all(arma::vectorise(runU_ == U));
  if (have) wy = runWy_;
  root(U, nullptr, runW_, have, out.A);
  if (!have) { runKey_ = key; runU_ = U; runWy_ = wy; }
  const arma::vec res = arma::join_cols(wy / rs, v);
  out.mu = out.A.t() * res;
  out.v0.set_size(U.n_rows);
  out.v0.fill(s2S * (1.0 + nugget_));
  out.v = out.v0 - arma::sum(arma::square(out.A), 0).t();
  if (XT.n_rows == 0) return;
  arma::mat Zt(XT.n_rows, p + q), Kb, AT, R;
  Zt.cols(0, p - 1) = XT;
  for (int k = 0; k < q; ++k) Zt.col(p + k).fill(phi[iKappa + k]);
  arma::vec rb(XT.n_rows, arma::fill::zeros);
  if (bias) biasCross(XT, Kb, rb);
  arma::mat WT;
  root(Zt, bias ? &Kb : nullptr, WT, false, AT);
  out.mT = muB + AT.t() * res;
  out.VT = s2S + s2B * rb - arma::sum(arma::square(AT), 0).t();
  runPrior(phi, Zt, U, R);
  out.CTU = R - AT.t() * out.A;
}
