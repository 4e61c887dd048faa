// The Kronecker simulator algebra on a product design: the m = I J
// simulator rows are every combination of I experimental settings Xg and J
// calibration settings Tg (any row order), so with Y the I x J reshaping of
// ys, Rx = Rs(Xg,Xg) over the p experimental inputs, Rt = Rs(Tg,Tg) over the
// q calibration inputs and their eigendecompositions Rx = Ux diag(lx) Ux',
// Rt = Ut diag(lt) Ut':
//   Ds = Rx (x) Rt + nugget I = (Ux (x) Ut) diag(lam) (Ux (x) Ut)',
//   lam_ij = lx_i lt_j + nugget (the nugget stays exact),
//   log|Ds| = sum_ij log lam_ij,  ys' Ds^-1 ys = sum_ij Yt_ij^2 / lam_ij,
//   Yt = Ux' Y Ut.
// Every field row shares kappa, so column u of Bs = Rs(Xs,Xk) is the
// Kronecker vector Rxf[, u] (x) c with Rxf = Rs(Xg, Xu) and c_j = R_cal(Tg_j,
// kappa); with Ax = Ux' Rxf and ct = Ut' c,
//   Bs' Ds^-1 Bs = Ax' diag(w) Ax,  w_i = sum_j ct_j^2 / lam_ij,
//   Bs' Ds^-1 ys = Ax' g,           g_i = sum_j ct_j Yt_ij / lam_ij:
// a kappa move costs O(J^2 + I J + I nu^2), a move of an experimental-input
// correlation parameter one I x I eigendecomposition, a calibration-input
// one a J x J eigendecomposition; nothing of size m x m is ever formed.
//
// Any other split of the d = p + q columns into groups A (I settings Xg)
// and B (J settings Tg) whose combinations are the runs (an output index A
// crossed with scattered run settings B that mix experimental and
// calibration inputs): Ds = Ra (x) Rb + nugget I the same way (Ux, lx of Ra,
// Ut, lt of Rb). Field row u is z_u = (x_u, kappa); by separability
// Rs(Xs, z_u) = Ra(Xg, z_u[A]) (x) Rb(Tg, z_u[B]), both factors varying with
// u when a group holds experimental and calibration columns. With
// Ax = Ux' Ra(Xg, Z[A]) (I x nu) and Bf = Ut' Rb(Tg, Z[B]) (J x nu),
//   W_(ij),u = Ax_iu Bf_ju / sqrt(lam_ij),  wy_ij = Yt_ij / sqrt(lam_ij),
//   Bs' Ds^-1 Bs = W'W,  Bs' Ds^-1 ys = W'wy:
// O(m nu^2) a cross update; a kappa move recomputes the factor of each
// group that holds calibration columns (O(J^2 nu) for B), a correlation
// move the eigendecomposition of its group.
#include "fbc.h"
#include <map>
#include <set>

// Exact-equality key of row r over columns c.
static std::vector<double> row_key(const arma::mat& X, arma::uword r, const arma::uvec& c) {
  std::vector<double> key(c.n_elem);
  for (arma::uword k = 0; k < c.n_elem; ++k) key[k] = X.at(r, c[k]);
  return key;
}

// Are the pairs (a[r], b[r]), a in 0 .. A-1 and b in 0 .. B-1, distinct
// (A, B >= 2)? Without `mi`: and every one of the A B combinations; with
// it: the combinations no row takes (the missing cells) into mi, mj.
static bool grid_cells(const std::vector<int>& a, int A, const std::vector<int>& b, int B,
                       std::vector<int>* mi = nullptr, std::vector<int>* mj = nullptr) {
  if (A < 2 || B < 2 || (!mi && (double) A * B != (double) a.size())) return false;
  std::vector<char> seen((size_t) A * B, 0);
  for (size_t r = 0; r < a.size(); ++r) {
    char& s = seen[(size_t) b[r] * A + a[r]];
    if (s) return false;
    s = 1;
  }
  if (mi) {
    mi->clear(); mj->clear();
    for (int j = 0; j < B; ++j)
      for (int i = 0; i < A; ++i)
        if (!seen[(size_t) j * A + i]) { mi->push_back(i); mj->push_back(j); }
  }
  return true;
}
static bool full_grid(const std::vector<int>& a, int A, const std::vector<int>& b, int B) {
  return grid_cells(a, A, b, B);
}

// Is Xs every combination of its distinct rows over columns ca and over cb
// (with `missing`: but for the cells out.mi, out.mj, at most as many as its
// rows)?
static bool grid_split(const arma::mat& Xs, const arma::uvec& ca, const arma::uvec& cb,
                       ProductDesign& out, bool missing = false) {
  const int m = Xs.n_rows;
  std::map<std::vector<double>, int> xs, ts;
  std::vector<int> ix(m), jt(m);
  for (int r = 0; r < m; ++r) {
    ix[r] = xs.emplace(row_key(Xs, r, ca), (int) xs.size()).first->second;
    jt[r] = ts.emplace(row_key(Xs, r, cb), (int) ts.size()).first->second;
  }
  const int I = xs.size(), J = ts.size();
  if ((double) I * J > 2.0 * m) return false;
  if (missing ? !grid_cells(ix, I, jt, J, &out.mi, &out.mj) : !full_grid(ix, I, jt, J))
    return false;
  if (!missing) { out.mi.clear(); out.mj.clear(); }
  out.I = I; out.J = J; out.ix = ix; out.jt = jt; out.ca = ca; out.cb = cb;
  out.Xg.set_size(I, ca.n_elem); out.Tg.set_size(J, cb.n_elem);
  for (int r = 0; r < m; ++r) {
    const arma::uvec row = {(arma::uword) r};
    out.Xg.row(ix[r]) = Xs.submat(row, ca);
    out.Tg.row(jt[r]) = Xs.submat(row, cb);
  }
  return true;
}

