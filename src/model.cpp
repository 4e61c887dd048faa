// The Cholesky log-likelihood of the KOH model through its block structure.
//
// With y = (yf, ys), residual r = (yf - muB, ys), Ds = Rs(Xs,Xs) + nugget I,
// Ls = chol(Ds), z = Ls^-1 ys, W = Ls^-1 Rs(Xs,Xk) and
//   S = sigma2S (Rs(Xk,Xk) - W'W) + sigma2B Rb + sigma2E I   (Schur complement),
// LS = chol(S), v = LS^-1 (yf - muB - W'z):
//   log L = -0.5 [ (n+m) log 2pi + m log sigma2S + log|Ds| + log|S|
//                  + z'z / sigma2S + v'v ].
// Because every field row shares kappa, Rs(Xs,Xk) = diag(c) Rx with
// Rx the correlation over the p experimental inputs and
// c_i = exp(-sum_l thetaS_{p+l} |xs_{i,p+l} - kappa_l|^alphaS_{p+l}), and
// Rs(Xk,Xk) involves the experimental inputs only.
#include "fbc.h"

static const double LOG_2PI = 1.837877066409345483560659472811;

void Posterior::set_sizes(int n_, int m_, int p_, int q_) {
  n = n_; m = m_; p = p_; q = q_;
  iKappa = 0; iThetaS = q; iAlphaS = iThetaS + p + q; iThetaB = iAlphaS + p + q;
  iAlphaB = iThetaB + p; iSigma2S = iAlphaB + p; iSigma2B = iSigma2S + 1;
  iSigma2E = iSigma2B + 1; iMuB = iSigma2E + 1; d = iMuB + 1;
  phi.zeros(d);
}

std::unique_ptr<Posterior> make_posterior(const arma::mat& Xf, const arma::vec& yf,
                                          const arma::mat& Xs, const arma::vec& ys,
                                          double nugget) {
  return std::unique_ptr<Posterior>(new DensePosterior(Xf, yf, Xs, ys, nugget));
}

DensePosterior::DensePosterior(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                               const arma::vec& ys, double nugget)
  : Xf_(Xf), yf_(yf), Xs_(Xs), ys_(ys), nugget_(nugget) {
  set_sizes(Xf.n_rows, Xs.n_rows, Xf.n_cols, Xs.n_cols - Xf.n_cols);
  touch_.reset(p + q, p);
  // Distinct field input rows: replicates share their columns of Rs(Xs,Xk),
  // Rs(Xk,Xk) and Rb, so those are computed for the nu distinct rows only
  // (row i of Xf is row grp_[i] of Xu_).
  grp_.resize(n);
  std::vector<int> first;
  for (int i = 0; i < n; ++i) {
    int g = -1;
    for (size_t u = 0; u < first.size() && g < 0; ++u)
      if (arma::all(Xf.row(i) == Xf.row(first[u]))) g = u;
    if (g < 0) { g = first.size(); first.push_back(i); }
    grp_[i] = g;
  }
  nu_ = first.size();
  Xu_.set_size(nu_, p);
  for (int u = 0; u < nu_; ++u) Xu_.row(u) = Xf.row(first[u]);
  Ps_.resize(p + q); Px_.resize(p); Pfs_.resize(p); Pfb_.resize(p);
  for (int b = 0; b < 2; ++b) {
    for (int k = 0; k < p + q; ++k) Ps_[k].b[b].zeros(m, m);
    for (int k = 0; k < p; ++k) {
      Px_[k].b[b].zeros(m, nu_); Pfs_[k].b[b].zeros(nu_, nu_); Pfb_[k].b[b].zeros(nu_, nu_);
    }
    Ls_.b[b].zeros(m, m); Rx_.b[b].zeros(m, nu_); Rkk_.b[b].zeros(nu_, nu_);
    W_.b[b].zeros(m, nu_); Q_.b[b].zeros(nu_, nu_); Rb_.b[b].zeros(nu_, nu_);
    LS_.b[b].zeros(n, n);
    z_.b[b].zeros(m); c_.b[b].zeros(m); wz_.b[b].zeros(nu_);
  }
  u_.zeros(n);
  ptrS_.resize(p + q); ptrX_.resize(p); ptrF_.resize(p); ptrB_.resize(p);
  Gs_.resize(p + q); Gx_.resize(p); Gf_.resize(p);
  for (int k = 0; k < p + q; ++k) {
    Gs_[k].zeros(m, m);
    log_dist(Xs.col(k), Xs.col(k), Gs_[k], true);
  }
  for (int k = 0; k < p; ++k) {
    Gx_[k].zeros(m, nu_); Gf_[k].zeros(nu_, nu_);
    log_dist(Xs.col(k), Xu_.col(k), Gx_[k], false);
    log_dist(Xu_.col(k), Xu_.col(k), Gf_[k], true);
  }
}

