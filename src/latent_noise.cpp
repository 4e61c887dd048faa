// A stochastic simulator's input-dependent noise (R/sim_noise.R): the
// variance of a run at unique input i is r_i = exp(g_i), and the latent
// log-variances g = gR over the m unique inputs have the GP prior
//   g ~ N(muG 1, sigma2G (Rg + LATENT_JITTER I)),
// Rg the Matern 5/2 correlation (kernels.cpp, h_k = sqrt(thetaG_k) |x_k - x'_k|)
// over the scaled inputs (experimental and calibration): the Gaussian
// kernel's correlation matrices are so near singular that a latent g
// rougher than its smooth span pushed sigma2G to 1e4 (the jitter's share
// of g's variance) in one of two chains, bench/sim-noise.R at 50 x 20. Its log density is part of
// the posterior's log-likelihood, so the hyperparameters muG, sigma2G and
// thetaG move by the sampler's Metropolis walks (a walk of muG or sigma2G
// costs a triangular solve, of thetaG a factorization of m x m), and g by
// elliptical slice sampling on the whitened prior (latent_ess()).
#include "fbc.h"

// Rg's jitter: keeps the correlation of close inputs invertible.
static const double LATENT_JITTER = 1e-6;
static const int LATENT_KERNEL = 4;  // the Matern 5/2 family (kernels.cpp)

// The GP's log density at the state (phi, with what t touches pending):
//   -0.5 [m log 2 pi + m log sigma2G + log|Rg| + |Lg^-1 (g - muG)|^2 / sigma2G],
// Lg = chol(Rg) refactored when thetaG moved (t.latentK). False when Rg is
// not positive definite.
bool SchurPosterior::latentPrior(const Touch& t, double& lp) {
  const double s2G = phi[iSigma2G];
  if (!(s2G > 0)) return false;
  if (t.latentK) {
    arma::mat& L = Lg_.alt();
    arma::vec two(p + q);
    two.fill(2.0);  // (the Matern family has no smoothness: unused)
    L = corr_matrix(Xs_, Xs_, phi.subvec(iThetaG, iThetaG + p + q - 1), two, LATENT_KERNEL);
    L.diag() += LATENT_JITTER;
    if (!chol_lower(L)) return false;
    ldG_.alt() = logdet_chol(L);
  }
  arma::vec r = phi.subvec(iG, iG + m - 1) - phi[iMuG];
  solve_lower(t.latentK ? Lg_.alt() : Lg_.cur(), r);
  const double ld = t.latentK ? ldG_.alt() : ldG_.cur();
  lp = -0.5 * (m * (LOG_2PI + std::log(s2G)) + ld + arma::dot(r, r) / s2G);
  return std::isfinite(lp);
}

// sqrt(sigma2G) Lg at the current state: a square root of the prior's covariance.
const arma::mat& SchurPosterior::latentFactor() const {
  latentK_ = std::sqrt(phi[iSigma2G]) * arma::trimatl(Lg_.cur());
  return latentK_;
}

// One elliptical slice sampling update of g (Murray, Adams and MacKay 2010)
// given everything else: with the prior N(mu, S), S = C C', nu = C e,
// e ~ N(0, I), the proposals g(a) = mu + (g - mu) cos a + nu sin a (the
// whitened z = C^-1 (g - mu) turned towards e by the angle a) on a bracket
// of angles that shrinks towards a = 0 (the current g) until
//   log L(g(a)) > log L(g) + log u,   u ~ U(0, 1),
// L the likelihood without the GP prior (the posterior's log-likelihood
// less latentLogPrior(), plus `lpOf`, the gR parameters' own log prior:
// flat on a wide interval). Every proposal is a move of gR through
// propose(); the last one is accepted. An exact update of p(g | rest),
// with no scale to tune, however many the latent values are. `ll` is the
// chain's log-likelihood, updated; lp its gR log priors. Returns the
// number of proposals (0: none accepted within LATENT_TRIES, g kept).
int latent_ess(Posterior& post, double& ll, arma::vec& lp,
               const std::function<double(int, double)>& lpOf) {
  static const int LATENT_TRIES = 100;
  const int m = post.m, j0 = post.iG;
  std::vector<int> idx(m);
  for (int i = 0; i < m; ++i) idx[i] = j0 + i;
  const arma::vec g = post.phi.subvec(j0, j0 + m - 1);
  const double mu = post.phi[post.iMuG];
  arma::vec e(m), lpNew(m), gNew(m);
  for (int i = 0; i < m; ++i) e[i] = R::norm_rand();
  const arma::vec nu = post.latentFactor() * e;
  double lpSum = 0;
  for (int i = 0; i < m; ++i) lpSum += lp[j0 + i];
  const double logy = ll - post.latentLogPrior(false) + lpSum + std::log(R::unif_rand());
  double a = 2 * M_PI * R::unif_rand(), lo = a - 2 * M_PI, hi = a;
  for (int k = 1; k <= LATENT_TRIES; ++k) {
    const double c = std::cos(a), s = std::sin(a);
    double lpS = 0;
    for (int i = 0; i < m; ++i) {
      gNew[i] = mu + (g[i] - mu) * c + nu[i] * s;
      lpNew[i] = lpOf(j0 + i, gNew[i]);
      lpS += lpNew[i];
    }
    const double llNew = std::isfinite(lpS) ? post.propose(idx, gNew) : R_NegInf;
    if (std::isfinite(llNew) && llNew - post.latentLogPrior(true) + lpS > logy) {
      post.accept();
      ll = llNew;
      for (int i = 0; i < m; ++i) lp[j0 + i] = lpNew[i];
      return k;
    }
    if (std::isfinite(lpS)) post.reject();
    if (a < 0) lo = a; else hi = a;
    a = lo + (hi - lo) * R::unif_rand();
  }
  return 0;
}

