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
#include <memory>
#include <vector>

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


// Which cached blocks a move touches (see DensePosterior::evaluate). A move
// of several parameters touches the union of what each one touches.
struct Touch {
  std::vector<char> simPow;   // per simulator input: alphaS_k moved (power matrix)
  std::vector<char> biasPow;  // per experimental input: alphaB_k moved
  bool simCorr = false;   // some thetaS/alphaS moved: Ds and its factor
  bool expDim = false;    //   ... of an experimental input: Rs(Xs,Xk), Rs(Xk,Xk)
  bool cChange = false;   // kappa or a calibration-input thetaS/alphaS moved
  bool biasCorr = false;  // thetaB/alphaB moved
  bool cross = false;     // W = Ls^-1 Rs(Xs,Xk) and W'z
  bool field = false;     // the Schur complement S and its factor
  bool scale = false;     // sigma2S, sigma2B, sigma2E multiplied by one factor
  void reset(int nSim, int nBias) {
    simPow.assign(nSim, 0); biasPow.assign(nBias, 0);
    simCorr = expDim = cChange = biasCorr = cross = field = scale = false;
  }
  void everything(int nSim, int nBias) {
    simPow.assign(nSim, 1); biasPow.assign(nBias, 1);
    simCorr = expDim = cChange = biasCorr = cross = field = true;
    scale = false;
  }
};

// The posterior's likelihood part with every factor cached, so that a move
// recomputes only the blocks it touches. This is the one interface the
// sampler (sampler.cpp) and prediction (predict.cpp) see; the algebra behind
// it (dense Cholesky here, model.cpp) is chosen by make_posterior().
// Parameter vector phi (length d = 4p + 3q + 4), scaled space, kappa on [0,1]:
//   kappa[q], thetaS[p+q], alphaS[p+q], thetaB[p], alphaB[p],
//   sigma2S, sigma2B, sigma2E, muB.
class Posterior {
public:
  virtual ~Posterior() {}
  int n, m, p, q, d;
  int iKappa, iThetaS, iAlphaS, iThetaB, iAlphaB, iSigma2S, iSigma2B, iSigma2E, iMuB;
  arma::vec phi;  // current parameters

  // Set phi and compute every block; false if a covariance is not PD.
  virtual bool init(const arma::vec& phi0) = 0;
  virtual double logLik() const = 0;
  // Log-likelihood with phi[idx[i]] = values[i] for every i (-Inf if a
  // factor fails); kept in scratch buffers until accept() or reject().
  virtual double propose(const std::vector<int>& idx, const arma::vec& values) = 0;
  double propose(int j, double value) {
    one_[0] = j; oneVal_[0] = value;
    return propose(one_, oneVal_);
  }
  // Log-likelihood with sigma2S, sigma2B and sigma2E all multiplied by c:
  // C(c) = c C, so log|C| and the quadratic form follow in closed form.
  virtual double proposeScale(double c) = 0;
  virtual void accept() = 0;
  virtual void reject() = 0;
  // The log-likelihood is Gaussian in muB: -0.5 |b - muB a|^2 + const with
  // a = LS^-1 1, b = LS^-1 (yf - W'z); returns a'a and a'b.
  virtual void muBQuadratic(double& aa, double& ab) const = 0;

  // Prediction at the current state (predict.cpp): for targets with
  // covariance ks with ys and kf with yf (columns), fills the conditional
  // mean and variance given y, with prior means mu0 and variances v0.
  virtual void condition(const arma::mat& ks, const arma::mat& kf, double mu0,
                         double v0, double* mean, double* var) = 0;

protected:
  void set_sizes(int n_, int m_, int p_, int q_);
  std::vector<int> one_ = std::vector<int>(1);
  arma::vec oneVal_ = arma::vec(1);
};

// The dense algebra: Cholesky factors of the m x m simulator block and of
// the n x n Schur complement (model.cpp).
class DensePosterior : public Posterior {
public:
  DensePosterior(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                 const arma::vec& ys, double nugget);
  bool init(const arma::vec& phi0) override;
  double logLik() const override { return loglik_.cur(); }
  double propose(const std::vector<int>& idx, const arma::vec& values) override;
  double proposeScale(double c) override;
  void accept() override;
  void reject() override;
  void muBQuadratic(double& aa, double& ab) const override;
  void condition(const arma::mat& ks, const arma::mat& kf, double mu0, double v0,
                 double* mean, double* var) override;

private:
  const arma::mat& Xf_; const arma::vec& yf_;
  const arma::mat& Xs_; const arma::vec& ys_;
  double nugget_;
  int nu_;                 // distinct field input rows
  arma::mat Xu_;           // ... and their values (nu x p)
  std::vector<int> grp_;   // field row i is distinct row grp_[i]
  Touch touch_;
  std::vector<int> oldIdx_;
  arma::vec oldVal_;
  std::vector<Buf2<arma::mat> > Ps_, Px_, Pfs_, Pfb_;
  // log-distances per input dimension (fixed): sim-sim, sim-field, field-field
  std::vector<arma::mat> Gs_, Gx_, Gf_;
  // preallocated lists of the power matrices evaluate() combines
  std::vector<const arma::mat*> ptrS_, ptrX_, ptrF_, ptrB_;
  Buf2<arma::mat> Ls_, Rx_, Rkk_, W_, Q_, Rb_, LS_;
  Buf2<arma::vec> z_, c_, wz_;
  Buf2<double> ldDs_, zz_, ldS_, vv_, loglik_;
  arma::vec u_;
  arma::mat G_, A_;  // prediction workspaces
  double evaluate(const Touch& t);
  void flip(const Touch& t);
  void add_touch(int j, Touch& t) const;
};

// The algebra for the data at hand (today: always dense).
std::unique_ptr<Posterior> make_posterior(const arma::mat& Xf, const arma::vec& yf,
                                          const arma::mat& Xs, const arma::vec& ys,
                                          double nugget);

#endif