// Relative flops of a move of the simulator block: the two
// eigendecompositions (9 (I^3 + J^3)), with k missing cells their k x k
// system (missing_system(): K^2 I J + k^2 min(I, J) / 2 to form, K the
// distinct settings of the larger group among them; k^3 / 3 to factor),
// against one Cholesky factor of the m x m block of the runs (m^3 / 3),
// all times 3.
static double kron_cost(const ProductDesign& pd) {
  const double I = pd.I, J = pd.J, k = pd.mi.size();
  if (!k) return 27.0 * (I * I * I + J * J * J);
  const std::vector<int>& c = I <= J ? pd.mj : pd.mi;
  const double K = std::set<int>(c.begin(), c.end()).size();
  return 27.0 * (I * I * I + J * J * J) + 3.0 * K * K * I * J +
         1.5 * k * k * std::min(I, J) + k * k * k;
}

// The experimental x calibration split when it is a complete grid (the
// cheapest kappa moves: kappa sits in one group alone); else the cheapest
// split that pays among the experimental x calibration one with missing
// cells and, with `general`, every split of the d <= 12 columns into two
// groups (complete or not; a split is skipped at once when its columns'
// distinct values alone make more than 2 m cells).
bool product_design(const arma::mat& Xs, int p, ProductDesign& out, bool general) {
  const int m = Xs.n_rows, d = Xs.n_cols, q = d - p;
  if (p < 1 || q < 1 || m < 4) return false;
  const arma::uvec all = arma::regspace<arma::uvec>(0, d - 1);
  if (grid_split(Xs, all.head(p), all.tail(q), out) && kronecker_pays(out)) {
    out.classic = true;
    return true;
  }
  if (d > 12) general = false;
  if (!general && d > 30) return false;
  std::vector<double> nv(d);
  for (int k = 0; k < d; ++k) nv[k] = arma::vec(arma::unique(Xs.col(k))).n_elem;
  double best = arma::datum::inf;
  ProductDesign pd;
  const unsigned exc = (1u << std::min(p, 30)) - 1;
  std::vector<unsigned> masks(1, exc);
  if (general)
    for (unsigned mask = 1; mask < (1u << d) - 1; mask += 2)  // column 0 in group A
      if (mask != exc) masks.push_back(mask);
  for (unsigned mask : masks) {
    std::vector<arma::uword> a, b;
    double na = 0, nb = 0;
    for (int k = 0; k < d; ++k) {
      const bool inA = (mask >> k) & 1u;
      (inA ? a : b).push_back(k);
      double& n = inA ? na : nb;
      n = std::max(n, nv[k]);
    }
    if (na * nb > 2.0 * m) continue;
    if (!grid_split(Xs, arma::uvec(a), arma::uvec(b), pd, true) || !kronecker_pays(pd)) continue;
    const double cost = kron_cost(pd);
    if (cost < best) { best = cost; out = pd; out.classic = mask == exc; }
  }
  return best < arma::datum::inf;
}

// The Kronecker algebra pays when its two eigendecompositions (about
// 9 (I^3 + J^3) flops), and the system of its missing cells, cost less
// than one Cholesky factor of the m x m block (m^3 / 3): from 4 settings
// of each on for a complete grid.
bool kronecker_pays(const ProductDesign& pd) {
  const double I = pd.I, J = pd.J;
  if (pd.mi.empty()) return 27.0 * (I * I * I + J * J * J) <= I * I * I * J * J * J;
  const double m = I * J - pd.mi.size();
  return kron_cost(pd) <= m * m * m;
}

// The product design of Xs when the Kronecker algebra would be used
// (algebra 0, auto): c(I, J), with `general` its group A's columns
// (1-based) as attribute "a", with missing cells their number as attribute
// "missing"; otherwise integer(0).
// [[Rcpp::export(.sim_algebra)]]
Rcpp::IntegerVector sim_algebra(const arma::mat& Xs, int p, int algebra = 0,
                                bool general = false) {
  ProductDesign pd;
  if (algebra != ALG_AUTO || !product_design(Xs, p, pd, general)) return Rcpp::IntegerVector(0);
  Rcpp::IntegerVector out = Rcpp::IntegerVector::create(pd.I, pd.J);
  if (general) out.attr("a") = Rcpp::IntegerVector(pd.ca.begin(), pd.ca.end()) + 1;
  if (!pd.mi.empty()) out.attr("missing") = (int) pd.mi.size();
  return out;
}

