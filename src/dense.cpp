// The dense simulator algebra: Ds = Rs(Xs,Xs) + nugget I, Ls = chol(Ds),
// z = Ls^-1 ys, W = Ls^-1 Bs with Bs = Rs(Xs,Xk) = diag(c) Rx:
//   log|Ds| = 2 sum log diag(Ls),  ys' Ds^-1 ys = z'z,
//   Q = Rkk - W'W,  wz = W'z.
// While 3 (p + q) m^2 doubles fit in fbc_cache_budget bytes ((p + q) m^2 for
// a family without a smoothness, whose terms are the distances themselves),
// the per-dimension log-distances (or distances) and power matrices of
// Rs(Xs,Xs) and Rx are kept (a move of thetaS_k then costs no exp per
// dimension); beyond it the
// correlation is formed on the fly with the same operations (the same
// numbers), reading the packed log-distances of the first min(p + q, 4)
// inputs (at most 2 m (m + 1) doubles: no logs for those), so the algebra
// holds about 4 m x m doubles (Ls, its proposal, the packed caches) plus
// O((p + n) m) whatever p + q is.
#include "fbc.h"

double fbc_cache_budget = 16.0 * 1024 * 1024;

// Set the cache budget (bytes); returns the previous one. For tests and
// benchmarks: a budget of 0 forces the on-the-fly path.
// [[Rcpp::export(.fbc_cache_budget)]]
double fbc_cache_budget_r(double bytes = -1) {
  const double old = fbc_cache_budget;
  if (bytes >= 0) fbc_cache_budget = bytes;
  return old;
}

DensePosterior::DensePosterior(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                               const arma::vec& ys, double nugget, const Model& model)
  : SchurPosterior(Xf, yf, Xs, ys, nugget, model) {
  // per input: the distances and, for a family with a smoothness, two power
  // matrices (current and proposal)
  const bool smooth = kernel_has_alpha(kernS_);
  cached_ = (smooth ? 3.0 : 1.0) * (p + q) * (double) m * m * sizeof(double) <= fbc_cache_budget;
  for (int b = 0; b < 2; ++b) {
    Ls_.b[b].zeros(m, m); Rx_.b[b].zeros(m, nu_); W_.b[b].zeros(m, nu_);
    z_.b[b].zeros(m); c_.b[b].zeros(m);
  }
  if (!cached_) {
    const int K = std::min(p + q, 4);
    Gp_.resize(K); ptrG_.resize(K);
    for (int k = 0; k < K; ++k) {
      kernel_dist_packed(kernS_, Xs.col(k), Gp_[k]);
      ptrG_[k] = Gp_[k].data();
    }
    return;
  }
  if (smooth) {
    Ps_.resize(p + q); Px_.resize(p);
    for (int b = 0; b < 2; ++b) {
      for (int k = 0; k < p + q; ++k) Ps_[k].b[b].zeros(m, m);
      for (int k = 0; k < p; ++k) Px_[k].b[b].zeros(m, nu_);
    }
  }
  ptrS_.resize(p + q); ptrX_.resize(p);
  Gs_.resize(p + q); Gx_.resize(p);
  for (int k = 0; k < p + q; ++k) {
    Gs_[k].zeros(m, m);
    kernel_dist(kernS_, Xs.col(k), Xs.col(k), Gs_[k], true);
  }
  for (int k = 0; k < p; ++k) {
    Gx_[k].zeros(m, nu_);
    kernel_dist(kernS_, Xs.col(k), Xu_.col(k), Gx_[k], false);
  }
}

bool DensePosterior::simUpdate(const Touch& t, double& ldDs, double& zz) {
  const arma::vec thetaS = phi.subvec(iThetaS, iThetaS + p + q - 1);
  const arma::vec alphaS = phi.subvec(iAlphaS, iAlphaS + p + q - 1);
  // Ds, Ls = chol(Ds), z = Ls^-1 ys.
  if (t.simCorr) {
    arma::mat& L = Ls_.alt();
    if (cached_) {
      for (int k = 0; k < p + q; ++k) {
        const bool redo = t.simPow[k];
        if (Ps_.empty()) { ptrS_[k] = &Gs_[k]; continue; }  // no smoothness: P = G
        if (redo) kernel_term(kernS_, Gs_[k], alphaS[k], Ps_[k].alt(), true);
        ptrS_[k] = redo ? &Ps_[k].alt() : &Ps_[k].cur();
      }
      kernel_combine(kernS_, ptrS_, thetaS, L, true);
    } else {
      kernel_corr_self(kernS_, Xs_, p + q, thetaS.memptr(), alphaS.memptr(), ptrG_, L);
    }
    level_scale(levels, phi.memptr() + iRhoS, Xs_, Xs_, L, true);
    if (latent) {
      // ... exp(gR_i) / n_i with an input-dependent noise
      const double s2S = phi[iSigma2S];
      for (int i = 0; i < m; ++i) L.at(i, i) += nugget_ + meanNoise(i) / s2S;
    } else if (simNoise) {
      // the unique runs' means: their noise variance sigma2R / n_i, in
      // units of sigma2S
      const double ratio = phi[iSigma2R] / phi[iSigma2S];
      for (int i = 0; i < m; ++i) L.at(i, i) += nugget_ + ratio * repInv[i];
    } else {
      for (int i = 0; i < m; ++i) L.at(i, i) += nugget_;
    }
    if (!chol_lower(L)) return false;
    ldDs = logdet_chol(L);
    arma::vec& zn = z_.alt();
    zn = ys_;
    solve_lower(L, zn);
    zz = arma::dot(zn, zn);
  }
  // Experimental-input part Rx of Rs(Xs,Xk).
  if (t.expDim) {
    if (cached_) {
      for (int k = 0; k < p; ++k) {
        const bool redo = t.simPow[k];
        if (Px_.empty()) { ptrX_[k] = &Gx_[k]; continue; }
        if (redo) kernel_term(kernS_, Gx_[k], alphaS[k], Px_[k].alt(), false);
        ptrX_[k] = redo ? &Px_[k].alt() : &Px_[k].cur();
      }
      const arma::vec th = thetaS.head(p);
      kernel_combine(kernS_, ptrX_, th, Rx_.alt(), false);
    } else {
      kernel_corr(kernS_, Xs_, Xu_, p, thetaS.memptr(), alphaS.memptr(), Rx_.alt(), false);
    }
    level_scale(levels, phi.memptr() + iRhoS, Xs_, Xu_, Rx_.alt(), false);
  }
  // Calibration-input factor c_i = R_cal(xs_i, kappa).
  if (t.cChange)
    kernel_corr_point(kernS_, Xs_, p, q, phi.memptr() + iKappa, thetaS.memptr() + p,
                      alphaS.memptr() + p, c_.alt());
  return true;
}