// Add what a move of parameter j touches to t.
void DensePosterior::add_touch(int j, Touch& t) const {
  if (j < iThetaS) {                       // kappa
    t.cChange = t.cross = t.field = true;
  } else if (j < iThetaB) {                // thetaS, alphaS
    const bool alpha = j >= iAlphaS;
    const int k = alpha ? j - iAlphaS : j - iThetaS;
    if (alpha) t.simPow[k] = 1;
    t.simCorr = t.cross = t.field = true;
    if (k < p) t.expDim = true; else t.cChange = true;
  } else if (j < iSigma2S) {               // thetaB, alphaB
    const bool alpha = j >= iAlphaB;
    const int k = alpha ? j - iAlphaB : j - iThetaB;
    if (alpha) t.biasPow[k] = 1;
    t.biasCorr = t.field = true;
  } else if (j < iMuB) {                   // sigma2S, sigma2B, sigma2E
    t.field = true;
  }                                        // muB: only the residual moves
}

bool DensePosterior::init(const arma::vec& phi0) {
  phi = phi0;
  Touch all; all.everything(p + q, p);
  double ll = evaluate(all);
  if (!std::isfinite(ll)) return false;
  flip(all);
  return true;
}

double DensePosterior::propose(const std::vector<int>& idx, const arma::vec& values) {
  const int k = idx.size();
  oldIdx_ = idx;
  oldVal_.set_size(k);
  touch_.reset(p + q, p);
  for (int i = 0; i < k; ++i) {
    oldVal_[i] = phi[idx[i]];
    phi[idx[i]] = values[i];
    add_touch(idx[i], touch_);
  }
  return evaluate(touch_);
}

// C -> c C: log|Ds| and z'z are unchanged, S -> c S (LS -> sqrt(c) LS,
// log|S| + n log c, v'v / c) and sigma2S -> c sigma2S.
double DensePosterior::proposeScale(double c) {
  oldIdx_.assign({iSigma2S, iSigma2B, iSigma2E});
  oldVal_ = {phi[iSigma2S], phi[iSigma2B], phi[iSigma2E]};
  touch_.reset(p + q, p);
  touch_.scale = true;
  phi[iSigma2S] *= c; phi[iSigma2B] *= c; phi[iSigma2E] *= c;
  const double s2S = phi[iSigma2S];
  if (!(s2S > 0) || !std::isfinite(c)) return R_NegInf;
  const double ldDs = ldDs_.cur(), zz = zz_.cur();
  const double ldS = ldS_.cur() + n * std::log(c), vv = vv_.cur() / c;
  ldDs_.alt() = ldDs; zz_.alt() = zz; ldS_.alt() = ldS; vv_.alt() = vv;
  const double ll = -0.5 * ((n + m) * LOG_2PI + m * std::log(s2S) + ldDs + ldS +
                            zz / s2S + vv);
  loglik_.alt() = ll;
  return ll;
}

void DensePosterior::accept() {
  if (touch_.scale) {
    const double c = phi[iSigma2S] / oldVal_[0];
    LS_.alt() = std::sqrt(c) * LS_.cur();
  }
  flip(touch_);
}

void DensePosterior::reject() {
  for (size_t i = 0; i < oldIdx_.size(); ++i) phi[oldIdx_[i]] = oldVal_[i];
}

void DensePosterior::muBQuadratic(double& aa, double& ab) const {
  arma::vec a(n, arma::fill::ones);
  arma::vec b(n);
  const arma::vec& wz = wz_.cur();
  for (int i = 0; i < n; ++i) b[i] = yf_[i] - wz[grp_[i]];
  solve_lower(LS_.cur(), a);
  solve_lower(LS_.cur(), b);
  aa = arma::dot(a, a);
  ab = arma::dot(a, b);
}