KroneckerPosterior::KroneckerPosterior(const arma::mat& Xf, const arma::vec& yf,
                                       const arma::mat& Xs, const arma::vec& ys, double nugget,
                                       const Model& model, const ProductDesign& design)
  : SchurPosterior(Xf, yf, Xs, ys, nugget, model), dz_(design) {
  const int I = dz_.I, J = dz_.J;
  Y_.zeros(I, J);
  for (int r = 0; r < m; ++r) Y_(dz_.ix[r], dz_.jt[r]) = ys[r];
  for (int b = 0; b < 2; ++b) {
    Ux_.b[b].zeros(I, I); Ut_.b[b].zeros(J, J); Ax_.b[b].zeros(I, nu_); Yt_.b[b].zeros(I, J);
    lx_.b[b].zeros(I); lt_.b[b].zeros(J); c_.b[b].zeros(J); ct_.b[b].zeros(J);
    w_.b[b].zeros(I); g_.b[b].zeros(I);
  }
  Rx_.zeros(I, I); Rt_.zeros(J, J); Rxf_.zeros(I, nu_);
  for (int g = 0; g < 2; ++g) {
    const arma::uvec& c = g ? dz_.cb : dz_.ca;
    hasExp_[g] = arma::any(c < (arma::uword) p);
    hasCal_[g] = arma::any(c >= (arma::uword) p);
  }
  if (!dz_.classic) {
    if (!levels.empty()) Rcpp::stop("the general Kronecker split takes numeric inputs only");
    for (int b = 0; b < 2; ++b) Bf_.b[b].zeros(J, nu_);
    Wg_.zeros(I * J, nu_);
    return;
  }
  split_levels();
}

// Is Xg every combination of the categorical inputs' level tuples and the
// numeric settings (the other columns)? Then, by separability,
//   Rx[k, k'] = Ct[tk, tk'] Rn[rk, rk'],
// Ct the correlation of the tuples (their indicators' kernel times the
// levels' correlations), Rn that of the numeric settings, and
// Rx = Ux diag(lx) Ux' with Ux[k, a R + b] = Uc[tk, a] Un[rk, b],
// lx[a R + b] = lc[a] ln[b]: a T x T and an R x R eigendecomposition
// instead of an I x I one (3 outputs x 50 points: 3 x 3 and 50 x 50 for
// 150 x 150).
void KroneckerPosterior::split_levels() {
  if (levels.empty()) return;
  const int I = dz_.I;
  std::vector<char> isLevel(p, 0);
  for (const LevelInput& f : levels)
    for (int c = 0; c < f.ncol; ++c) isLevel[f.col + c] = 1;
  std::map<std::vector<int>, int> tuples;
  std::map<std::vector<double>, int> nums;
  tk_.resize(I); rk_.resize(I);
  for (int k = 0; k < I; ++k) {
    std::vector<int> tk(levels.size());
    for (size_t f = 0; f < levels.size(); ++f) tk[f] = level_of(dz_.Xg, k, levels[f]);
    std::vector<double> nk;
    for (int c = 0; c < p; ++c) if (!isLevel[c]) nk.push_back(dz_.Xg.at(k, c));
    tk_[k] = tuples.emplace(tk, (int) tuples.size()).first->second;
    rk_[k] = nums.emplace(nk, (int) nums.size()).first->second;
  }
  const int T = tuples.size(), R = nums.size();
  if (!full_grid(tk_, T, rk_, R)) return;
  Xt_.set_size(T, p); Xn_.set_size(R, p);
  for (int k = 0; k < I; ++k) {
    if (rk_[k] == 0) Xt_.row(tk_[k]) = dz_.Xg.row(k);
    if (tk_[k] == 0) Xn_.row(rk_[k]) = dz_.Xg.row(k);
  }
  Ct_.zeros(T, T); Rn_.zeros(R, R);
  split_ = true;
}

arma::mat KroneckerPosterior::groupCorr(int g, const arma::mat& Zg) const {
  const arma::uvec& c = g ? dz_.cb : dz_.ca;
  const arma::uvec th = c + (arma::uword) iThetaS, al = c + (arma::uword) iAlphaS;
  return corr_matrix(g ? dz_.Tg : dz_.Xg, Zg, phi.elem(th), phi.elem(al), kernS_);
}

std::string KroneckerPosterior::algebra() const {
  return "Kronecker " + std::to_string(dz_.I) + " x " + std::to_string(dz_.J) +
         (dz_.mi.empty() ? "" : ", " + std::to_string(dz_.mi.size()) + " cells missing");
}