// W = Ls^-1 diag(c) Rx, wz = W'z, Q = Rkk - W'W (lower).
void DensePosterior::simCross(const Touch& t, const arma::mat& Rkk, arma::mat& Q,
                              arma::vec& wz) {
  const arma::mat& Ls = t.simCorr ? Ls_.alt() : Ls_.cur();
  const arma::vec& z = t.simCorr ? z_.alt() : z_.cur();
  const arma::mat& Rx = t.expDim ? Rx_.alt() : Rx_.cur();
  const arma::vec& c = t.cChange ? c_.alt() : c_.cur();
  arma::mat& Wn = W_.alt();
  for (int j = 0; j < nu_; ++j) {
    const double* rx = Rx.colptr(j);
    double* w = Wn.colptr(j);
    for (int i = 0; i < m; ++i) w[i] = c[i] * rx[i];
  }
  solve_lower(Ls, Wn);
  for (int j = 0; j < nu_; ++j) wz[j] = arma::dot(Wn.col(j), z);
  Q = Rkk;
  syrk_lower(Wn, -1.0, 1.0, Q);
}

void DensePosterior::simFlip(const Touch& t) {
  if (cached_ && !Ps_.empty())
    for (int k = 0; k < p + q; ++k)
      if (t.simPow[k]) {
        Ps_[k].flip();
        if (k < p) Px_[k].flip();
      }
  if (t.simCorr) { Ls_.flip(); z_.flip(); }
  if (t.expDim) Rx_.flip();
  if (t.cChange) c_.flip();
  if (t.cross) W_.flip();
}

// K = Ls^-1 Rs(Xs, xk*): a = K'z, b = colsums(K^2), G = W'K.
void DensePosterior::simCondition(const arma::mat& Xnew, arma::vec& a, arma::vec& b,
                                  arma::mat& G) {
  const int nb = Xnew.n_rows;
  arma::mat xk(nb, p + q);
  xk.cols(0, p - 1) = Xnew;
  for (int j = 0; j < q; ++j) xk.col(p + j).fill(phi[iKappa + j]);
  K_ = corr_matrix(Xs_, xk, phi.subvec(iThetaS, iThetaS + p + q - 1), phi.subvec(iAlphaS, iAlphaS + p + q - 1),
                   kernS_);
  level_scale(levels, phi.memptr() + iRhoS, Xs_, xk, K_, false);
  solve_lower(Ls_.cur(), K_);
  const arma::vec& z = z_.cur();
  for (int c = 0; c < nb; ++c) {
    const double* k = K_.colptr(c);
    double kz = 0.0, kk = 0.0;
    for (int i = 0; i < m; ++i) { kz += k[i] * z[i]; kk += k[i] * k[i]; }
    a[c] = kz; b[c] = kk;
  }
  G = W_.cur().t() * K_;
}

// Li = Ls^-1 (a triangular inverse), so Ds^-1 = Li' Li: a = Li' z and
// (Ds^-1)_BB = Li_B' Li_B with Li_B the columns B of Li.
void DensePosterior::simHeldout(const std::vector<std::vector<int> >& folds, arma::vec& a,
                                std::vector<arma::mat>& QBB) {
  const arma::mat Li = arma::inv(arma::trimatl(Ls_.cur()));
  a = Li.t() * z_.cur();
  QBB.resize(folds.size());
  for (size_t k = 0; k < folds.size(); ++k) {
    const arma::mat LB = Li.cols(arma::conv_to<arma::uvec>::from(folds[k]));
    QBB[k] = LB.t() * LB;
  }
}

// W = Ls^-1 Rs(Xs, Z), wy = Ls^-1 ys, G = (Ls^-1 Rs(Xs,Xk))' W.
void DensePosterior::simWhiten(const arma::mat& Z, arma::mat& W, arma::vec& wy, arma::mat& G,
                               bool haveW) {
  if (!haveW) {
    W = corr_matrix(Xs_, Z, phi.subvec(iThetaS, iThetaS + p + q - 1),
                    phi.subvec(iAlphaS, iAlphaS + p + q - 1), kernS_);
    level_scale(levels, phi.memptr() + iRhoS, Xs_, Z, W, false);
    solve_lower(Ls_.cur(), W);
    wy = z_.cur();
  }
  G = W_.cur().t() * W;
}
