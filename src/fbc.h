// Shared declarations for the FBC compiled core.
//
// Notation (scaled space, as in the vignette): y = (yf, ys) of length n + m,
//   C = [ A  B' ]   A = sigma2S Rs(Xk,Xk) + sigma2B Rb(Xf,Xf) + sigma2E I_n
//       [ B  D  ]   B = sigma2S Rs(Xs,Xk),  D = sigma2S (Rs(Xs,Xs) + nugget I_m)
// with separable correlations R(x,x') = prod_k r(|x_k - x'_k|; theta_k, alpha_k)
// whose one-dimensional family r is chosen per GP (kernels.cpp: power
// exponential, Gaussian, Matern 3/2, Matern 5/2), times the levels'
// correlation C[a, a'] of each categorical input (rhoS, rhoB) and, with a
// bias per field data set, the data sets' correlation in the bias (rhoD;
// levels.cpp).
// Everything is evaluated through the Schur complement S = A - B' D^-1 B;
// the simulator block D is the algebra's business (dense Cholesky, or
// Kronecker eigendecompositions on a product design).
#ifndef FBC_H
#define FBC_H

#ifndef R_NO_REMAP
#define R_NO_REMAP
#endif
#include <RcppArmadillo.h>
#include <cstring>
#include <functional>
#include <memory>
#include <vector>

// Prior family codes, named in prior_codes() (priors.cpp), which the registry
// of R/priors.R is checked against when the package loads.
enum PriorFamily {
  PF_UNIFORM = 1, PF_GAUSSIAN, PF_GAMMA, PF_BETA, PF_LOGNORMAL, PF_LOGISTIC,
  PF_BETASHIFT, PF_EXPONENTIAL, PF_INVGAMMA, PF_JEFFREYS, PF_FIXED, PF_HALFT_SD
};

// Transformation on which a parameter's random walk runs.
enum Transform { TR_IDENTITY = 0, TR_LOG = 1, TR_LOGIT12 = 2, TR_ATANH = 3 };

// Which algebra make_posterior() uses: the product-design (Kronecker) one
// whenever the simulator design allows it, or always the dense one.
// ALG_VECCHIA: the nearest-neighbour approximation (vecchia.cpp), with the
// ordering and neighbours the model carries.
enum AlgebraChoice { ALG_AUTO = 0, ALG_DENSE = 1, ALG_VECCHIA = 2 };

// The Vecchia algebra's design (R/vecchia.R): k neighbours per node among
// the runs, kf among the field latents, the runs' maximin order (0-based
// rows of Xs), each position's earlier neighbours (m x k, row-major by
// position, -1 past the last) and the input scaling w of the distances.
struct VecchiaDesign {
  int k = 0, kf = 0;
  std::vector<int> ord, nbr;
  arma::vec w;
};

// What a prediction is of (R/predict.R, type): a new field observation
// (eta + delta + eps), the mean of the field (eta + delta), the simulator
// (eta), the bias (delta).
enum PredictType { PT_FIELD = 1, PT_MEAN = 2, PT_SIMULATOR = 3, PT_BIAS = 4 };

// What a move of a class's parameter touches (R/model-classes.R's `touch`
// column, handed over by class; R/boundary.R's touch_codes): only the
// residual (muB), kappa, the simulator GP's correlation (per input; its
// smoothness: also that input's power matrix; the levels' correlation: as
// an experimental input's), the bias GP's (likewise), the field block's
// variances, the simulator block's values (the simulator's own noise).
enum TouchKind { TK_RESIDUAL = 0, TK_KAPPA, TK_SIM, TK_SIMPOW, TK_SIMLEVELS, TK_BIAS, TK_BIASPOW,
                 TK_FIELD, TK_RUNS, TK_LATENT, TK_LATENTHYPER, TK_LATENTK };

// Parameter classes of the model. C++ keeps no list of them: R's model
// description (R/model-classes.R, model_classes) owns the classes and the
// layout, and hands each class's offset, length, what a move of it touches
// and whether the scale move multiplies it over by name (read_model()).
// Code that computes with a class looks it up by name, once, when a
// posterior is built (Layout::offset_of(), Posterior::set_sizes()); a class
// the layout does not name has no parameters.
//
// Where each class lives in phi: names[c], offset[c], length[c] (0-based, in
// R's table order), touch[c] (TouchKind), scaled[c], and for every position
// j of phi its class cls[j] (an index into names) and its place within the
// class pos[j] (thetaS and alphaS: the p experimental inputs, then the q
// calibration inputs; thetaB, alphaB: the p experimental inputs).
struct Layout {
  std::vector<std::string> names;
  std::vector<int> offset, length, touch;
  std::vector<char> scaled;
  int d = 0;
  std::vector<int> cls, pos;
  // The index of class `name` (-1: the layout has no such class).
  int index(const char* name) const {
    for (size_t c = 0; c < names.size(); ++c) if (names[c] == name) return (int) c;
    return -1;
  }
  // Its offset and length (0 and 0 for a class the layout does not name).
  int offset_of(const char* name) const { const int c = index(name); return c < 0 ? 0 : offset[c]; }
  int length_of(const char* name) const { const int c = index(name); return c < 0 ? 0 : length[c]; }
  // Is position j of phi in class `name`?
  bool is(int j, const char* name) const { return names[cls[j]] == name; }
};

// The model as the compiled entry points receive it from R
// (compiled_model() in R/model-classes.R): correlation families of the two GPs, the
// algebra choice, the discrepancy model and the layout of phi.
// A categorical input (R/factors.R): its indicator columns col .. col +
// ncol - 1 among the experimental inputs (one column for two levels, one per
// level from three) and its number of levels L. Both GPs hold the
// indicators' thetaS and thetaB at 0 and multiply their correlation by the
// levels' correlation C[a, b] (levels.cpp), from L (L - 1) / 2 canonical
// partial correlations (rhoS, rhoB).
struct LevelInput {
  int col = 0, ncol = 1, L = 2;
};