// GP conditional through the block factors: g = Ls^-1 ks,
// h = LS^-1 (kf - W'g), mean = mu0 + g'z / s2S + h'v, var = v0 - g'g / s2S - h'h
// (ks and kf already carry their variances; v = LS^-1 (yf - muB - W'z)).
void DensePosterior::condition(const arma::mat& ks, const arma::mat& kf, double mu0,
                               double v0, double* mean, double* var) {
  const double s2S = phi[iSigma2S];
  const arma::vec& z = z_.cur();
  const arma::vec& wz = wz_.cur();
  arma::vec v(n);
  for (int i = 0; i < n; ++i) v[i] = yf_[i] - phi[iMuB] - wz[grp_[i]];
  solve_lower(LS_.cur(), v);
  G_ = ks;
  solve_lower(Ls_.cur(), G_);
  const arma::mat T = W_.cur().t() * G_;  // distinct field rows
  A_ = kf;
  for (arma::uword c = 0; c < A_.n_cols; ++c)
    for (int i = 0; i < n; ++i) A_(i, c) -= T(grp_[i], c);
  solve_lower(LS_.cur(), A_);
  for (arma::uword c = 0; c < G_.n_cols; ++c) {
    const double* g = G_.colptr(c);
    const double* h = A_.colptr(c);
    double gz = 0.0, gg = 0.0, hv = 0.0, hh = 0.0;
    for (arma::uword k = 0; k < G_.n_rows; ++k) { gz += g[k] * z[k]; gg += g[k] * g[k]; }
    for (int k = 0; k < n; ++k) { hv += h[k] * v[k]; hh += h[k] * h[k]; }
    mean[c] = mu0 + gz / s2S + hv;
    var[c] = v0 - gg / s2S - hh;
  }
}

