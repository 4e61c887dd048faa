// Shared declarations for the FBC compiled core.
//
// Notation (scaled space, as in the vignette): y = (yf, ys) of length n + m,
//   C = [ A  B' ]   A = sigma2S Rs(Xk,Xk) + sigma2B Rb(Xf,Xf) + sigma2E I_n
//       [ B  D  ]   B = sigma2S Rs(Xs,Xk),  D = sigma2S (Rs(Xs,Xs) + nugget I_m)
// with R(x,x') = prod_k exp(-theta_k |x_k - x'_k|^alpha_k).
// Everything is evaluated through the Schur complement S = A - B' D^-1 B.
#ifndef FBC_H
#define FBC_H

#ifndef R_NO_REMAP
#define R_NO_REMAP
#endif
#include <RcppArmadillo.h>

// Prior family codes; R/priors.R keeps the same table (prior_families()).
enum PriorFamily {
  PF_UNIFORM = 1, PF_GAUSSIAN, PF_GAMMA, PF_BETA, PF_LOGNORMAL, PF_LOGISTIC,
  PF_BETASHIFT, PF_EXPONENTIAL, PF_INVGAMMA, PF_JEFFREYS, PF_FIXED
};

// Transformation on which a parameter's random walk runs.
enum Transform { TR_IDENTITY = 0, TR_LOG = 1, TR_LOGIT12 = 2 };

// kernels.cpp -------------------------------------------------------------
double log_prior(int family, double x, double p1, double p2);
double log_jacobian(int transform, double x);
double to_walk(int transform, double x);
double from_walk(int transform, double w);

// P(i,j) = |a_i - b_j|^alpha for one input dimension (lower triangle only
// when `lower` and a == b).
void pow_dist(const arma::vec& a, const arma::vec& b, double alpha,
              arma::mat& out, bool lower);
// G(i,j) = log|a_i - b_j| and P = exp(alpha G) = |a_i - b_j|^alpha.
void log_dist(const arma::vec& a, const arma::vec& b, arma::mat& out, bool lower);
void pow_from_log(const arma::mat& G, double alpha, arma::mat& out, bool lower);
// R(i,j) = exp(-sum_k theta_k P_k(i,j)), written into `out`.
void corr_from_pows(const std::vector<const arma::mat*>& P,
                    const arma::vec& theta, arma::mat& out, bool lower);
// Full correlation matrix between rows of X and Y.
arma::mat corr_matrix(const arma::mat& X, const arma::mat& Y,
                      const arma::vec& theta, const arma::vec& alpha);

// In-place lower Cholesky (LAPACK dpotrf); returns false when not PD.
bool chol_lower(arma::mat& A);
// log|A| from its lower Cholesky factor.
double logdet_chol(const arma::mat& L);
// x <- L^-1 x, L lower triangular (BLAS dtrsv / dtrsm).
void solve_lower(const arma::mat& L, arma::vec& x);
void solve_lower(const arma::mat& L, arma::mat& X);
// C <- beta C + alpha A' A (lower triangle, BLAS dsyrk).
void syrk_lower(const arma::mat& A, double alpha, double beta, arma::mat& C);

// Two buffers for one cached quantity: the current one and a scratch one a
// proposal is written into; accepting a proposal flips them (no copy).
template <class T> struct Buf2 {
  T b[2];
  int c = 0;
  T& cur() { return b[c]; }
  T& alt() { return b[1 - c]; }
  const T& cur() const { return b[c]; }
  void flip() { c = 1 - c; }
};


// Which cached blocks a move touches (see Posterior::evaluate).
struct Touch {
  bool all = false;       // recompute everything (initialisation)
  bool simAll = false;    // every thetaS/alphaS moved at once (block move)
  int simDim = -1;        // thetaS/alphaS dimension moved
  bool simAlpha = false;  //   ... and it was alphaS
  bool kappa = false;     // a calibration parameter moved
  int biasDim = -1;       // thetaB/alphaB dimension moved
  bool biasAlpha = false; //   ... and it was alphaB
  bool field = false;     // sigma2S, sigma2B or sigma2E moved
  // Derived: which caches are recomputed (p = number of experimental inputs).
  bool simPow(int k) const { return all || simAll || (simAlpha && simDim == k); }
  bool biasPow(int k) const { return all || (biasAlpha && biasDim == k); }
  bool simCorr() const { return all || simAll || simDim >= 0; }
  bool expDim(int p) const { return all || simAll || (simDim >= 0 && simDim < p); }
  bool cChange(int p) const { return all || simAll || kappa || simDim >= p; }
  bool biasCorr() const { return all || biasDim >= 0; }
  bool cross() const { return simCorr() || kappa; }
  bool fieldBlock() const { return cross() || biasCorr() || field; }
};

// The log-likelihood of the KOH model with every factor cached, so that a
// one-parameter move recomputes only the blocks it touches (model.cpp).
// Parameter vector phi (length d = 4p + 3q + 4), scaled space, kappa on [0,1]:
//   kappa[q], thetaS[p+q], alphaS[p+q], thetaB[p], alphaB[p],
//   sigma2S, sigma2B, sigma2E, muB.
class Posterior {
public:
  Posterior(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
            const arma::vec& ys, double nugget);
  int n, m, p, q, d;
  int iKappa, iThetaS, iAlphaS, iThetaB, iAlphaB, iSigma2S, iSigma2B, iSigma2E, iMuB;
  arma::vec phi;  // current parameters

  // Set phi and compute every block; false if a covariance is not PD.
  bool init(const arma::vec& phi0);
  double logLik() const { return loglik_.cur(); }
  // Log-likelihood with phi[j] = value (-Inf if a factor fails); the result
  // is kept in the scratch buffers until accept() or reject().
  double propose(int j, double value);
  // The same for a joint move of all thetaS and alphaS: values[i] is the
  // new phi[iThetaS + i], i < 2(p+q).
  double proposeSim(const arma::vec& values);
  void accept();
  void reject();

  // Cached pieces prediction reuses (current state).
  const arma::mat& Ls() const { return Ls_.cur(); }
  const arma::mat& LS() const { return LS_.cur(); }
  const arma::mat& W() const { return W_.cur(); }
  const arma::vec& z() const { return z_.cur(); }
  arma::vec resid() const;  // LS^-1 (yf - muB - W'z)

private:
  const arma::mat& Xf_; const arma::vec& yf_;
  const arma::mat& Xs_; const arma::vec& ys_;
  double nugget_;
  Touch touch_;
  double old_;
  int oldj_;
  arma::vec oldSim_;  // thetaS/alphaS before a proposeSim()
  std::vector<Buf2<arma::mat> > Ps_, Px_, Pfs_, Pfb_;
  // log-distances per input dimension (fixed): sim-sim, sim-field, field-field
  std::vector<arma::mat> Gs_, Gx_, Gf_;
  // preallocated lists of the power matrices evaluate() combines
  std::vector<const arma::mat*> ptrS_, ptrX_, ptrF_, ptrB_;
  Buf2<arma::mat> Ls_, Rx_, Rkk_, W_, Q_, Rb_, LS_;
  Buf2<arma::vec> z_, c_, wz_;
  Buf2<double> ldDs_, zz_, ldS_, vv_, loglik_;
  arma::vec u_;
  double evaluate(const Touch& t);
  void flip(const Touch& t);
  Touch touch_for(int j) const;
};

#endif
