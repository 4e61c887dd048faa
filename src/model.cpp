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

Posterior::Posterior(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                     const arma::vec& ys, double nugget)
  : Xf_(Xf), yf_(yf), Xs_(Xs), ys_(ys), nugget_(nugget) {
  n = Xf.n_rows; m = Xs.n_rows; p = Xf.n_cols; q = Xs.n_cols - p;
  iKappa = 0; iThetaS = q; iAlphaS = iThetaS + p + q; iThetaB = iAlphaS + p + q;
  iAlphaB = iThetaB + p; iSigma2S = iAlphaB + p; iSigma2B = iSigma2S + 1;
  iSigma2E = iSigma2B + 1; iMuB = iSigma2E + 1; d = iMuB + 1;
  phi.zeros(d);
  Ps_.resize(p + q); Px_.resize(p); Pfs_.resize(p); Pfb_.resize(p);
  for (int b = 0; b < 2; ++b) {
    for (int k = 0; k < p + q; ++k) Ps_[k].b[b].zeros(m, m);
    for (int k = 0; k < p; ++k) {
      Px_[k].b[b].zeros(m, n); Pfs_[k].b[b].zeros(n, n); Pfb_[k].b[b].zeros(n, n);
    }
    Ls_.b[b].zeros(m, m); Rx_.b[b].zeros(m, n); Rkk_.b[b].zeros(n, n);
    W_.b[b].zeros(m, n); Q_.b[b].zeros(n, n); Rb_.b[b].zeros(n, n); LS_.b[b].zeros(n, n);
    z_.b[b].zeros(m); c_.b[b].zeros(m); wz_.b[b].zeros(n);
  }
  u_.zeros(n);
  ptrS_.resize(p + q); ptrX_.resize(p); ptrF_.resize(p); ptrB_.resize(p);
  Gs_.resize(p + q); Gx_.resize(p); Gf_.resize(p);
  for (int k = 0; k < p + q; ++k) {
    Gs_[k].zeros(m, m);
    log_dist(Xs.col(k), Xs.col(k), Gs_[k], true);
  }
  for (int k = 0; k < p; ++k) {
    Gx_[k].zeros(m, n); Gf_[k].zeros(n, n);
    log_dist(Xs.col(k), Xf.col(k), Gx_[k], false);
    log_dist(Xf.col(k), Xf.col(k), Gf_[k], true);
  }
}

// Map a parameter index to the blocks it touches.
Touch Posterior::touch_for(int j) const {
  Touch t;
  if (j < iThetaS) t.kappa = true;
  else if (j < iAlphaS) t.simDim = j - iThetaS;
  else if (j < iThetaB) { t.simDim = j - iAlphaS; t.simAlpha = true; }
  else if (j < iAlphaB) t.biasDim = j - iThetaB;
  else if (j < iSigma2S) { t.biasDim = j - iAlphaB; t.biasAlpha = true; }
  else if (j < iMuB) t.field = true;
  return t;  // muB: only the residual moves
}

bool Posterior::init(const arma::vec& phi0) {
  phi = phi0;
  Touch all; all.all = true;
  double ll = evaluate(all);
  if (!std::isfinite(ll)) return false;
  flip(all);
  return true;
}

double Posterior::propose(int j, double value) {
  oldj_ = j; old_ = phi[j]; phi[j] = value;
  touch_ = touch_for(j);
  return evaluate(touch_);
}

double Posterior::proposeSim(const arma::vec& values) {
  const int k = 2 * (p + q);
  oldSim_ = phi.subvec(iThetaS, iThetaS + k - 1);
  phi.subvec(iThetaS, iThetaS + k - 1) = values.head(k);
  touch_ = Touch(); touch_.simAll = true;
  oldj_ = -1;
  return evaluate(touch_);
}

void Posterior::accept() { flip(touch_); }
void Posterior::reject() {
  if (oldj_ >= 0) phi[oldj_] = old_;
  else phi.subvec(iThetaS, iThetaS + oldSim_.n_elem - 1) = oldSim_;
}