bool KroneckerPosterior::gridUpdate(const Touch& t, double& ldDs, double& zz) {
  const double* thetaS = phi.memptr() + iThetaS;
  const double* alphaS = phi.memptr() + iAlphaS;
  const int I = dz_.I, J = dz_.J;
  const bool xMove = moved(t, 0), tMove = moved(t, 1);
  if (xMove && !dz_.classic) {
    if (!arma::eig_sym(lx_.alt(), Ux_.alt(), groupCorr(0, dz_.Xg))) return false;
  } else if (xMove && split_) {
    // Rx = Ct (x) Rn in Xg's order (split_levels())
    kernel_corr(kernS_, Xt_, Xt_, p, thetaS, alphaS, Ct_, false);
    level_scale(levels, phi.memptr() + iRhoS, Xt_, Xt_, Ct_, false);
    kernel_corr(kernS_, Xn_, Xn_, p, thetaS, alphaS, Rn_, false);
    if (!arma::eig_sym(lc_, Uc_, Ct_) || !arma::eig_sym(ln_, Un_, Rn_)) return false;
    const int T = Ct_.n_rows, R = Rn_.n_rows;
    arma::mat& Ux = Ux_.alt();
    arma::vec& lx = lx_.alt();
    for (int a = 0; a < T; ++a)
      for (int b = 0; b < R; ++b) {
        const int col = a * R + b;
        lx[col] = lc_[a] * ln_[b];
        double* u = Ux.colptr(col);
        for (int k = 0; k < I; ++k) u[k] = Uc_.at(tk_[k], a) * Un_.at(rk_[k], b);
      }
  } else if (xMove) {
    kernel_corr(kernS_, dz_.Xg, dz_.Xg, p, thetaS, alphaS, Rx_, false);
    level_scale(levels, phi.memptr() + iRhoS, dz_.Xg, dz_.Xg, Rx_, false);
    if (!arma::eig_sym(lx_.alt(), Ux_.alt(), Rx_)) return false;
  }
  if (xMove && dz_.classic) {
    kernel_corr(kernS_, dz_.Xg, Xu_, p, thetaS, alphaS, Rxf_, false);
    level_scale(levels, phi.memptr() + iRhoS, dz_.Xg, Xu_, Rxf_, false);
    Ax_.alt() = Ux_.alt().t() * Rxf_;
  }
  if (tMove && !dz_.classic) {
    if (!arma::eig_sym(lt_.alt(), Ut_.alt(), groupCorr(1, dz_.Tg))) return false;
  } else if (tMove) {
    kernel_corr(kernS_, dz_.Tg, dz_.Tg, q, thetaS + p, alphaS + p, Rt_, false);
    if (!arma::eig_sym(lt_.alt(), Ut_.alt(), Rt_)) return false;
  }
  const arma::mat& Ux = xMove ? Ux_.alt() : Ux_.cur();
  const arma::vec& lx = xMove ? lx_.alt() : lx_.cur();
  const arma::mat& Ut = tMove ? Ut_.alt() : Ut_.cur();
  const arma::vec& lt = tMove ? lt_.alt() : lt_.cur();
  if (t.simCorr) {
    double ld = 0.0;
    for (int j = 0; j < J; ++j)
      for (int i = 0; i < I; ++i) {
        const double l = lx[i] * lt[j] + nugget_;
        if (!(l > 0)) return false;
        ld += std::log(l);
      }
    arma::mat& Yt = Yt_.alt();
    Yt = Ux.t() * Y_ * Ut;
    double s = 0.0;
    for (int j = 0; j < J; ++j) {
      const double* y = Yt.colptr(j);
      for (int i = 0; i < I; ++i) s += y[i] * y[i] / (lx[i] * lt[j] + nugget_);
    }
    ldDs = ld; zz = s;
  }
  if (!dz_.classic) {
    // the field rows' factors of each group (kappa in the calibration columns)
    arma::mat Z(nu_, p + q);
    Z.cols(0, p - 1) = Xu_.cols(0, p - 1);
    for (int k = 0; k < q; ++k) Z.col(p + k).fill(phi[iKappa + k]);
    if (fieldMoved(t, 0)) Ax_.alt() = Ux.t() * groupCorr(0, Z.cols(dz_.ca));
    if (fieldMoved(t, 1)) Bf_.alt() = Ut.t() * groupCorr(1, Z.cols(dz_.cb));
    return true;
  }
  if (t.cChange) {
    kernel_corr_point(kernS_, dz_.Tg, 0, q, phi.memptr() + iKappa, thetaS + p, alphaS + p,
                      c_.alt());
    ct_.alt() = Ut.t() * c_.alt();
  }
  if (t.cross) {
    const arma::vec& ct = t.cChange ? ct_.alt() : ct_.cur();
    const arma::mat& Yt = t.simCorr ? Yt_.alt() : Yt_.cur();
    arma::vec& w = w_.alt();
    arma::vec& g = g_.alt();
    w.zeros(); g.zeros();
    for (int j = 0; j < J; ++j) {
      const double cj = ct[j], lj = lt[j];
      const double* y = Yt.colptr(j);
      for (int i = 0; i < I; ++i) {
        const double r = cj / (lx[i] * lj + nugget_);
        w[i] += cj * r;
        g[i] += y[i] * r;
      }
    }
  }
  return true;
}