// Recompute the blocks `t` touches into the scratch buffers, reading the
// current buffers for everything else; returns the new log-likelihood.
double DensePosterior::evaluate(const Touch& t) {
  const double s2S = phi[iSigma2S], s2B = phi[iSigma2B], s2E = phi[iSigma2E];
  // D = sigma2S Ds is positive definite only for sigma2S > 0.
  if (!(s2S > 0)) return R_NegInf;
  const arma::vec thetaS = phi.subvec(iThetaS, iAlphaS - 1);
  const arma::vec alphaS = phi.subvec(iAlphaS, iThetaB - 1);
  const bool simCorr = t.simCorr, expDim = t.expDim, cChange = t.cChange;
  const bool biasCorr = t.biasCorr, cross = t.cross, field = t.field;

  // Simulator block: Ds = Rs(Xs,Xs) + nugget I, Ls = chol(Ds), z = Ls^-1 ys.
  const arma::mat* Ls = &Ls_.cur();
  const arma::vec* z = &z_.cur();
  double ldDs = ldDs_.cur(), zz = zz_.cur();
  if (simCorr) {
    std::vector<const arma::mat*>& P = ptrS_;
    for (int k = 0; k < p + q; ++k) {
      const bool redo = t.simPow[k];
      if (redo) pow_from_log(Gs_[k], alphaS[k], Ps_[k].alt(), true);
      P[k] = redo ? &Ps_[k].alt() : &Ps_[k].cur();
    }
    arma::mat& L = Ls_.alt();
    corr_from_pows(P, thetaS, L, true);
    for (int i = 0; i < m; ++i) L.at(i, i) += nugget_;
    if (!chol_lower(L)) return R_NegInf;
    ldDs = logdet_chol(L);
    arma::vec& zn = z_.alt();
    zn = ys_;
    solve_lower(L, zn);
    zz = arma::dot(zn, zn);
    Ls = &L; z = &zn;
  }

  // Experimental-input parts of Rs(Xs,Xk) and Rs(Xk,Xk).
  const arma::mat* Rx = &Rx_.cur();
  const arma::mat* Rkk = &Rkk_.cur();
  if (expDim) {
    std::vector<const arma::mat*>& Px = ptrX_;
    std::vector<const arma::mat*>& Pf = ptrF_;
    for (int k = 0; k < p; ++k) {
      const bool redo = t.simPow[k];
      if (redo) {
        pow_from_log(Gx_[k], alphaS[k], Px_[k].alt(), false);
        pow_from_log(Gf_[k], alphaS[k], Pfs_[k].alt(), true);
      }
      Px[k] = redo ? &Px_[k].alt() : &Px_[k].cur();
      Pf[k] = redo ? &Pfs_[k].alt() : &Pfs_[k].cur();
    }
    const arma::vec th = thetaS.head(p);
    corr_from_pows(Px, th, Rx_.alt(), false);
    corr_from_pows(Pf, th, Rkk_.alt(), true);
    Rx = &Rx_.alt(); Rkk = &Rkk_.alt();
  }

  // Calibration-input factor c_i.
  const arma::vec* c = &c_.cur();
  if (cChange) {
    arma::vec& cn = c_.alt();
    cn.zeros();
    for (int l = 0; l < q; ++l) {
      const double kap = phi[iKappa + l], th = thetaS[p + l], al = alphaS[p + l];
      const double* xs = Xs_.colptr(p + l);
      for (int i = 0; i < m; ++i) cn[i] += th * std::pow(std::fabs(xs[i] - kap), al);
    }
    for (int i = 0; i < m; ++i) cn[i] = std::exp(-cn[i]);
    c = &cn;
  }

  // W = Ls^-1 diag(c) Rx, wz = W'z, Q = Rkk - W'W (lower).
  const arma::mat* Q = &Q_.cur();
  const arma::vec* wz = &wz_.cur();
  if (cross) {
    arma::mat& Wn = W_.alt();
    for (int j = 0; j < nu_; ++j) {
      const double* rx = Rx->colptr(j);
      double* w = Wn.colptr(j);
      for (int i = 0; i < m; ++i) w[i] = (*c)[i] * rx[i];
    }
    solve_lower(*Ls, Wn);
    arma::vec& wzn = wz_.alt();
    for (int j = 0; j < nu_; ++j) wzn[j] = arma::dot(Wn.col(j), *z);
    arma::mat& Qn = Q_.alt();
    Qn = *Rkk;
    syrk_lower(Wn, -1.0, 1.0, Qn);
    Q = &Qn; wz = &wzn;
  }

  // Bias correlation Rb over the experimental inputs.
  const arma::mat* Rb = &Rb_.cur();
  if (biasCorr) {
    const arma::vec thetaB = phi.subvec(iThetaB, iAlphaB - 1);
    const arma::vec alphaB = phi.subvec(iAlphaB, iSigma2S - 1);
    std::vector<const arma::mat*>& P = ptrB_;
    for (int k = 0; k < p; ++k) {
      const bool redo = t.biasPow[k];
      if (redo) pow_from_log(Gf_[k], alphaB[k], Pfb_[k].alt(), true);
      P[k] = redo ? &Pfb_[k].alt() : &Pfb_[k].cur();
    }
    corr_from_pows(P, thetaB, Rb_.alt(), true);
    Rb = &Rb_.alt();
  }

  // Schur complement S and its factor.
  const arma::mat* LS = &LS_.cur();
  double ldS = ldS_.cur();
  if (field) {
    // S(i,j) = s2S Q(g_i,g_j) + s2B Rb(g_i,g_j) + s2E [i = j], from the
    // lower triangles of the distinct-row Q and Rb
    arma::mat& S = LS_.alt();
    for (int j = 0; j < n; ++j) {
      const int gj = grp_[j];
      double* sc = S.colptr(j);
      for (int i = j; i < n; ++i) {
        const int gi = grp_[i];
        const int r = std::max(gi, gj), c = std::min(gi, gj);
        sc[i] = s2S * Q->at(r, c) + s2B * Rb->at(r, c);
      }
      sc[j] += s2E;
    }
    if (!chol_lower(S)) return R_NegInf;
    ldS = logdet_chol(S);
    LS = &S;
  }

  // Residual of the field block given the simulator block.
  const double muB = phi[iMuB];
  for (int j = 0; j < n; ++j) u_[j] = yf_[j] - muB - (*wz)[grp_[j]];
  solve_lower(*LS, u_);
  const double vv = arma::dot(u_, u_);

  ldDs_.alt() = ldDs; zz_.alt() = zz; ldS_.alt() = ldS; vv_.alt() = vv;
  const double ll = -0.5 * ((n + m) * LOG_2PI + m * std::log(s2S) + ldDs + ldS +
                            zz / s2S + vv);
  loglik_.alt() = ll;
  return ll;
}