struct Model {
  int kernS = 1, kernB = 1, algebra = ALG_AUTO;  // kernels: the power exponential
  Layout layout;
  std::vector<LevelInput> levels;  // the categorical inputs, if any
  // a bias per field data set: each field row's data set (0-based; empty:
  // one bias for all) among sourceL, whose biases the bias GP correlates by
  // a level correlation from the partial correlations rhoD
  std::vector<int> source;
  int sourceL = 0;
  // the measurement-error group of each field row (0-based; empty: one
  // group), e.g. outputs x sources: sigma2E has one entry per group
  std::vector<int> noise;
  // each field row's distinct row (0-based, numbered in order of first
  // appearance; R groups them exactly, rows equal in every input and in
  // their data set with a bias per data set): replicates share eta, the
  // bias and their correlations. Empty: found by set_field() (a call
  // without a fit's model).
  std::vector<int> fieldRows;
  VecchiaDesign vecchia;  // with algebra ALG_VECCHIA
  int threads = 1;        // OpenMP threads inside a chain (calibrate(threads =))
  // the simulator is a user's R function (function.cpp): no simulator GP,
  // so thetaS, alphaS, rhoS and sigma2S have length 0 in the layout
  bool emulator = true;
  // independent outputs (R/outputs.R): the output's indicator columns and
  // its number of levels K (outputs.L; 0: none). The perOutput classes
  // (all but kappa and sigma2E) then hold K copies, output after output,
  // and each output has its own simulator and bias GP (OutputsPosterior).
  LevelInput outputs = LevelInput{0, 0, 0};
  int nOutputs() const { return outputs.L > 1 && outputs.ncol > 0 ? outputs.L : 1; }
  // a stochastic simulator's replicate runs (R/sim_noise.R): Xs and ys are
  // then the unique inputs and their mean responses, repCount[i] the runs
  // at input i, repSSW their within sum of squares and repDf =
  // sum(repCount - 1); sigma2R, the simulator's own variance, has one
  // parameter (empty: a deterministic simulator, no sigma2R)
  std::vector<double> repCount;
  double repSSW = 0.0, repDf = 0.0;
  // with an input-dependent noise (class gR, one per unique input): each
  // unique input's within sum of squares (they add up to repSSW)
  std::vector<double> repSSWi;
  // the field one realization of the stochastic simulator: its noise
  // variance gains sigma2R (a constant noise only)
  bool fieldRealization = false;
};
// Reads list(kernS, kernB, algebra, offset, length) (offset and length
// integer vectors named by class) and checks that the layout tiles phi and
// gives the classes the compiled core computes with the lengths p and q
// imply (class_needs(), model.cpp).
Model read_model(const Rcpp::List& model, int p, int q);
// Fills lay.d, lay.cls and lay.pos from lay.offset and lay.length (and
// checks that the classes tile phi).
void fill_layout(Layout& lay);

// priors.cpp -----------------------------------------------------------------
double log_prior(int family, double x, double p1, double p2);

// transforms.cpp: the walks ---------------------------------------------------
double log_jacobian(int transform, double x);
double to_walk(int transform, double x);
double from_walk(int transform, double w);

// kernels.cpp: the kernel module -------------------------------------------
// Every correlation of either GP is computed here, for the family `kern`.
// The first K columns of X and Y are the inputs; theta and alpha point to K
// values. `lower`: X == Y and only the lower triangle is wanted.
void check_kernel(int kern);
// The families' codes by name and the names of those with a smoothness:
// list(code, alpha) (.model_codes()).
Rcpp::List kernel_table();
// Does the family have a smoothness alpha? (Only the power exponential:
// for the others alpha is ignored, and a cached term is the distance cache
// itself, so callers point at G instead of calling kernel_term.)
bool kernel_has_alpha(int kern);
// Cached per-dimension path (dense algebra, small m): G = kernel_dist(a, b)
// once, P = kernel_term(G, alpha) when alpha moves (P = G for the families
// without a smoothness), R = kernel_combine(P, theta).
void kernel_dist(int kern, const arma::vec& a, const arma::vec& b, arma::mat& G, bool lower);
void kernel_term(int kern, const arma::mat& G, double alpha, arma::mat& P, bool lower);
void kernel_combine(int kern, const std::vector<const arma::mat*>& P, const arma::vec& theta,
                    arma::mat& out, bool lower);
// The same numbers computed on the fly, with no per-dimension storage.
void kernel_corr(int kern, const arma::mat& X, const arma::mat& Y, int K, const double* theta,
                 const double* alpha, arma::mat& out, bool lower);
// Packed lower-triangle caches for the self-correlation of the m simulator
// rows: G = kernel_dist_packed(a) (m (m + 1) / 2 doubles), entry (i, j),
// i >= j, at packed_offset(j, m) + i - j; kernel_corr_self() uses G[k] where
// non-null and computes dimension k on the fly elsewhere (same numbers).
size_t packed_offset(size_t j, size_t m);
void kernel_dist_packed(int kern, const arma::vec& a, std::vector<double>& G);
void kernel_corr_self(int kern, const arma::mat& X, int K, const double* theta,
                      const double* alpha, const std::vector<const double*>& G,
                      arma::mat& out);
// out_i = R(X_i, point) over columns col0 .. col0 + K - 1 of X (the
// calibration factor of Rs(Xs, Xk): every field row shares kappa).
void kernel_corr_point(int kern, const arma::mat& X, int col0, int K, const double* point,
                       const double* theta, const double* alpha, arma::vec& out);
// The lower triangle of the first s rows of X, column by column, as ne =
// s (s + 1) / 2 flat entries (Vecchia's systems): kernel_dist_tri() the
// per-dimension values G (K ne doubles, dimension after dimension),
// kernel_corr_flat() the correlations from them (kernel_corr()'s numbers;
// w: ne doubles of workspace).
void kernel_dist_tri(int kern, const arma::mat& X, int s, int K, double* G);
void kernel_corr_flat(int kern, const double* G, size_t ne, int K, const double* theta,
                      const double* alpha, double* out, double* w);
// Full correlation matrix between rows of X and Y (prediction, correlation()).
arma::mat corr_matrix(const arma::mat& X, const arma::mat& Y, const arma::vec& theta,
                      const arma::vec& alpha, int kern = 1);

// levels.cpp: the categorical inputs' level correlations ---------------------
// The number of canonical partial correlations of the categorical inputs.
int level_count(const std::vector<LevelInput>& in);
// C[f] = the levels' correlation of input f from its partial correlations,
// z[0 ..] consecutively by input (see levels.cpp).
void level_corr(const std::vector<LevelInput>& in, const double* z,
                std::vector<arma::mat>& C);
// out(i, j) *= prod_f C[f](level of X row i, level of Y row j), over the
// first `rows` rows of X and Y (-1: all; lower: X == Y and only i >= j).
void level_scale(const std::vector<LevelInput>& in, const std::vector<arma::mat>& C,
                 const arma::mat& X, const arma::mat& Y, arma::mat& out, bool lower,
                 int rows = -1);
// The level (0-based) of row i of X for categorical input f.
int level_of(const arma::mat& X, arma::uword i, const LevelInput& f);
// out(i, j) *= C[a[i], b[j]] for the L x L level correlation C of the
// partial correlations z (the field data sets' biases), over out's rows and
// columns (lower: only i >= j).
void source_scale(int L, const double* z, const int* a, const int* b, arma::mat& out,
                  bool lower);
// The same with C computed from z first; nothing without categorical inputs.
void level_scale(const std::vector<LevelInput>& in, const double* z, const arma::mat& X,
                 const arma::mat& Y, arma::mat& out, bool lower);

// linalg.cpp: dense linear algebra -------------------------------------------
// In-place lower Cholesky (LAPACK dpotrf); returns false when not PD.
bool chol_lower(arma::mat& A);
// log|A| from its lower Cholesky factor.
double logdet_chol(const arma::mat& L);
// x <- L^-1 x, L lower triangular (LAPACK dtrtrs).
void solve_lower(const arma::mat& L, arma::vec& x);
void solve_lower(const arma::mat& L, arma::mat& X);
// C <- beta C + alpha A' A (lower triangle, BLAS dsyrk).
void syrk_lower(const arma::mat& A, double alpha, double beta, arma::mat& C);
// log(2 pi), for Gaussian log-densities.
const double LOG_2PI = 1.837877066409345483560659472811;