// Q = Rkk - Ax' diag(w) Ax (lower), wz = Ax' g.
void KroneckerPosterior::gridCross(const Touch& t, const arma::mat& Rkk, arma::mat& Q,
                                  arma::vec& wz) {
  if (!dz_.classic) {
    const arma::vec& lx = moved(t, 0) ? lx_.alt() : lx_.cur();
    const arma::vec& lt = moved(t, 1) ? lt_.alt() : lt_.cur();
    const arma::mat& A = fieldMoved(t, 0) ? Ax_.alt() : Ax_.cur();
    const arma::mat& B = fieldMoved(t, 1) ? Bf_.alt() : Bf_.cur();
    const arma::mat& Yt = t.simCorr ? Yt_.alt() : Yt_.cur();
    const int I = dz_.I, J = dz_.J;
    wz.zeros(nu_);
    for (int j = 0; j < J; ++j)
      for (int i = 0; i < I; ++i) {
        const int r = i + I * j;
        const double is = 1.0 / std::sqrt(lx[i] * lt[j] + nugget_), wy = Yt(i, j) * is;
        for (int u = 0; u < nu_; ++u) {
          Wg_(r, u) = A(i, u) * B(j, u) * is;
          wz[u] += Wg_(r, u) * wy;
        }
      }
    Q = Rkk;
    syrk_lower(Wg_, -1.0, 1.0, Q);
    return;
  }
  const arma::mat& Ax = (t.simCorr && t.expDim) ? Ax_.alt() : Ax_.cur();
  const arma::vec& w = w_.alt();
  const arma::vec& g = g_.alt();
  wz = Ax.t() * g;
  arma::mat B = Ax;
  B.each_col() %= arma::sqrt(w);
  Q = Rkk;
  syrk_lower(B, -1.0, 1.0, Q);
}

void KroneckerPosterior::simFlip(const Touch& t) {
  if (moved(t, 0)) { Ux_.flip(); lx_.flip(); }
  if (moved(t, 1)) { Ut_.flip(); lt_.flip(); }
  if (fieldMoved(t, 0)) Ax_.flip();
  if (t.simCorr) { Yt_.flip(); Lm_.flip(); hv_.flip(); }
  if (!dz_.classic) {
    if (fieldMoved(t, 1)) Bf_.flip();
    return;
  }
  if (t.cChange) { c_.flip(); ct_.flip(); }
  if (t.cross) { w_.flip(); g_.flip(); }
}

// Missing cells (runs absent from the grid): the runs' block is Ds_oo, the
// observed rows and columns of the full grid's Ds. With E the missing
// cells' columns of the identity, M = E' Ds^-1 E = Lm Lm' (k x k) and
//   Ds^-1 - Ds^-1 E M^-1 E' Ds^-1 = Ds_oo^-1 on the observed rows, 0 elsewhere,
// any full-grid vectors a, b (whatever their values at the missing cells)
// give a_o' Ds_oo^-1 b_o = a' Ds^-1 b - h_a' M^-1 h_b, h_a = E' Ds^-1 a, and
//   log|Ds_oo| = log|Ds| + log|M|:
// the full grid's Kronecker algebra (ys zero at the missing cells) less a
// rank-k correction; exact, the posterior of the observed runs. Forming M
// costs K^2 I J + k^2 min(I, J) / 2 (missing_system(), K <= max(I, J)
// distinct settings of the larger group among the missing cells),
// factoring it k^3 / 3, every move of the simulator's correlation; a move
// of the field rows' cross block adds nu columns of I J (I + J) and k^2 nu. (Entries of Ux (X % Li) Ut' at the missing cells,
// Li = 1 / lam: of Ds^-1 x for X = Ux' x Ut.)
arma::vec KroneckerPosterior::atMissing(const arma::mat& Ux, const arma::mat& Ut,
                                        const arma::mat& Li, const arma::mat& X) const {
  const arma::mat P = (Ux * (X % Li)) * Ut.t();
  arma::vec h(dz_.mi.size());
  for (arma::uword s = 0; s < h.n_elem; ++s) h[s] = P(dz_.mi[s], dz_.mj[s]);
  return h;
}

// Lm^-1 E' Ds^-1 K for Kronecker columns K_c whose factors in the
// eigenbases are A.col(c) (I) and B.col(c) (J; B one column: shared).
arma::mat KroneckerPosterior::missSolve(const arma::mat& Ux, const arma::mat& Ut,
                                        const arma::mat& Li, const arma::mat& L,
                                        const arma::mat& A, const arma::mat& B) const {
  arma::mat H(dz_.mi.size(), A.n_cols);
  for (arma::uword c = 0; c < A.n_cols; ++c)
    H.col(c) = atMissing(Ux, Ut, Li, A.col(c) * B.col(B.n_cols == 1 ? 0 : c).t());
  return arma::solve(arma::trimatl(L), H);
}

// M = E' Ds^-1 E, cell s at (r_s, c_s) of the grid (rows of P, rows of
// Q; Li's rows index P's columns a, its columns Q's columns b):
//   M_st = sum_a P[r_s,a] P[r_t,a] D_a(c_s, c_t),
//   D_a(c, c') = sum_b Li[a,b] Q[c,b] Q[c',b],
// D for every pair of the K distinct c's in one product Li W (W: the
// pairs' Q[c,.] % Q[c',.]): K^2 I J + k^2 I / 2 flops, with P the smaller
// group's eigenvectors, instead of k (I^2 J + I J^2) column by column.
static arma::mat missing_system(const arma::mat& P, const std::vector<int>& r,
                                const arma::mat& Q, const std::vector<int>& c,
                                const arma::mat& Li) {
  const int k = r.size();
  std::vector<int> id(Q.n_rows, -1), cs;
  for (int s = 0; s < k; ++s)
    if (id[c[s]] < 0) { id[c[s]] = cs.size(); cs.push_back(c[s]); }
  const int K = cs.size();
  arma::mat W(Q.n_cols, K * K);
  for (int u = 0; u < K; ++u)
    for (int v = 0; v < K; ++v) W.col(u * K + v) = (Q.row(cs[u]) % Q.row(cs[v])).t();
  const arma::mat D = Li * W;
  arma::mat Pr(P.n_cols, k);
  for (int s = 0; s < k; ++s) Pr.col(s) = P.row(r[s]).t();
  arma::mat M(k, k);
  for (int t = 0; t < k; ++t)
    for (int s = t; s < k; ++s)
      M(s, t) = M(t, s) = arma::dot(Pr.col(s) % Pr.col(t), D.col(id[c[s]] * K + id[c[t]]));
  return M;
}