// Recompute the blocks `t` touches into the scratch buffers, reading the
// current buffers for everything else; returns the new log-likelihood.
double Posterior::evaluate(const Touch& t) {
  const double s2S = phi[iSigma2S], s2B = phi[iSigma2B], s2E = phi[iSigma2E];
  // D = sigma2S Ds is positive definite only for sigma2S > 0.
  if (!(s2S > 0)) return R_NegInf;
  const arma::vec thetaS = phi.subvec(iThetaS, iAlphaS - 1);
  const arma::vec alphaS = phi.subvec(iAlphaS, iThetaB - 1);
  const bool simCorr = t.simCorr(), expDim = t.expDim(p), cChange = t.cChange(p);
  const bool biasCorr = t.biasCorr(), cross = t.cross(), field = t.fieldBlock();

  // Simulator block: Ds = Rs(Xs,Xs) + nugget I, Ls = chol(Ds), z = Ls^-1 ys.
  const arma::mat* Ls = &Ls_.cur();
  const arma::vec* z = &z_.cur();
  double ldDs = ldDs_.cur(), zz = zz_.cur();
  if (simCorr) {
    std::vector<const arma::mat*>& P = ptrS_;
    for (int k = 0; k < p + q; ++k) {
      const bool redo = t.simPow(k);
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
      const bool redo = t.simPow(k);
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
    for (int j = 0; j < n; ++j) {
      const double* rx = Rx->colptr(j);
      double* w = Wn.colptr(j);
      for (int i = 0; i < m; ++i) w[i] = (*c)[i] * rx[i];
    }
    solve_lower(*Ls, Wn);
    arma::vec& wzn = wz_.alt();
    for (int j = 0; j < n; ++j) wzn[j] = arma::dot(Wn.col(j), *z);
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
      const bool redo = t.biasPow(k);
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
    arma::mat& S = LS_.alt();
    for (int j = 0; j < n; ++j) {
      const double* qc = Q->colptr(j);
      const double* rb = Rb->colptr(j);
      double* sc = S.colptr(j);
      for (int i = j; i < n; ++i) sc[i] = s2S * qc[i] + s2B * rb[i];
      sc[j] += s2E;
    }
    if (!chol_lower(S)) return R_NegInf;
    ldS = logdet_chol(S);
    LS = &S;
  }

  // Residual of the field block given the simulator block.
  const double muB = phi[iMuB];
  for (int j = 0; j < n; ++j) u_[j] = yf_[j] - muB - (*wz)[j];
  solve_lower(*LS, u_);
  const double vv = arma::dot(u_, u_);

  ldDs_.alt() = ldDs; zz_.alt() = zz; ldS_.alt() = ldS; vv_.alt() = vv;
  const double ll = -0.5 * ((n + m) * LOG_2PI + m * std::log(s2S) + ldDs + ldS +
                            zz / s2S + vv);
  loglik_.alt() = ll;
  return ll;
}

// Make the scratch buffers written by evaluate(t) current.
void Posterior::flip(const Touch& t) {
  const bool simCorr = t.simCorr(), expDim = t.expDim(p), cChange = t.cChange(p);
  const bool biasCorr = t.biasCorr(), cross = t.cross(), field = t.fieldBlock();
  for (int k = 0; k < p + q; ++k)
    if (t.simPow(k)) {
      Ps_[k].flip();
      if (k < p) { Px_[k].flip(); Pfs_[k].flip(); }
    }
  for (int k = 0; k < p; ++k)
    if (t.biasPow(k)) Pfb_[k].flip();
  if (simCorr) { Ls_.flip(); z_.flip(); }
  if (expDim) { Rx_.flip(); Rkk_.flip(); }
  if (cChange) c_.flip();
  if (cross) { W_.flip(); Q_.flip(); wz_.flip(); }
  if (biasCorr) Rb_.flip();
  if (field) LS_.flip();
  ldDs_.flip(); zz_.flip(); ldS_.flip(); vv_.flip(); loglik_.flip();
}

arma::vec Posterior::resid() const {
  arma::vec u = yf_ - phi[iMuB] - wz_.cur();
  solve_lower(LS_.cur(), u);
  return u;
}

// Log-likelihood at each row of `phis`, reached by one-parameter moves from
// the previous row (every changed coordinate proposed and accepted in turn),
// so that the cached block updates can be checked against a dense formula.
// blockSim: thetaS/alphaS change through one joint move (proposeSim);
// decoys: before each move, propose a different value and reject it.
// [[Rcpp::export(.loglik_path)]]
Rcpp::NumericVector loglik_path(const arma::mat& Xf, const arma::vec& yf,
                                const arma::mat& Xs, const arma::vec& ys,
                                const arma::mat& phis, double nugget,
                                bool blockSim = false, bool decoys = false) {
  Posterior post(Xf, yf, Xs, ys, nugget);
  Rcpp::NumericVector out(phis.n_rows, NA_REAL);
  if (!post.init(phis.row(0).t())) return out;
  out[0] = post.logLik();
  const int s0 = post.iThetaS, s1 = post.iThetaB;
  for (arma::uword r = 1; r < phis.n_rows; ++r) {
    double ll = post.logLik();
    const arma::vec row = phis.row(r).t();
    if (blockSim && arma::any(row.subvec(s0, s1 - 1) != post.phi.subvec(s0, s1 - 1))) {
      const arma::vec vals = row.subvec(s0, s1 - 1);
      if (decoys) {
        post.proposeSim(0.5 * (vals + post.phi.subvec(s0, s1 - 1)) + 0.01);
        post.reject();
      }
      ll = post.proposeSim(vals);
      if (!std::isfinite(ll)) { post.reject(); return out; }
      post.accept();
    }
    for (int j = 0; j < post.d; ++j) {
      if (row[j] == post.phi[j]) continue;
      if (decoys) {
        post.propose(j, 0.5 * (row[j] + post.phi[j]) + 0.01);
        post.reject();
      }
      ll = post.propose(j, row[j]);
      if (!std::isfinite(ll)) { post.reject(); return out; }
      post.accept();
    }
    out[r] = ll;
  }
  return out;
}