// Two buffers for one cached quantity: the current one and a scratch one a
// proposal is written into; accepting a proposal flips them (no copy).
template <class T> struct Buf2 {
  T b[2]{};  // value-initialised: a double buffer read before its first write is 0
  int c = 0;
  T& cur() { return b[c]; }
  T& alt() { return b[1 - c]; }
  const T& cur() const { return b[c]; }
  void flip() { c = 1 - c; }
};

// Which cached blocks a move touches (see SchurPosterior::evaluate). A move
// of several parameters touches the union of what each one touches.
struct Touch {
  std::vector<char> simPow;   // per simulator input: alphaS_k moved (power matrix)
  std::vector<char> biasPow;  // per experimental input: alphaB_k moved
  bool simCorr = false;   // some thetaS/alphaS moved: Ds and its factor
  bool expDim = false;    //   ... of an experimental input: Rs(Xs,Xk), Rs(Xk,Xk)
  bool calDim = false;    //   ... of a calibration input
  bool cChange = false;   // kappa or a calibration-input thetaS/alphaS moved
  bool biasCorr = false;  // thetaB/alphaB moved
  bool cross = false;     // Rs(Xs,Xk)' Ds^-1 Rs(Xs,Xk) and Rs(Xs,Xk)' Ds^-1 ys
  bool field = false;     // the Schur complement S and its factor
  bool scale = false;     // the variances multiplied by one factor
  bool latentK = false;   // thetaG moved: the latent log-variances' prior factor
  bool latentLp = false;  // gR, muG, sigma2G or thetaG moved: their GP prior
  // nothing touched, or everything but the scale move's variances
  void all(int nSim, int nBias, bool v) {
    simPow.assign(nSim, v); biasPow.assign(nBias, v);
    simCorr = expDim = calDim = cChange = biasCorr = cross = field = latentK = latentLp = v;
    scale = false;
  }
  void reset(int nSim, int nBias) { all(nSim, nBias, false); }
  void everything(int nSim, int nBias) { all(nSim, nBias, true); }
};

// The simulator's conditional at candidate inputs for the design of new
// runs (Posterior::runConditional(), design.cpp). With y the data and C =
// L L' its covariance (any square root the algebra has; with independent
// outputs block diagonal, each candidate's column nonzero in its output's
// rows only): A = L^-1 Cov(y, eta(U)) (N x Nc), so that
// Cov(eta(U_a), eta(U_b) | y) = prior - A_a'A_b; mu and v the candidates'
// means and variances given y (a run's value: the nugget included), v0
// their prior variances; with targets XT, zeta(x) = eta(x, kappa) + delta(x)
// (predict(type = "mean")): its means mT, variances VT given y and its
// covariances CTU with the candidates' values (T x Nc).
struct RunConditional {
  arma::mat A, CTU;
  arma::vec mu, v, v0, mT, VT;
};

// The field block's covariance given the simulator runs, S = D + Z M Z'
// (field.cpp): D the field rows' noise variances d, Z each row's distinct
// row, M the distinct rows' part (its lower triangle read). factor() gives
// S = L L' (n x n Cholesky), or with `reduce` (replicated rows) works on the
// distinct rows alone (L = chol(I + N^1/2 M N^1/2), N = Z' D^-1 Z): the
// same log|S| and the same products by the whitening F^-1 (S = F F') and
// by S^-1. False where S is not positive definite, or (floor > 0) a pivot
// L_ii^2 falls below floor times the largest diagonal entry.
struct FieldFactor {
  bool reduced = false;
  arma::mat L;
  arma::vec d, sd, sN;  // reduced: d, sqrt(d), sqrt(diag(N))
  double logdet = 0.0;  // log|S|
  bool factor(const arma::mat& M, const std::vector<int>& grp, const arma::vec& dv, bool reduce,
              double floor);
  void whiten(arma::mat& X, const std::vector<int>& grp) const;  // X <- F^-1 X
  void whiten(arma::vec& x, const std::vector<int>& grp) const;
  void solve(arma::mat& X, const std::vector<int>& grp) const;   // X <- S^-1 X
  void solve(arma::vec& x, const std::vector<int>& grp) const;
  arma::mat inverse(const std::vector<int>& grp) const;          // S^-1
  void scale(double c);                                          // S -> c S
};

// The posterior's likelihood part with every factor cached, so that a move
// recomputes only the blocks it touches. This is the one interface the
// sampler (sampler.cpp) and prediction (predict.cpp) see; the algebra behind
// it is chosen by make_posterior().
// Parameter vector phi (scaled space, kappa on [0,1]) holds the classes at
// the offsets of `layout` (iKappa ... iRhoD, looked up by name in
// set_sizes()). The discrepancy model (R/model-classes.R,
// discrepancy_models) is read off the layout: a bias GP (`bias`) when
// sigma2B has parameters (else thetaB, alphaB, muB ... have none), with a
// mean (`biasMean`) when muB has, scaled (`sgasp`, the S-GaSP of Gu and
// Wang 2018: Posterior::biasModel()) when lambdaZ has: the offsets of
// empty classes are never read.
class Posterior {
public:
  virtual ~Posterior() {}
  int n, m, p, q, d;
  Layout layout;
  int iKappa, iThetaS, iAlphaS, iThetaB, iAlphaB, iSigma2S, iSigma2B, iSigma2E, iMuB, iLambdaZ;
  int iRhoS, iRhoB, iRhoD;          // the level correlations' partial correlations
  std::vector<LevelInput> levels;   // the categorical inputs (none: empty)
  bool bias;                // the model has a bias GP (sigma2B has parameters)
  bool biasMean;            // ... with a mean (muB has)
  bool sgasp;               // ... scaled, the S-GaSP (lambdaZ has)
  // the simulator's own noise (sigma2R has a parameter): the runs are the
  // unique inputs' means, so D = sigma2S (Rs + nugget I) + sigma2R
  // diag(repInv) and the log-likelihood has the replicates' within term
  // noiseLoglik() (model.cpp)
  bool simNoise = false;
  int iSigma2R = 0;
  arma::vec repInv;         // 1 / the runs at each unique input
  double repSSW = 0.0, repDf = 0.0, repLogN = 0.0;  // repLogN: sum of log n_i
  double noiseLoglik() const;
  bool fieldReal = false;   // the field's noise variance is sigma2E + sigma2R
  // an input-dependent noise (latent_noise.cpp): input i's variance is
  // exp(gR_i), gR ~ GP(muG, sigma2G Rg(thetaG)); the GP's log density is
  // part of logLik() (latentLogPrior())
  bool latent = false;
  int iG = 0, iMuG = 0, iSigma2G = 0, iThetaG = 0;
  arma::vec repSSWi, repDfi;  // per unique input: within sum of squares, n_i - 1
  // the noise variance of unique input i's mean, r_i / n_i
  double meanNoise(int i) const {
    return (latent ? std::exp(phi[iG + i]) : phi[iSigma2R]) * repInv[i];
  }
  // the latent GP's log density at the current state and the lower
  // Cholesky factor of sigma2G Rg (what elliptical slice sampling draws
  // from), and that of the pending proposal's
  virtual double latentLogPrior(bool pending) const { return 0.0; }
  virtual const arma::mat& latentFactor() const { Rcpp::stop("no latent noise"); }
  // ... and at the hyperparameters of ph (false: not positive definite)
  virtual bool latentFactorAt(const arma::vec&, arma::mat&) const { return false; }
  std::vector<int> scaled;  // the variances the scale move multiplies (in phi)
  arma::vec phi;  // current parameters