bool KroneckerPosterior::simUpdate(const Touch& t, double& ldDs, double& zz) {
  if (!gridUpdate(t, ldDs, zz)) return false;
  const int k = dz_.mi.size();
  if (!k || !t.simCorr) return true;
  const arma::mat& Ux = moved(t, 0) ? Ux_.alt() : Ux_.cur();
  const arma::mat& Ut = moved(t, 1) ? Ut_.alt() : Ut_.cur();
  const arma::mat Li = 1.0 / ((moved(t, 0) ? lx_.alt() : lx_.cur()) *
                              (moved(t, 1) ? lt_.alt() : lt_.cur()).t() + nugget_);
  const arma::mat M = dz_.I <= dz_.J ? missing_system(Ux, dz_.mi, Ut, dz_.mj, Li)
                                     : missing_system(Ut, dz_.mj, Ux, dz_.mi, Li.t());
  arma::mat& L = Lm_.alt();
  if (!arma::chol(L, M, "lower")) return false;
  hv_.alt() = arma::solve(arma::trimatl(L), atMissing(Ux, Ut, Li, Yt_.alt()));
  ldDs += 2.0 * arma::sum(arma::log(L.diag()));
  zz -= arma::dot(hv_.alt(), hv_.alt());
  return true;
}

// Q = Rkk - Bs_o' Ds_oo^-1 Bs_o = (the full grid's) + C'C, wz = (the full
// grid's) - C' hv, C = Lm^-1 E' Ds^-1 Bs.
void KroneckerPosterior::simCross(const Touch& t, const arma::mat& Rkk, arma::mat& Q,
                                  arma::vec& wz) {
  gridCross(t, Rkk, Q, wz);
  if (dz_.mi.empty()) return;
  const arma::mat& Ux = moved(t, 0) ? Ux_.alt() : Ux_.cur();
  const arma::mat& Ut = moved(t, 1) ? Ut_.alt() : Ut_.cur();
  const arma::mat Li = 1.0 / ((moved(t, 0) ? lx_.alt() : lx_.cur()) *
                              (moved(t, 1) ? lt_.alt() : lt_.cur()).t() + nugget_);
  const arma::mat& B = dz_.classic ? (t.cChange ? ct_.alt() : ct_.cur())
                                   : (fieldMoved(t, 1) ? Bf_.alt() : Bf_.cur());
  const arma::mat C = missSolve(Ux, Ut, Li, t.simCorr ? Lm_.alt() : Lm_.cur(),
                                fieldMoved(t, 0) ? Ax_.alt() : Ax_.cur(), B);
  syrk_lower(C, 1.0, 1.0, Q);
  wz -= C.t() * (t.simCorr ? hv_.alt() : hv_.cur());
}

// The targets' factors in the eigenbases: Ux' Rs_A(Xg, z[A]) and
// Ut' Rs_B(Tg, z[B]) at z = (Xnew, kappa) (experimental x calibration: the
// second one column, kappa's).
void KroneckerPosterior::targetFactors(const arma::mat& Xnew, arma::mat& an, arma::mat& bn) {
  if (dz_.classic) {
    arma::mat rx = corr_matrix(dz_.Xg, Xnew, phi.subvec(iThetaS, iThetaS + p - 1),
                               phi.subvec(iAlphaS, iAlphaS + p - 1), kernS_);
    level_scale(levels, phi.memptr() + iRhoS, dz_.Xg, Xnew, rx, false);
    an = Ux_.cur().t() * rx;
    bn = ct_.cur();
    return;
  }
  arma::mat Z(Xnew.n_rows, p + q);
  Z.cols(0, p - 1) = Xnew.cols(0, p - 1);
  for (int k = 0; k < q; ++k) Z.col(p + k).fill(phi[iKappa + k]);
  an = Ux_.cur().t() * groupCorr(0, Z.cols(dz_.ca));
  bn = Ut_.cur().t() * groupCorr(1, Z.cols(dz_.cb));
}

void KroneckerPosterior::simCondition(const arma::mat& Xnew, arma::vec& a, arma::vec& b,
                                      arma::mat& G) {
  gridCondition(Xnew, a, b, G);
  if (dz_.mi.empty()) return;
  arma::mat an, bn;
  targetFactors(Xnew, an, bn);
  const arma::mat Li = 1.0 / (lx_.cur() * lt_.cur().t() + nugget_);
  const arma::mat Cc = missSolve(Ux_.cur(), Ut_.cur(), Li, Lm_.cur(), an, bn);
  const arma::mat Cb = missSolve(Ux_.cur(), Ut_.cur(), Li, Lm_.cur(), Ax_.cur(),
                                 dz_.classic ? arma::mat(ct_.cur()) : Bf_.cur());
  a -= Cc.t() * hv_.cur();
  b -= arma::sum(arma::square(Cc), 0).t();
  G -= Cb.t() * Cc;
}