// sqrt(sigma2G) chol(Rg + jitter I) at the hyperparameters of ph (not the
// state's); false when not positive definite.
bool SchurPosterior::latentFactorAt(const arma::vec& ph, arma::mat& C) const {
  arma::vec two(p + q);
  two.fill(2.0);
  C = corr_matrix(Xs_, Xs_, ph.subvec(iThetaG, iThetaG + p + q - 1), two, LATENT_KERNEL);
  C.diag() += LATENT_JITTER;
  if (!(ph[iSigma2G] > 0) || !chol_lower(C)) return false;
  C = std::sqrt(ph[iSigma2G]) * arma::trimatl(C);
  return true;
}

// A joint walk of the latent GP's hyperparameters `hyp` (muG, sigma2G,
// thetaG; w' = w + s e on their walks' scale, tr their walks) with the
// whitened latent z = C^-1 (g - muG) held fixed, so that g moves with them,
// g' = muG' + C' z: the non-centred move beside the centred ones (the
// hyperparameters' walk given g, the slice move of g given them), which
// alone cross the ridge between thetaG, sigma2G and g slowly (each given
// the others is tight; Yu and Meng 2011). The target in (hyperparameters,
// z) is p(h) N(z; 0, I) L(g): accepted with
//   log r = log L(g') - log L(g) + log p(h') - log p(h) + Jacobian,
// L the likelihood without the GP prior (as latent_ess()). True when accepted.
bool latent_shift(Posterior& post, double& ll, arma::vec& lp, const std::vector<int>& hyp,
                  const std::vector<int>& tr, double s,
                  const std::function<double(int, double)>& lpOf) {
  const int m = post.m, j0 = post.iG, k = hyp.size();
  arma::vec z = post.phi.subvec(j0, j0 + m - 1) - post.phi[post.iMuG];
  solve_lower(post.latentFactor(), z);
  arma::vec ph = post.phi;
  double r = 0;
  for (int i = 0; i < k; ++i) {
    const int j = hyp[i];
    const double x = ph[j], xNew = from_walk(tr[i], to_walk(tr[i], x) + s * R::norm_rand());
    ph[j] = xNew;
    r += lpOf(j, xNew) - lp[j] + log_jacobian(tr[i], xNew) - log_jacobian(tr[i], x);
  }
  arma::mat C;
  if (!std::isfinite(r) || !post.latentFactorAt(ph, C)) return false;
  std::vector<int> idx(hyp);
  arma::vec vals(k + m), lpG(m);
  for (int i = 0; i < k; ++i) vals[i] = ph[hyp[i]];
  const arma::vec g = ph[post.iMuG] + C * z;
  for (int i = 0; i < m; ++i) {
    idx.push_back(j0 + i);
    vals[k + i] = g[i];
    lpG[i] = lpOf(j0 + i, g[i]);
    r += lpG[i] - lp[j0 + i];
  }
  if (!std::isfinite(r)) return false;
  const double llNew = post.propose(idx, vals);
  r += llNew - post.latentLogPrior(true) - ll + post.latentLogPrior(false);
  if (std::isfinite(llNew) && std::log(R::unif_rand()) < r) {
    post.accept();
    ll = llNew;
    for (int i = 0; i < k; ++i) lp[hyp[i]] = lpOf(hyp[i], vals[i]);
    for (int i = 0; i < m; ++i) lp[j0 + i] = lpG[i];
    return true;
  }
  post.reject();
  return false;
}