  // Set phi and compute every block; false if a covariance is not PD. (A
  // phi of another length than the layout's stops: set_phi().)
  virtual bool init(const arma::vec& phi0) = 0;
  virtual double logLik() const = 0;
  // Log-likelihood with phi[idx[i]] = values[i] for every i (-Inf if a
  // factor fails); kept in scratch buffers until accept() or reject().
  virtual double propose(const std::vector<int>& idx, const arma::vec& values) = 0;
  double propose(int j, double value) {
    one_[0] = j; oneVal_[0] = value;
    return propose(one_, oneVal_);
  }
  // Log-likelihood with the variances `scaled` (sigma2S, sigma2B if any,
  // sigma2E) all multiplied by c: C(c) = c C, so log|C| and the quadratic
  // form follow in closed form.
  virtual double proposeScale(double c) = 0;
  virtual void accept() = 0;
  virtual void reject() = 0;
  // The log-likelihood is Gaussian in muB: -0.5 |b - muB a|^2 + const with
  // a = LS^-1 1, b = LS^-1 (yf - B'D^-1 ys); returns a'a and a'b.
  virtual void muBQuadratic(double& aa, double& ab) const = 0;

  // Prediction at the current state (predict.cpp): for new experimental
  // inputs Xnew (rows, scaled) and type 1 field, 2 mean, 3 simulator,
  // 4 bias, the conditional mean and variance of the target given y; a
  // field target's measurement error is that of group noise[c] (0-based;
  // null: group 0).
  virtual void condition(const arma::mat& Xnew, int type, double* mean, double* var,
                         const int* noise = nullptr, const int* source = nullptr) = 0;
  // The held-out predictive of the simulator runs from the simulator GP
  // alone (covariance sigma2S Ds, scaled space) at the current state, one
  // fold of 0-based runs at a time (heldout.cpp); false if a fold's block
  // is not positive definite.
  virtual bool heldout(const std::vector<std::vector<int> >& folds, arma::vec& mean,
                       arma::vec& var) = 0;
  // The leave-one-out predictive of the field data at the current state
  // (loo.cpp): for each group of 0-based field rows, log p(y_G | the other
  // field rows, y_s) (scaled space), into `logdens`.
  virtual void fieldLoo(const std::vector<std::vector<int> >& groups,
                        arma::vec& logdens) const = 0;
  // A short description of the algebra (for tests and messages).
  virtual std::string algebra() const = 0;
  // The simulator runs' quadratic form zz = ys' Ds^-1 ys (correlation units)
  // at a proposal of the simulator GP's correlation parameters alone
  // (phi[idx[i]] = values[i]; no variance among them), ahead of propose():
  // an algebra that can (Vecchia) computes it without changing the state and
  // keeps it, so that a propose() of the same correlation parameters right
  // after does not compute it again. Returns false where the algebra cannot
  // (the sampler then makes the plain joint move); ok = false when Ds is not
  // positive definite at the proposal.
  virtual bool simPreview(const std::vector<int>&, const arma::vec&, double& zz, bool& ok) {
    zz = NA_REAL; ok = false;
    return false;
  }
  // Can it (simPreview())? And zz at the current state (NaN where not).
  virtual bool canPreview() const { return false; }
  virtual double currentZz() const { return NA_REAL; }

  // The simulator's conditional at candidate inputs U (Nc x (p + q), any
  // calibration input) and the targets XT (T x p, none: 0 rows) at the
  // current state (RunConditional; the design of new runs, design.cpp).
  virtual void runConditional(const arma::mat&, const arma::mat&, RunConditional&) {
    Rcpp::stop("the design of new runs needs a simulator GP");
  }
  // The simulator's prior covariance s2S Rs(X, Y) between rows of X and Y
  // (p + q columns) at parameters ph, which need not be the state's.
  virtual void runPrior(const arma::vec&, const arma::mat&, const arma::mat&, arma::mat&) const {
    Rcpp::stop("the design of new runs needs a simulator GP");
  }

  // The discrepancy model's bias correlation on the distinct field inputs
  // from the bias GP's R, and its cross-correlation and variance at new
  // inputs (model.cpp; Ruu() gives R on the distinct inputs if needed; the
  // look-ahead, design.cpp, calls them too).
  bool biasModel(arma::mat& R, arma::mat& B, arma::mat& W) const;
  void biasModelCross(const std::function<arma::mat()>& Ruu, arma::mat& K, arma::vec& r) const;

protected:
  void set_sizes(int n_, int m_, int p_, int q_, const Model& model);
  // phi = phi0, which must have the layout's d entries (every init()).
  void set_phi(const arma::vec& phi0) {
    if ((int) phi0.n_elem != d)
      Rcpp::stop("phi has %d entries where the model's layout has %d", (int) phi0.n_elem, d);
    phi = phi0;
  }
  // The field rows' groups (model.fieldRows, checked against Xf, or found
  // here by exact equality without it): field row i is distinct row
  // grp_[i] of Xu_ (nu_ x p), in measurement-error group noise_[i]; srcU_
  // the data set of each distinct row (sourceL_ data sets with a bias each,
  // 0: one bias).
  void set_field(const arma::mat& Xf, const Model& model);
  int nu_ = 0, sourceL_ = 0;
  arma::mat Xu_;
  std::vector<int> grp_, noise_, srcU_;
  // log p(y_G | the rest) per group G from the field block's inverse S^-1
  // and residual r (loo.cpp); a'a and a'b with a = F^-1 1, b = F^-1 r
  // (S = F F', FieldFactor; the exact muB draw's quadratic).
  static void gaussian_loo(const arma::mat& Sinv, const arma::vec& r,
                           const std::vector<std::vector<int> >& groups, arma::vec& logdens);
  static void mub_quadratic(const FieldFactor& FS, const std::vector<int>& grp, arma::vec r,
                            double& aa, double& ab);
  std::vector<int> one_ = std::vector<int>(1);
  arma::vec oneVal_ = arma::vec(1);