// k_c = rx_c (x) c with rx_c = Rs(Xg, Xnew_c) and an_c = Ux' rx_c:
//   a_c = an_c' g,  b_c = sum_i an_ic^2 w_i,  G = Ax' diag(w) An.
void KroneckerPosterior::gridCondition(const arma::mat& Xnew, arma::vec& a, arma::vec& b,
                                      arma::mat& G) {
  if (!dz_.classic) {
    // general split, with an = Ux' Ra(Xg, z[A]), bn = Ut' Rb(Tg, z[B]) and
    // Li = 1 / lam: a_c = an_c' (Yt % Li) bn_c, b_c = (an_c^2)' Li bn_c^2,
    // G_uc = an_c' (Li % Ax_u Bf_u') bn_c
    arma::mat an, bn;
    targetFactors(Xnew, an, bn);
    const arma::mat Li = 1.0 / (lx_.cur() * lt_.cur().t() + nugget_);
    a = arma::sum(an % ((Yt_.cur() % Li) * bn), 0).t();
    b = arma::sum(arma::square(an) % (Li * arma::square(bn)), 0).t();
    G.set_size(nu_, Xnew.n_rows);
    for (int u = 0; u < nu_; ++u)
      G.row(u) = arma::sum(an % ((Li % (Ax_.cur().col(u) * Bf_.cur().col(u).t())) * bn), 0);
    return;
  }
  const arma::vec& w = w_.cur();
  const arma::vec& g = g_.cur();
  arma::mat rx = corr_matrix(dz_.Xg, Xnew, phi.subvec(iThetaS, iThetaS + p - 1),
                             phi.subvec(iAlphaS, iAlphaS + p - 1), kernS_);
  level_scale(levels, phi.memptr() + iRhoS, dz_.Xg, Xnew, rx, false);
  An_ = Ux_.cur().t() * rx;
  a = An_.t() * g;
  b = (arma::square(An_).t()) * w;
  An_.each_col() %= w;
  G = Ax_.cur().t() * An_;
}

// Ds^-1 = (Ux (x) Ut) diag(1 / lam) (Ux (x) Ut)'; with Li_ab = 1 / lam_ab
// and run r at (i, j) = (ix_r, jt_r):
//   a_r = [Ux (Yt % Li) Ut']_ij,
//   (Ds^-1)_rr = [(Ux % Ux) Li (Ut % Ut)']_ij                 (a fold of one run),
//   (Ds^-1)_rs = [Ux M_s Ut']_ij, M_s = (Ux_{i_s,.}' Ut_{j_s,.}) % Li (column s):
// O(I^2 J + I J^2), and O(I^2 J + |B| J) per run of a larger fold B;
// nothing of size m x m is formed.
void KroneckerPosterior::simHeldout(const std::vector<std::vector<int> >& folds, arma::vec& a,
                                    std::vector<arma::mat>& QBB) {
  const arma::mat& Ux = Ux_.cur();
  const arma::mat& Ut = Ut_.cur();
  const arma::vec& lx = lx_.cur();
  const arma::vec& lt = lt_.cur();
  const std::vector<int>& ix = dz_.ix;
  const std::vector<int>& jt = dz_.jt;
  if (!dz_.mi.empty()) {
    // missing cells: a = [Ds^-1 (y0 - E M^-1 h_y)]_o and (Ds_oo^-1)_BB =
    // (Ds^-1)_BB - C_B' C_B, C_B = Lm^-1 E' Ds^-1 E_B (see atMissing())
    const arma::mat Li = 1.0 / (lx * lt.t() + nugget_);
    const arma::mat& L = Lm_.cur();
    const arma::vec w = arma::solve(arma::trimatu(L.t()), hv_.cur());
    arma::mat Ew(dz_.I, dz_.J, arma::fill::zeros);
    for (size_t s = 0; s < dz_.mi.size(); ++s) Ew(dz_.mi[s], dz_.mj[s]) = w[s];
    const arma::mat A = (Ux * ((Yt_.cur() - Ux.t() * Ew * Ut) % Li)) * Ut.t();
    a.set_size(m);
    for (int r = 0; r < m; ++r) a[r] = A(ix[r], jt[r]);
    QBB.resize(folds.size());
    for (size_t k = 0; k < folds.size(); ++k) {
      const std::vector<int>& B = folds[k];
      const int nb = B.size();
      arma::mat D(nb, nb), H(dz_.mi.size(), nb);
      for (int c = 0; c < nb; ++c) {
        const arma::mat X = Ux.row(ix[B[c]]).t() * Ut.row(jt[B[c]]);
        const arma::mat P = (Ux * (X % Li)) * Ut.t();
        for (int b = 0; b < nb; ++b) D(b, c) = P(ix[B[b]], jt[B[b]]);
        H.col(c) = atMissing(Ux, Ut, Li, X);
      }
      const arma::mat C = arma::solve(arma::trimatl(L), H);
      QBB[k] = D - C.t() * C;
    }
    return;
  }
  arma::mat Li(dz_.I, dz_.J);
  for (int j = 0; j < dz_.J; ++j)
    for (int i = 0; i < dz_.I; ++i) Li(i, j) = 1.0 / (lx[i] * lt[j] + nugget_);
  const arma::mat A = Ux * (Yt_.cur() % Li) * Ut.t();
  a.set_size(m);
  for (int r = 0; r < m; ++r) a[r] = A(ix[r], jt[r]);
  arma::mat Dg, P;
  for (const std::vector<int>& B : folds)
    if (B.size() == 1) { Dg = arma::square(Ux) * Li * arma::square(Ut).t(); break; }
  QBB.resize(folds.size());
  for (size_t k = 0; k < folds.size(); ++k) {
    const std::vector<int>& B = folds[k];
    const int nb = B.size();
    arma::mat& Q = QBB[k];
    Q.set_size(nb, nb);
    if (nb == 1) { Q(0, 0) = Dg(ix[B[0]], jt[B[0]]); continue; }
    for (int c = 0; c < nb; ++c) {
      const int s = B[c];
      P = Ux * ((Ux.row(ix[s]).t() * Ut.row(jt[s])) % Li);
      for (int b = 0; b < nb; ++b) Q(b, c) = arma::dot(P.row(ix[B[b]]), Ut.row(jt[B[b]]));
    }
  }
}