// Make the scratch buffers written by evaluate(t) current.
void DensePosterior::flip(const Touch& t) {
  const bool simCorr = t.simCorr, expDim = t.expDim, cChange = t.cChange;
  const bool biasCorr = t.biasCorr, cross = t.cross, field = t.field || t.scale;
  for (int k = 0; k < p + q; ++k)
    if (t.simPow[k]) {
      Ps_[k].flip();
      if (k < p) { Px_[k].flip(); Pfs_[k].flip(); }
    }
  for (int k = 0; k < p; ++k)
    if (t.biasPow[k]) Pfb_[k].flip();
  if (simCorr) { Ls_.flip(); z_.flip(); }
  if (expDim) { Rx_.flip(); Rkk_.flip(); }
  if (cChange) c_.flip();
  if (cross) { W_.flip(); Q_.flip(); wz_.flip(); }
  if (biasCorr) Rb_.flip();
  if (field) LS_.flip();
  ldDs_.flip(); zz_.flip(); ldS_.flip(); vv_.flip(); loglik_.flip();
}


// Log-likelihood at each row of `phis`, reached by moves from the previous
// row, so that the cached block updates can be checked against a dense
// formula. `groups[j]` > 0 puts parameter j in a group moved jointly (one
// propose() of the group's changed coordinates); 0 moves it alone.
// scale: when sigma2S, sigma2B, sigma2E all change by one factor, move them
// by proposeScale(). decoys: before each move, propose another value and
// reject it.
// [[Rcpp::export(.loglik_path)]]
Rcpp::NumericVector loglik_path(const arma::mat& Xf, const arma::vec& yf,
                                const arma::mat& Xs, const arma::vec& ys,
                                const arma::mat& phis, double nugget,
                                SEXP groups = R_NilValue,
                                bool decoys = false, bool scale = false) {
  std::unique_ptr<Posterior> pp = make_posterior(Xf, yf, Xs, ys, nugget);
  Posterior& post = *pp;
  Rcpp::NumericVector out(phis.n_rows, NA_REAL);
  if (!post.init(phis.row(0).t())) return out;
  out[0] = post.logLik();
  const int d = post.d;
  std::vector<int> grp(d, 0);
  if (!Rf_isNull(groups)) {
    const Rcpp::IntegerVector g(groups);
    for (int j = 0; j < std::min<int>(d, g.size()); ++j) grp[j] = g[j];
  }
  const int nG = *std::max_element(grp.begin(), grp.end());
  auto move = [&](const std::vector<int>& idx, const arma::vec& vals) {
    if (decoys) {
      arma::vec dv(vals.n_elem);
      for (size_t i = 0; i < idx.size(); ++i) dv[i] = 0.5 * (vals[i] + post.phi[idx[i]]) + 0.01;
      post.propose(idx, dv);
      post.reject();
    }
    const double ll = post.propose(idx, vals);
    if (!std::isfinite(ll)) { post.reject(); return false; }
    post.accept();
    return true;
  };
  for (arma::uword r = 1; r < phis.n_rows; ++r) {
    const arma::vec row = phis.row(r).t();
    if (scale) {
      const int a = post.iSigma2S;
      const double c = row[a] / post.phi[a];
      bool same = c != 1.0;
      for (int j = a; j < a + 3; ++j)
        same = same && std::fabs(row[j] / post.phi[j] - c) < 1e-12 * c;
      if (same) {
        if (decoys) { post.proposeScale(1.3); post.reject(); }
        if (!std::isfinite(post.proposeScale(c))) { post.reject(); return out; }
        post.accept();
        for (int j = a; j < a + 3; ++j) post.phi[j] = row[j];  // exact values
      }
    }
    for (int g = 1; g <= nG; ++g) {
      std::vector<int> idx;
      for (int j = 0; j < d; ++j) if (grp[j] == g && row[j] != post.phi[j]) idx.push_back(j);
      if (idx.empty()) continue;
      arma::vec vals(idx.size());
      for (size_t i = 0; i < idx.size(); ++i) vals[i] = row[idx[i]];
      if (!move(idx, vals)) return out;
    }
    for (int j = 0; j < d; ++j) {
      if (row[j] == post.phi[j]) continue;
      if (!move(std::vector<int>{j}, arma::vec{row[j]})) return out;
    }
    out[r] = post.logLik();
  }
  return out;
}