  // The parameters a proposal overwrote and their old values, so that
  // reject() puts them back: every subclass's propose() and proposeScale()
  // go through saveSet() / saveScale(), its reject() through restore().
  std::vector<int> oldIdx_;
  arma::vec oldVal_;
  // phi[idx[i]] = values[i] for every i, the old values saved.
  void saveSet(const std::vector<int>& idx, const arma::vec& values) {
    oldIdx_ = idx;
    oldVal_.set_size(idx.size());
    for (size_t i = 0; i < idx.size(); ++i) {
      oldVal_[i] = phi[idx[i]];
      phi[idx[i]] = values[i];
    }
  }
  // phi[scaled] *= c, the old values saved.
  void saveScale(double c) {
    arma::vec v(scaled.size());
    for (size_t i = 0; i < scaled.size(); ++i) v[i] = phi[scaled[i]] * c;
    saveSet(scaled, v);
  }
  // The factor c of the pending scale move: new / old of its first variance.
  double pendingScale() const { return phi[oldIdx_[0]] / oldVal_[0]; }
  // Put back what the pending proposal overwrote.
  void restore() {
    for (size_t i = 0; i < oldIdx_.size(); ++i) phi[oldIdx_[i]] = oldVal_[i];
  }
};

// The one per-draw loop of the entry points that evaluate the posterior at
// given draws (prediction, held-out runs, leave-one-out): for each row i of
// `phis` the posterior is set to it (its factors from scratch) and f(i)
// runs; a draw whose covariance is not positive definite (init() or f(i)
// false) is an error naming it. Checks for an interrupt every 100 draws.
template <class F>
void for_each_draw(Posterior& post, const arma::mat& phis, F f) {
  if (phis.n_cols != (arma::uword)post.d) Rcpp::stop("phis must have %d columns", post.d);
  for (arma::uword i = 0; i < phis.n_rows; ++i) {
    if (!post.init(phis.row(i).t()) || !f(i))
      Rcpp::stop("The covariance matrix of draw %d is not positive definite.", (int)i + 1);
    if (i % 100 == 99) Rcpp::checkUserInterrupt();
  }
}

// latent_noise.cpp: one elliptical slice sampling update of the latent
// log-variances gR (the chain's log-likelihood ll and log priors lp
// updated; lpOf(j, x): parameter j's log prior at x); the proposals made,
// 0 when none was accepted.
int latent_ess(Posterior& post, double& ll, arma::vec& lp,
               const std::function<double(int, double)>& lpOf);
// ... and one joint walk of the latent GP's hyperparameters hyp (walks tr,
// step s on their scale) with the whitened latent values held fixed (true:
// accepted)
bool latent_shift(Posterior& post, double& ll, arma::vec& lp, const std::vector<int>& hyp,
                  const std::vector<int>& tr, double s,
                  const std::function<double(int, double)>& lpOf);

// The classes the compiled core computes with, one row each (model.cpp):
// its name, the parameters the data need (p experimental and q calibration
// inputs, K outputs; e, b: a simulator GP, a bias GP; G noise groups; lc,
// ld level correlations; u unique runs with an input-dependent noise),
// whether a model may have none instead (a class of some models only), the
// member holding its offset and the algebras that compute with it (AlgebraKind
// bits; all unless the row says). read_model() checks the lengths and the
// algebras, set_sizes() looks up the offsets and make_posterior() takes the
// Kronecker algebra only where its classes allow, by these rows; R's table
// (model_classes) may hold more classes, and must name these
// (check_model_codes()); R reads the algebras (.class_algebras()).
enum AlgebraKind { AK_DENSE = 1, AK_KRONECKER = 2, AK_VECCHIA = 4, AK_FUNCTION = 8, AK_OUTPUTS = 16,
                   AK_ALL = 31 };
struct ClassNeed {
  const char* name; int length; bool optional; int Posterior::* offset;
  unsigned algebras = AK_ALL;
};
std::vector<ClassNeed> class_needs(int p, int q, int K, int e, int b, int G, int lc, int ld,
                                   int u);
// The first class of `lay` (with parameters) that an algebra of kind `kind`
// (AlgebraKind bits, all of which must compute with it) does not compute
// with; nullptr when there is none.
const char* class_outside(const Layout& lay, unsigned kind);

// Everything but the simulator block: the field block, its Schur
// complement S = sigma2S Q + sigma2B Rb + sigma2E I (no Rb term without a
// bias) with
// Q = Rs(Xk,Xk) - Rs(Xs,Xk)' Ds^-1 Rs(Xs,Xk), the residual and the moves'
// bookkeeping (model.cpp). The simulator algebra behind it supplies
// log|Ds|, ys' Ds^-1 ys, Q and Rs(Xs,Xk)' Ds^-1 ys through the sim*() hooks.
class SchurPosterior : public Posterior {
public:
  bool init(const arma::vec& phi0) override;
  double logLik() const override { return loglik_.cur(); }
  double propose(const std::vector<int>& idx, const arma::vec& values) override;
  double proposeScale(double c) override;
  void accept() override;
  void reject() override;
  void muBQuadratic(double& aa, double& ab) const override;
  void condition(const arma::mat& Xnew, int type, double* mean, double* var,
                 const int* noise = nullptr, const int* source = nullptr) override;
  bool heldout(const std::vector<std::vector<int> >& folds, arma::vec& mean,
               arma::vec& var) override;
  void fieldLoo(const std::vector<std::vector<int> >& groups,
                arma::vec& logdens) const override;
  void runConditional(const arma::mat& U, const arma::mat& XT, RunConditional& out) override;
  void runPrior(const arma::vec& ph, const arma::mat& X, const arma::mat& Y,
                arma::mat& K) const override;
  // The simulator's conditional mean given y at the current state as a
  // kernel expansion (sensitivity.cpp): E[eta(z) | y] = sum_j w_j Rs(z, Z_j)
  // over the centres Z = (Xs; the distinct field rows at kappa); with
  // support points P a conditional sample path through them (centres P added);
  // wb: the bias's mean as s2B Rb(x, Xu) wb over the distinct field inputs.
  void simMean(arma::mat& Z, arma::vec& w, const arma::mat* P = nullptr,
               arma::vec* wb = nullptr);

protected:
  // x <- Ds^-1 x at the current state (sensitivity.cpp; by default from
  // simHeldout()'s inverse, an algebra may do better).
  virtual void simSolve(arma::vec& x);
  SchurPosterior(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                 const arma::vec& ys, double nugget, const Model& model);
  const arma::mat& Xf_; const arma::vec& yf_;
  const arma::mat& Xs_; const arma::vec& ys_;
  double nugget_;
  bool scratch_ = false;   // init(): S factored from scratch, no pivot floor (see evaluate())
  int kernS_, kernB_;