// Ds^-1/2 = diag(lam)^-1/2 (Ux (x) Ut)' with lam_ij = lx_i lt_j + nugget;
// Rs(Xs, z) = rx(z) (x) rt(z), so W_ij = (Ux' rx)_i (Ut' rt)_j / sqrt(lam_ij),
// wy_ij = (Ux' Y Ut)_ij / sqrt(lam_ij), and the field latents' columns
// (Ax, ct) the same way.
void KroneckerPosterior::simWhiten(const arma::mat& Z, arma::mat& W, arma::vec& wy,
                                   arma::mat& G, bool haveW) {
  if (!dz_.mi.empty())
    Rcpp::stop("the design of new runs on a product design with missing cells needs `algebra = \"dense\"`");
  const int I = dz_.I, J = dz_.J, nz = Z.n_rows;
  const arma::vec th = phi.subvec(iThetaS, iThetaS + p + q - 1);
  const arma::vec al = phi.subvec(iAlphaS, iAlphaS + p + q - 1);
  arma::mat rx, rt;
  if (dz_.classic) {
    const arma::mat Zx = Z.cols(0, p - 1);
    rx = corr_matrix(dz_.Xg, Zx, th.head(p), al.head(p), kernS_);
    level_scale(levels, phi.memptr() + iRhoS, dz_.Xg, Zx, rx, false);
    rt = corr_matrix(dz_.Tg, Z.cols(p, p + q - 1), th.tail(q), al.tail(q), kernS_);
  } else {
    rx = groupCorr(0, Z.cols(dz_.ca));
    rt = groupCorr(1, Z.cols(dz_.cb));
  }
  const arma::mat ax = Ux_.cur().t() * rx, at = Ut_.cur().t() * rt;
  const arma::vec& lx = lx_.cur();
  const arma::vec& lt = lt_.cur();
  const arma::mat& Ax = Ax_.cur();
  const arma::vec& ct = ct_.cur();
  const arma::mat& Yt = Yt_.cur();
  if (!haveW) { W.set_size(m, nz); wy.set_size(m); }
  arma::mat WB(m, nu_);
  for (int j = 0; j < J; ++j)
    for (int i = 0; i < I; ++i) {
      const int r = i + I * j;
      const double is = 1.0 / std::sqrt(lx[i] * lt[j] + nugget_);
      for (int u = 0; u < nu_; ++u)
        WB(r, u) = Ax(i, u) * (dz_.classic ? ct[j] : Bf_.cur()(j, u)) * is;
      if (haveW) continue;
      for (int c = 0; c < nz; ++c) W(r, c) = ax(i, c) * at(j, c) * is;
      wy[r] = Yt(i, j) * is;
    }
  G = WB.t() * W;
}

// x <- Ds^-1 x = (Ux (x) Ut) diag(lam)^-1 (Ux (x) Ut)' x on a complete grid
// (x as the I x J matrix X of its runs' cells: Ux (Ux' X Ut / lam) Ut'),
// O(I J (I + J)); with missing cells the inverse simHeldout() forms.
void KroneckerPosterior::simSolve(arma::vec& x) {
  if (!dz_.mi.empty()) { SchurPosterior::simSolve(x); return; }
  const int I = dz_.I, J = dz_.J;
  arma::mat X(I, J);
  for (int r = 0; r < m; ++r) X(dz_.ix[r], dz_.jt[r]) = x[r];
  const arma::mat& Ux = Ux_.cur();
  const arma::mat& Ut = Ut_.cur();
  arma::mat Xt = Ux.t() * X * Ut;
  const arma::vec& lx = lx_.cur();
  const arma::vec& lt = lt_.cur();
  for (int j = 0; j < J; ++j)
    for (int i = 0; i < I; ++i) Xt(i, j) /= lx[i] * lt[j] + nugget_;
  X = Ux * Xt * Ut.t();
  for (int r = 0; r < m; ++r) x[r] = X(dz_.ix[r], dz_.jt[r]);
}