  // The simulator algebra, at the proposal (scratch buffers):
  // update what t touches, setting ldDs = log|Ds| and zz = ys' Ds^-1 ys
  // when t.simCorr (false if Ds is not PD);
  virtual bool simUpdate(const Touch& t, double& ldDs, double& zz) = 0;
  // Q = Rkk - Rs(Xs,Xk)' Ds^-1 Rs(Xs,Xk) (lower) and wz = Rs(Xs,Xk)' Ds^-1 ys
  // over the distinct field rows (called when t.cross);
  virtual void simCross(const Touch& t, const arma::mat& Rkk, arma::mat& Q, arma::vec& wz) = 0;
  // make the scratch buffers of simUpdate(t) current;
  virtual void simFlip(const Touch& t) = 0;
  // at the current state, for targets k_c = Rs(Xs, (Xnew_c, kappa)):
  // a_c = k_c' Ds^-1 ys, b_c = k_c' Ds^-1 k_c, G = Rs(Xs,Xk)' Ds^-1 K (nu x b).
  virtual void simCondition(const arma::mat& Xnew, arma::vec& a, arma::vec& b,
                            arma::mat& G) = 0;
  // at the current state, what the held-out formulas need from Ds^-1:
  // a = Ds^-1 ys and, per fold B (0-based runs), QBB[k] = (Ds^-1)_BB.
  virtual void simHeldout(const std::vector<std::vector<int> >& folds, arma::vec& a,
                          std::vector<arma::mat>& QBB) = 0;
  // at the current state, a square root of Ds^-1 applied to the runs'
  // correlations with points Z (p + q columns, any calibration input):
  // W (r x nz) with W_a'W_b = Rs(Xs, Z_a)' Ds^-1 Rs(Xs, Z_b), wy with
  // W'wy = Rs(Xs, Z)' Ds^-1 ys, and G = Rs(Xs,Xk)' Ds^-1 Rs(Xs, Z) (nu x nz);
  // haveW: W and wy are given (they depend on the simulator's correlation
  // parameters alone), only G is wanted.
  virtual void simWhiten(const arma::mat& Z, arma::mat& W, arma::vec& wy, arma::mat& G,
                         bool haveW) = 0;

private:
  Touch touch_;
  std::vector<Buf2<arma::mat> > Pfs_, Pfb_;
  std::vector<arma::mat> Gf_;  // per experimental input: field-field kernel_dist
  std::vector<arma::mat> Gfb_; // ... for the bias GP's family when it differs
  std::vector<const arma::mat*> ptrF_, ptrB_;
  Buf2<arma::mat> Rkk_, Q_, Rb_;
  Buf2<FieldFactor> FS_;  // the field block's factor (fieldFactor())
  arma::mat M_;           // its distinct rows' part
  arma::vec dv_;          // ... and the rows' noise variances
  Buf2<arma::vec> wz_;
  Buf2<double> ldDs_, zz_, ldS_, vv_, loglik_;
  arma::vec u_;
  // the latent noise's GP prior (latent_noise.cpp): chol(Rg + jitter I),
  // its log determinant, the log density; latentK_ the factor times
  // sqrt(sigma2G), built when asked (latentFactor())
  Buf2<arma::mat> Lg_;
  Buf2<double> ldG_, lpG_;
  mutable arma::mat latentK_;
  bool latentPrior(const Touch& t, double& lp);
public:
  double latentLogPrior(bool pending) const override { return pending ? lpG_.b[1 - lpG_.c] : lpG_.cur(); }
  const arma::mat& latentFactor() const override;
  bool latentFactorAt(const arma::vec& ph, arma::mat& C) const override;
private:
  // runConditional()'s runs' part at the candidates, kept while the
  // simulator's correlation parameters (runKey_) and the candidates stay
  arma::vec runKey_, runWy_;
  arma::mat runU_, runW_;
  double evaluate(const Touch& t);
  double loglik(double ldDs, double zz, double ldS, double vv, double lpG);
  bool fieldFactor(const arma::mat& Q, const arma::mat* Rb, double s2S, double s2B, double& ldS);
  void flip(const Touch& t);
  void add_touch(int j, Touch& t) const;
  // the bias's correlation with new inputs (see model.cpp)
  void biasCross(const arma::mat& Xnew, arma::mat& K, arma::vec& r,
                 const int* source = nullptr) const;
  // out(i, j) *= the bias's level correlations between row i of X (field
  // data set srcX[i]) and row j of Y (srcY[j]): rhoB's, and rhoD's with a
  // bias per data set (see model.cpp)
  void biasLevels(const arma::mat& X, const int* srcX, const arma::mat& Y, const int* srcY,
                  arma::mat& out, bool lower) const;
  arma::mat Bz_, Wz_;  // S-GaSP workspaces

public:
  double currentZz() const override { return zz_.cur(); }

protected:
  // Q and wz at the current state (Q: lower triangle), for an algebra's
  // prediction.
  const arma::mat& curQ() const { return Q_.cur(); }
  const arma::vec& curWz() const { return wz_.cur(); }
};

// The dense algebra: the Cholesky factor of the m x m simulator block
// (dense.cpp). Per-dimension power matrices are cached while they fit in the
// cache budget; beyond it the correlation is formed on the fly, from packed
// log-distances of at most 4 inputs (2 m^2 doubles).
class DensePosterior : public SchurPosterior {
public:
  DensePosterior(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                 const arma::vec& ys, double nugget, const Model& model);
  std::string algebra() const override { return cached_ ? "dense (cached)" : "dense"; }

protected:
  bool simUpdate(const Touch& t, double& ldDs, double& zz) override;
  void simCross(const Touch& t, const arma::mat& Rkk, arma::mat& Q, arma::vec& wz) override;
  void simFlip(const Touch& t) override;
  void simCondition(const arma::mat& Xnew, arma::vec& a, arma::vec& b, arma::mat& G) override;
  void simHeldout(const std::vector<std::vector<int> >& folds, arma::vec& a,
                  std::vector<arma::mat>& QBB) override;
  void simWhiten(const arma::mat& Z, arma::mat& W, arma::vec& wy, arma::mat& G,
                 bool haveW) override;
  void simSolve(arma::vec& x) override;  // two triangular solves (sensitivity.cpp)

private:
  bool cached_;
  std::vector<Buf2<arma::mat> > Ps_, Px_;
  // log-distances per input dimension (fixed): sim-sim, sim-field
  std::vector<arma::mat> Gs_, Gx_;
  std::vector<const arma::mat*> ptrS_, ptrX_;
  // beyond the budget: packed log-distances of up to 4 simulator inputs
  std::vector<std::vector<double> > Gp_;
  std::vector<const double*> ptrG_;
  Buf2<arma::mat> Ls_, Rx_, W_;
  Buf2<arma::vec> z_, c_;
  arma::mat K_;  // prediction workspace
};

// A simulator design that is every combination of I settings of one group
// of input columns (ca) and J settings of the others (cb): row r of Xs is
// Xg[ix[r]] in columns ca and Tg[jt[r]] in columns cb. `classic`: ca the p
// experimental columns, cb the q calibration ones. Some combinations may
// have no run (missing cells, at most as many as the runs).
struct ProductDesign {
  int I = 0, J = 0;
  arma::mat Xg, Tg;
  std::vector<int> ix, jt;
  arma::uvec ca, cb;
  bool classic = true;
  std::vector<int> mi, mj;  // the missing cells (Xg[mi[s]], Tg[mj[s]]): no run
};
// True (and the design filled in) when Xs (m x (p + q)) is such a design,
// rows compared exactly, in any row order, and its eigendecompositions cost
// less than one m x m Cholesky factor: the experimental x calibration split
// when it is one, else (`general`) the cheapest other split of the columns.
bool product_design(const arma::mat& Xs, int p, ProductDesign& out, bool general = false);
bool kronecker_pays(const ProductDesign& pd);

// The Kronecker algebra on a product design (kronecker.cpp):
// Ds = Rx (x) Rt + nugget I = (Ux (x) Ut) diag(lx_i lt_j + nugget) (Ux (x) Ut)'.
class KroneckerPosterior : public SchurPosterior {
public:
  KroneckerPosterior(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                     const arma::vec& ys, double nugget, const Model& model,
                     const ProductDesign& design);
  std::string algebra() const override;

protected:
  bool simUpdate(const Touch& t, double& ldDs, double& zz) override;
  void simCross(const Touch& t, const arma::mat& Rkk, arma::mat& Q, arma::vec& wz) override;
  void simFlip(const Touch& t) override;
  void simCondition(const arma::mat& Xnew, arma::vec& a, arma::vec& b, arma::mat& G) override;
  void simHeldout(const std::vector<std::vector<int> >& folds, arma::vec& a,
                  std::vector<arma::mat>& QBB) override;
  void simWhiten(const arma::mat& Z, arma::mat& W, arma::vec& wy, arma::mat& G,
                 bool haveW) override;
  void simSolve(arma::vec& x) override;  // by the eigendecompositions (complete grids)

private:
  // the algebra of the full grid (ys zero at the missing cells); the
  // sim*() hooks add the missing cells' corrections to it
  bool gridUpdate(const Touch& t, double& ldDs, double& zz);
  void gridCross(const Touch& t, const arma::mat& Rkk, arma::mat& Q, arma::vec& wz);
  void gridCondition(const arma::mat& Xnew, arma::vec& a, arma::vec& b, arma::mat& G);
  arma::vec atMissing(const arma::mat& Ux, const arma::mat& Ut, const arma::mat& Li,
                      const arma::mat& X) const;
  arma::mat missSolve(const arma::mat& Ux, const arma::mat& Ut, const arma::mat& Li,
                      const arma::mat& L, const arma::mat& A, const arma::mat& B) const;
  void targetFactors(const arma::mat& Xnew, arma::mat& an, arma::mat& bn);
  Buf2<arma::mat> Lm_;  // the factor of (Ds^-1)_mm over the missing cells
  Buf2<arma::vec> hv_;  // Lm^-1 (Ds^-1 y0)_m
  void split_levels();
  // the general split: group g's correlation between its grid and the rows
  // of Zg (g's columns); which buffers a move touches
  arma::mat groupCorr(int g, const arma::mat& Zg) const;
  bool moved(const Touch& t, int g) const {
    return t.simCorr && ((t.expDim && hasExp_[g]) || (t.calDim && hasCal_[g]));
  }
  bool fieldMoved(const Touch& t, int g) const {
    return moved(t, g) || (t.cChange && hasCal_[g]);
  }
  ProductDesign dz_;
  bool hasExp_[2], hasCal_[2];
  Buf2<arma::mat> Bf_;               // general split: Ut' Rs_B(Tg, field rows)
  arma::mat Wg_;
  arma::mat Y_;                      // ys as an I x J matrix
  // When the experimental settings Xg are themselves every combination of
  // T level tuples of the categorical inputs and R numeric settings, Rx =
  // Ct (x) Rn up to the order of Xg's rows (kronecker.cpp): setting k is
  // tuple tk_[k] at numeric setting rk_[k]; Xt_ (T x p) holds a setting of
  // each tuple at one numeric setting, Xn_ (R x p) each numeric setting at
  // one tuple.
  bool split_ = false;
  std::vector<int> tk_, rk_;
  arma::mat Xt_, Xn_, Ct_, Rn_, Uc_, Un_;
  arma::vec lc_, ln_;
  Buf2<arma::mat> Ux_, Ut_, Ax_, Yt_;
  Buf2<arma::vec> lx_, lt_, c_, ct_, w_, g_;
  arma::mat Rx_, Rt_, Rxf_, An_;     // workspaces
};

// The nearest-neighbour (Vecchia) algebra (vecchia.cpp): the runs and the
// field latents as nodes of a graph, each conditioned on its nearest
// predecessors; no m x m matrix is formed.
class VecchiaPosterior : public SchurPosterior {
public:
  VecchiaPosterior(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                   const arma::vec& ys, double nugget, const Model& model);
  std::string algebra() const override;
  bool simPreview(const std::vector<int>& idx, const arma::vec& values, double& zz,
                  bool& ok) override;
  bool canPreview() const override { return true; }

protected:
  bool simUpdate(const Touch& t, double& ldDs, double& zz) override;
  void simCross(const Touch& t, const arma::mat& Rkk, arma::mat& Q, arma::vec& wz) override;
  void simFlip(const Touch& t) override;
  void simCondition(const arma::mat& Xnew, arma::vec& a, arma::vec& b, arma::mat& G) override;
  void simHeldout(const std::vector<std::vector<int> >& folds, arma::vec& a,
                  std::vector<arma::mat>& QBB) override;
  void simWhiten(const arma::mat& Z, arma::mat& W, arma::vec& wy, arma::mat& G,
                 bool haveW) override;
  void simSolve(arma::vec& x) override;  // Ds^-1 ~ U U', for the kernel expansion

private:
  // the runs' pass (simUpdate()) at phi: log|Ds|, zz; false if not PD
  bool runsPass(double& ldDs, double& zz);
  // the simulator GP's correlation parameters of phi (thetaS, alphaS, rhoS)
  arma::vec simKey() const;
  // the last simPreview(): at correlation parameters previewKey_ its
  // log|Ds|, zz and whether Ds was PD (previewSet_: not used yet)
  arma::vec previewKey_;
  double previewLd_ = 0, previewZz_ = 0;
  bool previewOk_ = false, previewSet_ = false;
  VecchiaDesign vd_;
  std::vector<std::vector<int> > nbrL_;  // each field latent's earlier latents
  Buf2<std::vector<int> > nbrF_;         // the field latents' runs (nu x k) at kappa
  // one conditional's system, one per thread: rows Xg, factor Kw, rhs; the
  // distances, correlations, products (Gw, Cw, Ww); fieldNeighbours()'
  // (d2, run) of the runs that may be among a latent's k nearest
  struct Work {
    arma::mat Kw, Xg;
    arma::vec rhs;
    std::vector<double> Gw, Cw, Ww, x;
    std::vector<int> rid;  // the run of each of Xg's run rows

    std::vector<std::pair<double, int> > cand;
  };
  std::vector<Work> ws_;
  int nt_ = 1;                           // threads
  std::vector<double> runLd_, runZz_;    // runsPass()'s per-run terms, summed in order
  arma::vec levelZ_;                     // rhoS the level correlations levelC_ are of
  std::vector<arma::mat> levelC_;
  void syncLevels();
  std::vector<int> xOrd_;                // per field input the runs by their scaled
  std::vector<double> xD2_;              // squared distance's experimental part (m x nu)
  arma::mat dt_;                         // m x q workspace: (w (t - kappa))^2
  // the runs' conditioning sets' distance values (cacheRuns()): run i's
  // c_i = runC_[i] neighbours, its values from runOff_[i] in runG_ (empty:
  // not cached)
  std::vector<int> runC_;
  std::vector<size_t> runOff_;
  std::vector<double> runG_;
  void cacheRuns();
  // simCross()'s latent algebra: each latent's earlier latents by index
  // (latent, place in nbrL_), M's entries of each row, g and h, Mi and Mi
  // diag(g) (latentSolve())
  std::vector<std::vector<std::pair<int, int> > > rowL_;
  std::vector<std::vector<double> > cL_;
  arma::vec hL_, gL_;
  arma::mat Mi_, Ag_;
  void latentSolve(arma::mat& Q, arma::vec& wz);
  const double* runDist(int i) const { return runG_.empty() ? nullptr : runG_.data() + runOff_[i]; }
  double conditional(Work& w, int s, int runs, bool coef, const double* G = nullptr,
                     const double* y = nullptr) const;
  void fieldNeighbours(std::vector<int>& nbrF, const std::vector<int>& prev);
  int gather(Work& w, const int* nb, int c, const std::vector<int>& L, const double* x) const;
  int gatherRun(Work& w, int i) const;
  // a run's diagonal in correlation units: the nugget, and with the
  // simulator's own noise its mean's noise variance over sigma2S
  double runDiag(int j) const {
    return simNoise ? nugget_ + meanNoise(j) / phi[iSigma2S] : nugget_;
  }
};

// Independent outputs (outputs.cpp): the covariance of (yf, ys) is block
// diagonal over the outputs, so log L = sum_o log L_o(kappa, phi_o), each
// output's block a posterior of its own (its algebra chosen as for one
// output) over its rows, its parameters a map into the common phi.
// `block` builds one output's posterior (posterior.cpp).
typedef std::unique_ptr<Posterior> (*BlockFactory)(const arma::mat&, const arma::vec&,
                                                   const arma::mat&, const arma::vec&, double,
                                                   const Model&);
class OutputsPosterior : public Posterior {
public:
  OutputsPosterior(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                   const arma::vec& ys, double nugget, const Model& model, BlockFactory block);
  bool init(const arma::vec& phi0) override;
  double logLik() const override { return ll_; }
  double propose(const std::vector<int>& idx, const arma::vec& values) override;
  double proposeScale(double c) override;
  void accept() override;
  void reject() override;
  void muBQuadratic(double& aa, double& ab) const override;
  void condition(const arma::mat& Xnew, int type, double* mean, double* var,
                 const int* noise = nullptr, const int* source = nullptr) override;
  bool heldout(const std::vector<std::vector<int> >& folds, arma::vec& mean,
               arma::vec& var) override;
  void fieldLoo(const std::vector<std::vector<int> >& groups,
                arma::vec& logdens) const override;
  void runConditional(const arma::mat& U, const arma::mat& XT, RunConditional& out) override;
  void runPrior(const arma::vec& ph, const arma::mat& X, const arma::mat& Y,
                arma::mat& K) const override;
  std::string algebra() const override;

private:
  int K_;
  LevelInput out_;
  std::vector<Model> subModel_;
  // each output's data (the sub-posteriors hold references into these)
  std::vector<arma::mat> Xf_, Xs_;
  std::vector<arma::vec> yf_, ys_;
  std::vector<std::vector<int> > rowsF_, rowsS_;  // their rows in the whole data
  std::vector<int> localF_, localS_;              // a row's place in its output's
  std::vector<int> outF_, outS_;                  // ... and its output
  std::vector<std::vector<int> > map_;            // output o's parameter k: phi[map_[o][k]]
  std::vector<int> owner_, local_;                // phi[j]: its output (-1 kappa), place
  std::vector<std::vector<int> > groupLocal_;     // output o: global noise group -> its own
  std::vector<std::unique_ptr<Posterior> > sub_;
  std::vector<double> llo_, llNew_;
  std::vector<char> touched_;
  double ll_ = 0.0, llProp_ = 0.0;
  bool scaleMove_ = false;
  void sub_model(const Model& model, int o, Model& sub);
};

// The algebra for the data at hand: Kronecker on a product design unless
// `model.algebra` is ALG_DENSE, else dense.
std::unique_ptr<Posterior> make_posterior(const arma::mat& Xf, const arma::vec& yf,
                                          const arma::mat& Xs, const arma::vec& ys,
                                          double nugget, const Model& model);
// ... with the model as R hands it over (read_model()).
std::unique_ptr<Posterior> make_posterior(const arma::mat& Xf, const arma::vec& yf,
                                          const arma::mat& Xs, const arma::vec& ys,
                                          double nugget, const Rcpp::List& model);

// The posterior of a simulator given as an R function (function.cpp):
// `sim` holds the closures R builds (R/simulator_function.R): field(u),
// the scaled f at the field rows for kappa u (sampler's scale), and
// at(Xnew, u), the scaled f at new scaled inputs.
std::unique_ptr<Posterior> make_function_posterior(const arma::mat& Xf, const arma::vec& yf,
                                                   const Model& model, const Rcpp::List& sim);

// The rows of each label (labels 1 .. k over n rows, each used; heldout.cpp):
// the folds of emulator_cv() and the groups of loo().
std::vector<std::vector<int> > label_groups(const Rcpp::IntegerVector& labels, int n,
                                            const char* what);

// Bytes the dense algebra may spend on per-dimension caches (dense.cpp).
extern double fbc_cache_budget;

// Small matrices without LAPACK calls (the Vecchia algebra's conditionals,
// vecchia.cpp), inline for their hot loops.

// In-place lower Cholesky of the leading s x s block of A (leading dimension
// lda), carried on over rows s .. rows - 1 (A[r, j] -> (A[r, j] - sum_l<j
// A[r, l] L[j, l]) / L[j, j]: a row b there becomes L^-1 b); false when not
// positive definite. Small matrices: no LAPACK call. Left-looking by
// columns: column j less L[j, l] times column l for l = 0 .. j - 1 (each
// entry subtracts its products in the order of l, as the dot-product form
// does; the columns are contiguous and their entries independent).
inline bool small_chol(double* A, int s, int lda, int rows) {
  for (int j = 0; j < s; ++j) {
    double* cj = A + (size_t) j * lda;
    for (int l = 0; l < j; ++l) {
      const double* cl = A + (size_t) l * lda;
      const double ljl = cl[j];
      for (int i = j; i < rows; ++i) cj[i] -= cl[i] * ljl;
    }
    double d = cj[j];
    if (!(d > 0)) return false;
    d = std::sqrt(d);
    cj[j] = d;
    for (int i = j + 1; i < rows; ++i) cj[i] = cj[i] / d;
  }
  return true;
}

// Solves L' x = b in place (L lower, leading s x s block of A): the
// coefficients of a Vecchia conditional from its factor's last row.
inline void small_back(const double* A, int s, int lda, double* x) {
  for (int i = s - 1; i >= 0; --i) {
    double v = x[i];
    for (int l = i + 1; l < s; ++l) v -= A[(size_t) i * lda + l] * x[l];
    x[i] = v / A[(size_t) i * lda + i];
  }
}

#endif
