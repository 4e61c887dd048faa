// Adaptive Metropolis-within-Gibbs sweep over phi (vignette 3.4, A.2).
//
// A sweep visits the free parameters in the order of phi and makes one move
// for each, every move an exact Metropolis-Hastings (or Gibbs) update of the
// posterior p(phi | y) given the rest:
// * single-site: x_j moves by a Gaussian random walk on w = g(x_j) (identity
//   for kappa and muB, log for theta and variances, logit of x - 1 for alpha),
//   accepted with
//     log r = log L(phi*) + log p(x*) - log L(phi) - log p(x)
//             + log|dx/dw|(x*) - log|dx/dw|(x);
//   during burn-in its log SD adapts towards acceptance 0.44 (the one
//   adaptation rule below);
// * block (at the block's first parameter): all its parameters move at once,
//   w* = w + exp(s) L e, e ~ N(0, I), with the same acceptance ratio summed
//   over the block. L starts as diag(proposal SDs) and, after 100 burn-in
//   sweeps, becomes the Cholesky factor of the running covariance of w over
//   burn-in (refreshed every 50 sweeps, Haario et al. 2001); s adapts towards
//   acceptance 0.234 (0.44 for one parameter). After a warm-up of
//   data-dependent length a simulator block of 2 to 4 walked parameters
//   proposes instead w* ~ t_7(mu, C) (mu, C its warm-up
//   estimate; independence Metropolis-Hastings, log r adding log q(w) -
//   log q(w*));
// * overlay block (after the per-parameter moves, before the jumps): a
//   block, as above, over parameters that also have moves of their own
//   (kappa's joint walk beside each kappa's walk and jump: calibration
//   inputs that trade off, only a combination of them identified, move
//   along their ridge together, which no one-parameter move can);
// * muB (gaussian prior N(m0, s0^2)): drawn exactly from its full conditional,
//   log L being Gaussian in muB (Posterior::muBQuadratic): precision
//   a'a + 1/s0^2, mean (a'b + m0/s0^2) / precision (no muB without a bias);
// * scale (after the sweep): the k variances that exist (sigma2S, sigma2B
//   with a bias, sigma2E) all multiplied by c = exp(e), e ~ N(0, exp(2 s)):
//   a joint random walk on their logs, whose likelihood needs no
//   factorization (C -> c C); log r adds the k prior ratios and the
//   Jacobian k e. s adapts towards 0.44 like a single site.
// One adaptation rule for every adapted scale: at the end of burn-in batch b
// (every 50 sweeps), log s moves by +min(0.5, 1/sqrt(b)) when the batch's
// acceptance rate is above the move's target, by -min(0.5, 1/sqrt(b))
// otherwise (adapt_step()).
// Warm-up of data-dependent length (nBurn < 0, R's nBurn = NULL): the
// same adaptation, in windows of WINDOW sweeps. A window is settled when
// every adapted move's acceptance over it is within WARM_BAND of its
// target, the log size of its proposal (log s, plus log det(L)^(1/k) for a
// block) has moved by at most WARM_DRIFT adaptation steps over the last two
// windows (the rule's +-steps cancel around the right scale and add up
// while it is still walking), every block is shaped, its shape within
// exp(WARM_SHAPE) of the previous window's, and a joint block of at least
// WARM_ESS_K walked parameters holds warmESS effective draws per parameter
// (Block::window_ess()). Warm-up ends at the end of the second settled
// window in a row, at the earliest after warmMin sweeps, at warmMax in any
// case (warmCapped). The joint proposals' covariance estimate is kept by
// window, in epochs that double, each earlier epoch weighted `forget`
// times the next (Block::pooled()): 0 restarts the estimate at 200, 400,
// 800, ..., whose effective draws had to be earned again after every
// restart; 0.5 changes it smoothly and leaves the drift from the start
// little weight. The decision is part of the chain's state, so a run split
// into pieces ends warm-up at the same sweep.
// Every move owns its state (Move; NIMBLE's samplers the model); the chain
// keeps only the sweep clock, the log densities and the warm-up's decision.
// Every adapted scale is frozen after burn-in, so the retained draws come
// from one valid kernel. The sampler's whole state goes in and comes out as
// a list: a run split into pieces (update(), checkpoints) is the same run,
// given R's RNG state.
#include "fbc.h"
#include <cli/progress.h>
#include <climits>
#include <algorithm>

static void check_interrupt_fn(void*) { R_CheckUserInterrupt(); }
// TRUE when the user pressed Ctrl-C (the interrupt is consumed here so the
// draws made so far can be returned).
static bool user_interrupted() {
  return !R_ToplevelExec(check_interrupt_fn, NULL);
}

static const int BATCH = 50;
static const int WINDOW = 100;  // sweeps per warm-up window (a multiple of BATCH)
static const double WARM_BAND = 0.15, WARM_DRIFT = 2.5, WARM_SHAPE = 0.3;
// the effective-draws rule holds blocks of at least this many parameters
// (a smaller block's shape is learnt soon enough: with the rule on every
// joint block the ball drop's blocks of 2 and 3 parameters ran warm-up to
// 700-900 sweeps and the default run took 10.5 CPU s against
// RobustCalibration's 10.2 in the same process; held to blocks of 4 or
// more, 300-500 sweeps and 4.9 s against 5.7; RESULTS-defaults.md)
static const int WARM_ESS_K = 4;
// the independence proposal of a simulator block after warm-up
// (BlockMove): a multivariate t with IND_NU degrees of freedom whose scale
// matrix is IND_INFLATE^2 times the warm-up's covariance estimate. At
// m = 1000 (bench/RESULTS-defaults.md, 2 chains x 6000 sweeps, seed 1)
// inflation 1.0 accepted 0.28 and gave the slowest thetaS a bulk ESS of
// 1072 per 3700 draws; inflation 1.2 797 (nu = 20: 968, acceptance 0.22),
// 1.5 460 (acceptance 0.12); the walk it replaces 236.
static const double IND_NU = 7, IND_INFLATE = 1.0;
// ... and only for blocks of at most IND_MAX_K walked parameters: at
// m = 20,000 (5 walked) the warm-up's estimate was 1.6-3.9 times wider than
// the posterior (the drift of its earlier epochs) and 0.8-1.4 sd off its
// centre, and the proposal accepted 18 of 400 (a walk there: 0.29); at
// m = 1000 (4 walked) it accepted 0.28 with 4.5 times the walk's ESS. A
// check of the proposal per chain (a trial in warm-up) would lift this.
static const int IND_MAX_K = 4;

// prior on parameter j: family code, parameters, and the affine map
// prior argument = a + b * phi_j (kappa is stored on the [0,1] scale).
struct Priors {
  Rcpp::IntegerVector family, transform;
  Rcpp::NumericVector p1, p2, a, b, lconst;
  double operator()(int j, double x) const {
    return log_prior(family[j], a[j] + b[j] * x, p1[j], p2[j]) + lconst[j];
  }
};

// The one adaptation rule (see the top): log s after burn-in batch `batch`
// whose acceptance rate was `rate`.
static double adapt_step(double logscale, double rate, double target, int batch) {
  return logscale + (rate > target ? 1 : -1) * std::min(0.5, 1.0 / std::sqrt((double) batch));
}

static double list_num(const Rcpp::List& s, const char* name, double dflt) {
  return s.containsElementNamed(name) ? Rcpp::as<double>(s[name]) : dflt;
}
// An R vector (no dim attribute) of x's values.
static Rcpp::NumericVector num(const arma::vec& x) {
  return Rcpp::NumericVector(x.begin(), x.end());
}
static std::vector<int> list_ints(const Rcpp::List& s, const char* name) {
  return s.containsElementNamed(name) ? Rcpp::as<std::vector<int> >(s[name]) : std::vector<int>();
}
// R's 1-based indices, 0-based.
static std::vector<int> zero_based(const Rcpp::IntegerVector& ix) {
  std::vector<int> out(ix.begin(), ix.end());
  for (int& j : out) j -= 1;
  return out;
}
static bool has(const std::vector<int>& v, int x) {
  return std::find(v.begin(), v.end(), x) != v.end();
}

// Welford update of a running mean and centred sums of squares M2 (lower
// triangle) by w, the n-th draw (e: a workspace).
static void welford(const arma::vec& w, int n, arma::vec& mean, arma::mat& M2, arma::vec& e) {
  const int k = w.n_elem;
  for (int i = 0; i < k; ++i) e[i] = w[i] - mean[i];
  mean += e / n;
  for (int a = 0; a < k; ++a)
    for (int b = 0; b <= a; ++b) M2(a, b) += e[a] * (w[b] - mean[b]);
}

// An adaptive joint random walk over some parameters (see the top).
struct Block {
  std::vector<int> idx;
  arma::vec mean, w, wNew, e, lpNew, vals;
  arma::mat cov, L, tmp;  // cov: Welford sums of squares (lower triangle)
  // warm-up of data-dependent length (restart < 0): the draws recorded, by
  // window of WINDOW sweeps (window j: sweeps WINDOW j + 1 ... WINDOW (j + 1)):
  // each closed window's count, index, mean (a column of winMeans) and
  // centred sums of squares (a k x k slice of winM2, side by side); the open
  // window's likewise (curN, curWin, curMean, curM2); `forget` the weight
  // of each earlier epoch (see pooled())
  arma::vec winCount, winIndex, curMean;
  arma::mat winMeans, winM2, curM2;
  double logscale = 0, accBatch = 0, forget = 0;
  int n = 0, batch = 0, restart = 0, curN = 0, curWin = -1;  // restart < 0: a warm-up of data-dependent length
  bool shaped = false;
  // how many leading parameters the walk moves (the rest drawn otherwise:
  // BlockMove's collapse); 0 for all. The warm-up's effective-draws rule
  // counts these only, whose shape (L's leading block) the walk uses.
  int walked = 0;
  // an overlay block (R's sampler_moves()$overlay): a joint walk over
  // parameters that also have moves of their own (kappa's joint block)
  bool overlay = false;

  void start(const std::vector<int>& index, const arma::vec& logsd) {
    idx = index;
    const int k = idx.size();
    mean.zeros(k); cov.zeros(k, k); L.zeros(k, k);
    for (int i = 0; i < k; ++i) L(i, i) = std::exp(logsd[idx[i]]);
    logscale = -0.5 * std::log((double) k);
    clear_windows();
    alloc();
  }
  void alloc() {
    const int k = idx.size();
    w.set_size(k); wNew.set_size(k); e.set_size(k); lpNew.set_size(k); vals.set_size(k);
  }
  void clear_windows() {
    const int k = idx.size();
    winCount.reset(); winIndex.reset(); winMeans.set_size(k, 0); winM2.set_size(k, 0);
    curN = 0; curWin = -1; curMean.zeros(k); curM2.zeros(k, k);
  }
  void read(const Rcpp::List& s) {
    idx = zero_based(s["index"]);
    mean = Rcpp::as<arma::vec>(s["mean"]);
    cov = Rcpp::as<arma::mat>(s["cov"]);
    L = Rcpp::as<arma::mat>(s["chol"]);
    logscale = s["logscale"]; accBatch = s["accBatch"];
    n = s["n"]; batch = s["batch"]; shaped = s["shaped"];
    // (a state written before the windows' estimate: it starts afresh)
    clear_windows();
    if (s.containsElementNamed("winM2")) {
      winCount = Rcpp::as<arma::vec>(s["winCount"]);
      winIndex = Rcpp::as<arma::vec>(s["winIndex"]);
      winMeans = Rcpp::as<arma::mat>(s["winMeans"]);
      winM2 = Rcpp::as<arma::mat>(s["winM2"]);
      curN = s["curN"]; curWin = s["curWin"];
      curMean = Rcpp::as<arma::vec>(s["curMean"]);
      curM2 = Rcpp::as<arma::mat>(s["curM2"]);
      const int k = idx.size();
      if (winCount.n_elem == 0) { winMeans.set_size(k, 0); winM2.set_size(k, 0); }
    }
    alloc();
  }
  // (the windows only under a warm-up of data-dependent length: a fixed
  // burn-in's state is as it was before them)
  Rcpp::List write() const {
    using Rcpp::_;
    Rcpp::IntegerVector ix(idx.size());
    for (size_t i = 0; i < idx.size(); ++i) ix[i] = idx[i] + 1;
    Rcpp::List out = Rcpp::List::create(
      _["index"] = ix, _["logscale"] = logscale, _["chol"] = L, _["shaped"] = shaped,
      _["mean"] = mean, _["cov"] = cov, _["n"] = n, _["batch"] = batch, _["accBatch"] = accBatch);
    if (overlay) out.push_back(true, "overlay");
    if (restart >= 0) return out;
    out.push_back(num(winCount), "winCount");
    out.push_back(num(winIndex), "winIndex");
    out.push_back(Rcpp::wrap(winMeans), "winMeans");
    out.push_back(Rcpp::wrap(winM2), "winM2");
    out.push_back(curN, "curN");
    out.push_back(curWin, "curWin");
    out.push_back(num(curMean), "curMean");
    out.push_back(Rcpp::wrap(curM2), "curM2");
    return out;
  }
  int walk_count() const { return walked > 0 ? walked : (int) idx.size(); }
  // log det(L)^(1/k): the log size of the shape.
  double log_volume() const { return arma::mean(arma::log(L.diag())); }
  // Log SD the shape L gives each parameter, relative to its size.
  arma::vec log_shape() const {
    return 0.5 * arma::log(arma::sum(arma::square(L), 1)) - log_volume();
  }
  // Start the running mean and covariance afresh (L is kept).
  void forget_all() { n = 0; mean.zeros(); cov.zeros(); }
  // Welford update of the running mean and covariance of w.
  void record() { welford(w, ++n, mean, cov, e); }
  // Warm-up of data-dependent length: w at sweep `it` joins its window
  // (Welford within the window).
  void record_window(int it) {
    const int j = (it - 1) / WINDOW;
    if (curN > 0 && j != curWin) close_window();
    curWin = j; ++curN; ++n;
    welford(w, curN, curMean, curM2, e);
  }
  // The open window joins the closed ones.
  void close_window() {
    if (curN == 0) return;
    const int k = idx.size();
    winCount.resize(winCount.n_elem + 1); winCount.back() = curN;
    winIndex.resize(winIndex.n_elem + 1); winIndex.back() = curWin;
    winMeans.insert_cols(winMeans.n_cols, curMean);
    winM2.insert_cols(winM2.n_cols, arma::symmatl(curM2));
    curN = 0; curMean.zeros(k); curM2.zeros(k, k);
  }
  // Window j's epoch: 0 for windows 0-1 (sweeps 1-200), e for windows
  // 2^e ... 2^(e+1) - 1 (sweeps 200 2^(e-1) + 1 ... 200 2^e): the epochs
  // double, as the restarts of a fixed estimate did.
  static int epoch(int j) {
    int e = 0;
    if (j >= 2) { e = 1; while (j >= 4) { j /= 2; ++e; } }
    return e;
  }
  // Weighted pooled estimate (see the top): every window's draws weighted
  // a = forget^(E - its epoch), E the newest window's epoch (forget = 0: the
  // newest epoch alone, an estimate started afresh at 200, 400, 800, ...;
  // forget > 0: each earlier epoch kept at a fraction of the next one's
  // weight, so a new epoch changes nothing until its draws come). Mean
  // mu = sum a n m / S, covariance
  //   C = sum a (M2 + n (m - mu)(m - mu)') / S,  S = sum a n
  // (cov.wt(method = "ML") with the weights a per draw), over the closed
  // windows and the open one (withOpen); returns the draws weighed (a > 0).
  int pooled(bool withOpen, arma::vec& mu, arma::mat& C) const {
    const int B = winCount.n_elem, k = idx.size();
    const int newest = withOpen && curN > 0 ? curWin : (B ? (int) winIndex[B - 1] : curWin);
    const int E = epoch(std::max(newest, 0));
    arma::vec a(B);
    double S = 0;
    int count = 0;
    for (int b = 0; b < B; ++b) {
      a[b] = std::pow(forget, E - epoch((int) winIndex[b]));
      S += a[b] * winCount[b];
      if (a[b] > 0) count += winCount[b];
    }
    const bool open = withOpen && curN > 0;
    if (open) { S += curN; count += curN; }
    mu.zeros(k); C.zeros(k, k);
    if (S <= 0) return 0;
    for (int b = 0; b < B; ++b) mu += a[b] * winCount[b] * winMeans.col(b) / S;
    if (open) mu += curN * curMean / S;
    for (int b = 0; b < B; ++b) {
      if (a[b] == 0) continue;
      const arma::vec d = winMeans.col(b) - mu;
      C += a[b] * (winM2.cols(b * k, b * k + k - 1) + winCount[b] * d * d.t());
    }
    if (open) {
      const arma::vec d = curMean - mu;
      C += arma::symmatl(curM2) + curN * d * d.t();
    }
    C /= S;
    return count;
  }
  // End of a warm-up window: it joins the closed windows, and the fewest
  // effective draws of a parameter in the weighted estimate (0 with fewer
  // than 4 recent windows): its effective size for independent draws,
  //   N = (sum a n)^2 / sum a^2 n,
  // over each parameter's mixing time measured by batch means over the
  // recent windows (the newest two epochs; the newest alone when forget = 0),
  //   tau_i = nbar var(window means_i) / v_i
  // (v_i the recent windows' pooled variance, nbar their mean count), so
  // ESS_i = N / tau_i; with forget = 0, B v_i / var(window means_i). The
  // older windows' drift from the start does not count against the
  // recent mixing. Only the walked parameters count (walk_count()).
  double window_ess() {
    close_window();
    const int B = winCount.n_elem, k = idx.size(), kw = walk_count();
    if (B == 0) return 0;
    const int E = epoch((int) winIndex[B - 1]), from = forget > 0 ? E - 1 : E;
    double sa = 0, sa2 = 0, nR = 0;
    std::vector<int> recent;
    for (int b = 0; b < B; ++b) {
      const int eb = epoch((int) winIndex[b]);
      const double a = std::pow(forget, E - eb);
      sa += a * winCount[b]; sa2 += a * a * winCount[b];
      if (eb >= from) { recent.push_back(b); nR += winCount[b]; }
    }
    const int R = recent.size();
    if (R < 4 || sa2 <= 0) return 0;
    const double N = sa * sa / sa2, nbar = nR / R;
    double ess = INFINITY;
    for (int i = 0; i < kw; ++i) {
      double mu = 0;
      for (int b : recent) mu += winCount[b] * winMeans(i, b) / nR;
      double v = 0, mm = 0, s2 = 0;
      for (int b : recent) {
        const double d = winMeans(i, b) - mu;
        v += winM2(i, b * k + i) + winCount[b] * d * d;
        mm += winMeans(i, b) / R;
      }
      v /= nR;
      for (int b : recent) s2 += std::pow(winMeans(i, b) - mm, 2) / (R - 1);
      ess = std::min(ess, s2 > 0 ? N * v / (nbar * s2) : N);
    }
    return ess;
  }
  // End of a burn-in batch with acceptance rate `rate`: scale towards the
  // target acceptance, shape L.
  void adapt(double rate) {
    const int k = idx.size();
    ++batch;
    logscale = adapt_step(logscale, rate, k == 1 ? 0.44 : 0.234, batch);
    bool enough = n >= 2 * BATCH;
    if (restart < 0) {
      arma::vec mu;
      enough = pooled(true, mu, tmp) >= 2 * BATCH;
    } else if (enough) {
      tmp = cov / (n - 1);
    }
    if (enough) {
      const double eps = 1e-10 * (1 + arma::max(tmp.diag()));
      for (int i = 0; i < k; ++i) tmp(i, i) += eps;
      if (chol_lower(tmp)) {
        // a warm-up of data-dependent length keeps the proposal's volume
        // when it reshapes (the scale tuned so far stays right when an
        // estimate started afresh leaves out the drift from the start)
        const double vol = restart < 0 && shaped ? log_volume() : 0;
        L = arma::trimatl(tmp);
        if (!shaped) logscale = std::log(2.38 / std::sqrt((double) k));
        else if (restart < 0) logscale += vol - log_volume();
        shaped = true;
      }
    }
  }
};

// Everything a chain carries from one piece of a run to the next but the
// moves' own state (Move): the posterior, the log priors and likelihood,
// the sweep and batch clock, the warm-up's decision. `logsd` and
// `accBatch` are the state's per-parameter proposal log SDs and batch
// acceptances as read (the moves take theirs from them and write them back).
struct Chain {
  Posterior& post;
  const Priors& pr;
  arma::vec logsd, lp, accBatch;
  std::vector<Block*> blocks;  // the block moves' blocks, in R's order
  int iter = 0, batch = 0;
  bool burn = true;  // the sweep under way is a burn-in sweep
  double ll = 0;
  Rcpp::CharacterVector params;  // parameter names (R's spec$vars), for the report
  // warm-up of data-dependent length (see the top): sweeps of warm-up once
  // it ended (0: not yet), its bounds, settled windows in a row, and per
  // move the acceptance so far in this window and the log scale at the end
  // of the last two windows (winScale: 2 x moves), per block parameter the
  // log SD of the shape at the end of the last window
  bool adaptive = false, warmCapped = false;
  int warmup = 0, warmMin = 200, warmMax = 5000, settled = 0, windows = 0;
  double warmESS = 0, warmForget = 0;
  arma::vec winAcc, winShape;
  arma::mat winScale;
  Chain(Posterior& p, const Priors& r) : post(p), pr(r) {}
  std::string param_name(int j) const {
    return params.size() == post.d ? std::string(params[j]) : "phi" + std::to_string(j + 1);
  }
};

// A move: one exact Metropolis-Hastings (or Gibbs) update of some
// parameters given the rest. step() proposes and accepts or rejects
// (true: accepted); adapt() ends a burn-in batch of BATCH sweeps with the
// batch's acceptance rate; logScale() is the adapted proposal scale
// reported for it. The sweep makes `repeats` steps of each move in the
// schedule's order.
struct Move {
  std::string name;
  std::vector<int> idx;     // the parameters it moves (0-based, in phi)
  int repeats = 1;
  double accepted = 0, tries = 0;  // over retained sweeps of every piece of the run
  virtual ~Move() {}
  virtual bool step(Chain& ch) = 0;
  // after repeat `rep` of sweep `it` (burn-in or not): what the move learns
  virtual void after(bool, int, int) {}
  // acceptances / repeats in the current batch (the move's own count; a
  // block's is its Block's)
  double accBatch = 0;
  virtual double& batchCount() { return accBatch; }
  virtual void adapt(const Chain&) {}
  virtual double logScale() const { return NA_REAL; }
  // the log size of its proposal, whose drift a warm-up watches
  virtual double warmScale() const { return logScale(); }
  // its adapted state into the chain's state list (write_chain())
  virtual void write(arma::vec&, arma::vec&, Rcpp::List&) const {}
  // the acceptance rate its scale adapts towards (NA: not adapted)
  virtual double acceptGoal() const { return NA_REAL; }
  virtual const char* kind() const = 0;
};

// The Metropolis decision of a move of the parameters idx whose proposal
// gave the log-likelihood llNew and log priors lpNew: accept when
// log u < llNew - ll + the terms (the log prior, Jacobian and proposal
// changes, added in their order); keeps or restores the posterior's state.
static bool metropolis(Chain& ch, const std::vector<int>& idx, const double* lpNew, double llNew,
                       std::initializer_list<double> terms) {
  double r = llNew - ch.ll;
  for (double t : terms) r += t;
  if (std::isfinite(llNew) && std::log(R::unif_rand()) < r) {
    ch.post.accept();
    ch.ll = llNew;
    for (size_t i = 0; i < idx.size(); ++i) ch.lp[idx[i]] = lpNew[i];
    return true;
  }
  ch.post.reject();
  return false;
}

// Single-site random-walk Metropolis move of parameter j.
struct SiteMove : Move {
  int j;
  double logsd;  // log SD of its walk
  SiteMove(int j_, const Chain& ch) : j(j_), logsd(ch.logsd[j_]) {
    idx = {j_};
    accBatch = ch.accBatch[j_];
    name = ch.param_name(j_);
  }
  const char* kind() const override { return "single"; }
  bool step(Chain& ch) override {
    Posterior& post = ch.post;
    const int tr = ch.pr.transform[j];
    const double x = post.phi[j];
    const double xNew = from_walk(tr, to_walk(tr, x) + std::exp(logsd) * R::norm_rand());
    const double lpNew = ch.pr(j, xNew);
    if (!std::isfinite(lpNew)) return false;
    const double jac = log_jacobian(tr, xNew) - log_jacobian(tr, x);
    if (!std::isfinite(jac)) return false;
    return metropolis(ch, idx, &lpNew, post.propose(j, xNew), {lpNew - ch.lp[j], jac});
  }
  void adapt(const Chain& ch) override {
    logsd = adapt_step(logsd, accBatch / BATCH, 0.44, ch.batch);
  }
  double logScale() const override { return logsd; }
  double acceptGoal() const override { return 0.44; }
  void write(arma::vec& lsd, arma::vec& acc, Rcpp::List&) const override {
    lsd[j] = logsd; acc[j] = accBatch;
  }
};

// Joint random-walk move of a block (w* = w + exp(s) L e); it records the
// burn-in draws that shape L. Collapsed (collapsed(): b.walked set by
// collapse_sigma2S()): the simulator block with sigma2S
// last, on an algebra that gives zz = ys' Ds^-1 ys ahead of the proposal
// (Posterior::simPreview()): the walk moves the correlation parameters
// (the first k - 1 entries of w, with L's leading block: the Cholesky
// factor of their marginal covariance) and sigma2S is drawn from the
// runs' own full conditional
//   q(s2 | theta) = IG(a0 + m / 2, b0 + zz(theta) / 2)
// ((a0, b0) the inverse gamma prior's, else 0), the exact conditional of
// sigma2S given the runs alone; the field data's share is corrected by
//   log r = log L* + log p* - log L - log p + jac(theta)
//           + log q(s2 | theta) - log q(s2* | theta*),
// a Metropolis-Hastings ratio with the walk's symmetric part cancelled.
// sigma2S's posterior is dominated by the m runs, so the walk need not
// follow the ridge between sigma2S and the length-scales
// (sigma2S / theta^(2 nu) is what the runs pin down), which a joint walk of
// all k must.
struct BlockMove : Move {
  Block b;
  double a0 = 0, b0 = 0;  // q's prior part
  std::vector<int> idxT;  // the walk's parameters (collapsed: all but sigma2S)
  arma::vec valsT;
  BlockMove(Block&& b_, int rep) : b(std::move(b_)) { idx = b.idx; repeats = rep; }
  bool collapsed() const { return b.walk_count() < (int) b.idx.size(); }
  const char* kind() const override {
    return indOn ? "independent" : idx.size() == 1 ? "walk" : "joint";
  }
  // log density of IG(a, bb) at x
  static double log_ig(double x, double a, double bb) {
    return a * std::log(bb) - R::lgammafn(a) - (a + 1.0) * std::log(x) - bb / x;
  }
  // A proposal for the block's first n parameters, e (drawn by the caller)
  // given: w'_i = c_i + s (Lp e)_i on the walk's scale, values from_walk(w');
  // the current positions into w; lpDiff = sum of log prior changes, jac =
  // sum of log Jacobian changes. False when either is not finite. (c may be
  // w itself: each c_i is read after w_i is set.)
  bool fill_proposal(const Chain& ch, int n, const arma::vec& c, double s, const arma::mat& Lp,
                     double& lpDiff, double& jac) {
    const Posterior& post = ch.post;
    for (int i = 0; i < n; ++i) {
      const int j = b.idx[i], tr = ch.pr.transform[j];
      b.w[i] = to_walk(tr, post.phi[j]);
      double step = 0;
      for (int l = 0; l <= i; ++l) step += Lp(i, l) * b.e[l];
      b.wNew[i] = c[i] + s * step;
      b.vals[i] = from_walk(tr, b.wNew[i]);
      b.lpNew[i] = ch.pr(j, b.vals[i]);
      lpDiff += b.lpNew[i] - ch.lp[j];
      jac += log_jacobian(tr, b.vals[i]) - log_jacobian(tr, post.phi[j]);
    }
    return std::isfinite(lpDiff) && std::isfinite(jac);
  }
  // The walk's proposal for the block's first n parameters: w' = w + exp(s)
  // L e, e ~ N(0, I_n) (fill_proposal()).
  bool walk_proposal(const Chain& ch, int n, double& lpDiff, double& jac) {
    for (int i = 0; i < n; ++i) b.e[i] = R::norm_rand();
    return fill_proposal(ch, n, b.w, std::exp(b.logscale), b.L, lpDiff, jac);
  }
  // The independence proposal (independent: R's sampler_moves()$independent;
  // after warm-up only; IND_NU, IND_INFLATE, IND_MAX_K at the top): built
  // once, at the first retained step, from the block's warm-up estimate.
  bool independent = false, indTried = false, indOn = false;
  arma::vec indMu, indU;
  arma::mat indL;
  // Builds it when the block qualifies: a warm-up of data-dependent length
  // that was not cut at its maximum, 2 to IND_MAX_K walked parameters, a
  // positive-definite estimate. Otherwise the walk goes on. (A block of
  // fewer than WARM_ESS_K is not held by the effective-draws rule; its
  // estimate comes from a settled warm-up's windows, and the t's tails
  // keep the kernel exact and its acceptance visible in the move report
  // whatever the estimate's error.)
  void build_independent(const Chain& ch) {
    indTried = true;
    const int kw = b.walk_count();
    if (!independent || b.restart >= 0 || ch.warmCapped || kw < 2 || kw > IND_MAX_K)
      return;
    arma::vec mu;
    arma::mat C;
    if (b.pooled(true, mu, C) < 2 * BATCH) return;
    indMu = mu.head(kw);
    indL = C.submat(0, 0, kw - 1, kw - 1) * (IND_INFLATE * IND_INFLATE);
    if (!chol_lower(indL)) return;
    indL = arma::trimatl(indL);
    indU.set_size(kw);
    indOn = true;
  }
  // log q(w) of the first n entries up to a constant, q = t_nu(mu, L L'):
  //   -(nu + n)/2 log(1 + |L^-1 (w - mu)|^2 / nu)
  double log_q(const arma::vec& w, int n) {
    double d = 0;
    for (int i = 0; i < n; ++i) {
      double s = w[i] - indMu[i];
      for (int l = 0; l < i; ++l) s -= indL(i, l) * indU[l];
      indU[i] = s / indL(i, i);
      d += indU[i] * indU[i];
    }
    return -0.5 * (IND_NU + n) * std::log1p(d / IND_NU);
  }
  // The independence proposal for the first n parameters:
  // w' = mu + sqrt(nu / c) L e, e ~ N(0, I_n), c ~ chi2(nu); as
  // fill_proposal(), with jac also holding log q(w) - log q(w').
  bool independent_proposal(const Chain& ch, int n, double& lpDiff, double& jac) {
    for (int i = 0; i < n; ++i) b.e[i] = R::norm_rand();
    const double g = std::sqrt(IND_NU / R::rchisq(IND_NU));
    if (!fill_proposal(ch, n, indMu, g, indL, lpDiff, jac)) return false;
    jac += log_q(b.w, n) - log_q(b.wNew, n);
    return std::isfinite(jac);
  }
  // The step's proposal: the independence one after warm-up where it was
  // built, else the walk.
  bool proposal(const Chain& ch, int n, double& lpDiff, double& jac) {
    if (!ch.burn) {
      if (!indTried) build_independent(ch);
      if (indOn) return independent_proposal(ch, n, lpDiff, jac);
    }
    return walk_proposal(ch, n, lpDiff, jac);
  }
  // (tailR: the block ends with the simulator's noise variance sigma2R,
  // drawn from the replicates' within term alone, IG(aR, bR); see
  // tail_sigma2R())
  bool tailR = false;
  double aR = 0, bR = 0;
  bool step_collapsed(Chain& ch) {
    Posterior& post = ch.post;
    const int k = b.idx.size(), kt = k - 1, js = b.idx[kt];
    double lpDiff = 0, jac = 0;
    if (!proposal(ch, kt, lpDiff, jac)) return false;
    const double s2 = post.phi[js];
    double s2New, lq;
    if (tailR) {
      s2New = 1.0 / R::rgamma(aR, 1.0 / bR);
      lq = log_ig(s2, aR, bR) - log_ig(s2New, aR, bR);
    } else {
      for (int i = 0; i < kt; ++i) valsT[i] = b.vals[i];
      double zzNew;
      bool ok;
      post.simPreview(idxT, valsT, zzNew, ok);
      if (!ok) return false;
      const double aq = a0 + 0.5 * post.m, bNew = b0 + 0.5 * zzNew;
      const double bOld = b0 + 0.5 * post.currentZz();
      s2New = 1.0 / R::rgamma(aq, 1.0 / bNew);
      lq = log_ig(s2, aq, bOld) - log_ig(s2New, aq, bNew);
    }
    b.vals[kt] = s2New;
    b.lpNew[kt] = ch.pr(js, s2New);
    if (!std::isfinite(b.lpNew[kt]) || !(s2New > 0)) return false;
    lpDiff += b.lpNew[kt] - ch.lp[js];
    return metropolis(ch, b.idx, b.lpNew.memptr(), post.propose(b.idx, b.vals), {lpDiff, jac, lq});
  }
  // the walk's positions w of every parameter of the block (what a burn-in
  // records)
  void position(const Chain& ch) {
    for (size_t i = 0; i < b.idx.size(); ++i)
      b.w[i] = to_walk(ch.pr.transform[b.idx[i]], ch.post.phi[b.idx[i]]);
  }
  bool step(Chain& ch) override {
    if (collapsed()) {
      const bool acc = step_collapsed(ch);
      position(ch);
      return acc;
    }
    double lpDiff = 0, jac = 0;
    if (!proposal(ch, b.idx.size(), lpDiff, jac)) return false;
    if (!metropolis(ch, b.idx, b.lpNew.memptr(), ch.post.propose(b.idx, b.vals), {lpDiff, jac}))
      return false;
    b.w = b.wNew;
    return true;
  }
  // burn-in: the walk's position joins the running covariance (afresh from
  // the restart sweep on)
  void after(bool burn, int it, int rep) override {
    if (!burn) return;
    if (b.restart < 0) { b.record_window(it); return; }
    if (it == b.restart && rep == 0) b.forget_all();
    b.record();
  }
  double& batchCount() override { return b.accBatch; }
  void adapt(const Chain&) override { b.adapt(b.accBatch / BATCH); }
  // (an independence proposal has no adapted scale)
  double logScale() const override { return indOn ? NA_REAL : b.logscale; }
  double warmScale() const override { return b.logscale + b.log_volume(); }
  double acceptGoal() const override { return idx.size() == 1 ? 0.44 : 0.234; }
};

// Exact draw of muB from its Gaussian full conditional (gaussian prior).
struct GibbsMuBMove : Move {
  GibbsMuBMove(int j, const Chain& ch) {
    idx = {j}; accBatch = ch.accBatch[j]; name = ch.param_name(j);
  }
  const char* kind() const override { return "gibbs"; }
  void write(arma::vec&, arma::vec& acc, Rcpp::List&) const override { acc[idx[0]] = accBatch; }
  bool step(Chain& ch) override {
    Posterior& post = ch.post;
    const int j = idx[0];
    double aa, ab;
    post.muBQuadratic(aa, ab);
    const double m0 = ch.pr.p1[j], s0 = ch.pr.p2[j];
    const double prec = aa + 1.0 / (s0 * s0);
    const double mu = (ab + m0 / (s0 * s0)) / prec + R::norm_rand() / std::sqrt(prec);
    const double llNew = post.propose(j, mu);
    post.accept();
    ch.ll = llNew;
    ch.lp[j] = ch.pr(j, mu);
    return true;
  }
};

// A move with one adapted proposal scale of its own (log SD logsd, towards
// acceptance `goal`, its own count of burn-in batches), kept in the chain's
// state as <key>Logsd, <key>AccBatch and <key>Batch; its kind is the key.
struct ScalarMove : Move {
  std::string key;
  double logsd, goal;
  int batch;
  ScalarMove(const char* key_, double goal_, const Rcpp::List& state) : key(key_), goal(goal_) {
    logsd = list_num(state, (key + "Logsd").c_str(), std::log(0.1));
    accBatch = list_num(state, (key + "AccBatch").c_str(), 0);
    batch = (int) list_num(state, (key + "Batch").c_str(), 0);
  }
  void adapt(const Chain&) override {
    ++batch;
    logsd = adapt_step(logsd, accBatch / BATCH, goal, batch);
  }
  double logScale() const override { return logsd; }
  double acceptGoal() const override { return goal; }
  const char* kind() const override { return key.c_str(); }
  void write(arma::vec&, arma::vec&, Rcpp::List& out) const override {
    out[key + "Logsd"] = logsd; out[key + "AccBatch"] = accBatch; out[key + "Batch"] = batch;
  }
};

// The variances that exist (sigma2S, sigma2B with a bias, sigma2E)
// multiplied by one factor c = exp(e): Jacobian c^k for k variances.
struct ScaleMove : ScalarMove {
  std::vector<double> lpNew;  // the proposal's log priors (workspace)
  ScaleMove(const Posterior& post, const Rcpp::List& state) : ScalarMove("scale", 0.44, state) {
    idx = post.scaled;
    lpNew.resize(idx.size());
    name = "scale";
  }
  bool step(Chain& ch) override {
    Posterior& post = ch.post;
    const double e = std::exp(logsd) * R::norm_rand(), c = std::exp(e);
    const int k = idx.size();
    double lpDiff = 0;
    for (int i = 0; i < k; ++i) {
      const int j = idx[i];
      lpNew[i] = ch.pr(j, post.phi[j] * c);
      lpDiff += lpNew[i] - ch.lp[j];
    }
    if (!std::isfinite(lpDiff)) return false;
    return metropolis(ch, idx, lpNew.data(), post.proposeScale(c), {lpDiff, k * e});
  }
};

// Independence proposal of kappa_j, uniform over [lo, hi] (R's
// jump_ranges(): a bounded prior's support, else its central 99.9%, on the
// sampler's scale; a mode-jumping move: the walk's adapted step stays
// within a mode). With x* ~ U(lo, hi) the proposal density is constant on
// the interval and cancels; from x outside it the reverse proposal has
// density 0 and the move is rejected:
//   log r = log L(phi*) + log p(x*) - log L(phi) - log p(x)   (x in [lo, hi]).
// Not adapted; one call of f (function simulator) or one kappa move's
// algebra per step.
struct JumpMove : Move {
  int j;
  double lo, hi;  // the interval on the sampler's scale
  JumpMove(int j_, double lo_, double hi_, const Chain& ch) : j(j_), lo(lo_), hi(hi_) {
    if (!(std::isfinite(lo) && std::isfinite(hi) && lo < hi))
      Rcpp::stop("the jump move of %s needs a finite interval", ch.param_name(j_).c_str());
    idx = {j_};
    name = ch.param_name(j_) + " jump";
  }
  const char* kind() const override { return "jump"; }
  bool step(Chain& ch) override {
    Posterior& post = ch.post;
    const double x = post.phi[j];
    // drawn before the check, so a chain inside the interval (always, for
    // a bounded prior) uses the random stream it did before the check
    const double xNew = lo + (hi - lo) * R::unif_rand();
    if (x < lo || x > hi) return false;
    const double lpNew = ch.pr(j, xNew);
    if (!std::isfinite(lpNew)) return false;
    return metropolis(ch, idx, &lpNew, post.propose(j, xNew), {lpNew - ch.lp[j]});
  }
};

// Elliptical slice sampling of a stochastic simulator's latent
// log-variances gR, all at once (latent_noise.cpp); not adapted.
struct LatentMove : Move {
  explicit LatentMove(const Chain& ch) {
    for (int i = 0; i < ch.post.m; ++i) idx.push_back(ch.post.iG + i);
    name = "gR";
  }
  const char* kind() const override { return "slice"; }
  bool step(Chain& ch) override {
    return latent_ess(ch.post, ch.ll, ch.lp, [&](int j, double x) { return ch.pr(j, x); }) > 0;
  }
};

// The latent GP's free hyperparameters moved with the whitened latent
// values held fixed (latent_noise.cpp); its step adapts towards acceptance
// 0.234 like the scale move's.
struct LatentShiftMove : ScalarMove {
  std::vector<int> tr;
  LatentShiftMove(const Chain& ch, const Rcpp::List& state) : ScalarMove("shift", 0.234, state) {
    const Posterior& post = ch.post;
    for (const char* c : {"muG", "sigma2G", "thetaG"})
      for (int k = 0; k < post.layout.length_of(c); ++k) {
        const int j = post.layout.offset_of(c) + k;
        if (ch.pr.family[j] != PF_FIXED) { idx.push_back(j); tr.push_back(ch.pr.transform[j]); }
      }
    name = "latent shift";
  }
  bool step(Chain& ch) override {
    return latent_shift(ch.post, ch.ll, ch.lp, idx, tr, std::exp(logsd),
                        [&](int j, double x) { return ch.pr(j, x); });
  }
};

typedef std::vector<std::unique_ptr<Move> > Schedule;

// The chain's adapted state from `state` (an earlier piece's, or the
// initial one of R's initial_state(): then the defaults below).
static void read_chain(Chain& ch, const Rcpp::List& state, int d) {
  ch.logsd = Rcpp::as<arma::vec>(state["logsd"]);
  ch.iter = (int) list_num(state, "iter", 0);
  ch.batch = (int) list_num(state, "batch", 0);
  ch.accBatch = state.containsElementNamed("accBatch") ?
    Rcpp::as<arma::vec>(state["accBatch"]) : arma::vec(d, arma::fill::zeros);
  ch.warmup = (int) list_num(state, "warmup", 0);
  ch.warmMin = (int) list_num(state, "warmMin", 200);
  ch.warmMax = (int) list_num(state, "warmMax", 5000);
  ch.warmESS = list_num(state, "warmESS", 0);
  ch.warmForget = list_num(state, "warmForget", 0);
  ch.warmCapped = list_num(state, "warmCapped", 0) != 0;
  ch.settled = (int) list_num(state, "settled", 0);
  ch.windows = (int) list_num(state, "windows", 0);
  if (state.containsElementNamed("winAcc")) {
    ch.winAcc = Rcpp::as<arma::vec>(state["winAcc"]);
    ch.winShape = Rcpp::as<arma::vec>(state["winShape"]);
    ch.winScale = Rcpp::as<arma::mat>(state["winScale"]);
  }
}

// The joint blocks of `blockSpec` (R's sampler_moves()$blocks), each
// continued from `state` when it has them, else started from the
// parameters' proposal SDs, with the burn-in sweep their covariance
// estimate restarts at: from the middle of burn-in (when burn-in has at
// least 400 sweeps), so the first sweeps' drift from the starting point
// does not inflate it (a warm-up of data-dependent length starts it afresh
// at 200, 400, 800, ...).
static std::vector<Block> make_blocks(const Chain& ch, const Rcpp::List& blockSpec,
                                      const std::vector<int>& overlay,
                                      const Rcpp::List& state, int nBurn) {
  const int d = ch.post.d;
  const int restartAt = nBurn < 0 ? -1 : nBurn >= 400 ? nBurn / 2 : 0;
  Rcpp::List blockState;
  if (state.containsElementNamed("blocks") && !Rf_isNull(state["blocks"]))
    blockState = Rcpp::as<Rcpp::List>(state["blocks"]);
  const bool haveBlocks = blockState.size() > 0 && blockState.size() == blockSpec.size();
  std::vector<Block> blocks(blockSpec.size());
  std::vector<char> inBlock(d, 0);
  for (int b = 0; b < blockSpec.size(); ++b) {
    const Rcpp::IntegerVector ix = blockSpec[b];
    if (haveBlocks) {
      blocks[b].read(Rcpp::as<Rcpp::List>(blockState[b]));
    } else {
      blocks[b].start(zero_based(ix), ch.logsd);
    }
    if ((int) blocks[b].idx.size() != ix.size())
      Rcpp::stop("the block proposal to continue from has the wrong size");
    blocks[b].restart = restartAt;
    blocks[b].forget = ch.warmForget;
    blocks[b].overlay = has(overlay, b + 1);
    for (int j : blocks[b].idx) {
      if (j < 0 || j >= d || ch.pr.family[j] == PF_FIXED || (inBlock[j] && !blocks[b].overlay))
        Rcpp::stop("a block holds a fixed, repeated or unknown parameter");
      if (!blocks[b].overlay) inBlock[j] = 1;
    }
  }
  return blocks;
}

// Makes block move mv draw sigma2S from the runs' conditional (BlockMove)
// when asked (`want`), the block ends with sigma2S among other parameters
// and the algebra gives zz ahead of a proposal; else it stays the plain
// joint walk.
static void collapse_sigma2S(BlockMove& mv, const Chain& ch, bool want) {
  const Posterior& post = ch.post;
  const std::vector<int>& idx = mv.b.idx;
  const int k = idx.size();
  // (with the simulator's own noise Ds holds sigma2R / sigma2S, so the
  // runs' conditional of sigma2S is not that inverse gamma)
  if (!want || k < 2 || !post.canPreview() || post.simNoise ||
      post.layout.length_of("sigma2S") != 1 || idx[k - 1] != post.iSigma2S)
    return;
  mv.b.walked = k - 1;
  mv.idxT.assign(idx.begin(), idx.end() - 1);
  mv.valsT.set_size(k - 1);
  const int j = post.iSigma2S;
  const Priors& pr = ch.pr;
  if (pr.family[j] == PF_INVGAMMA && pr.a[j] == 0 && pr.b[j] == 1) {
    mv.a0 = pr.p1[j]; mv.b0 = pr.p2[j];
  }
}

// Makes the simulator block mv, when it ends with the simulator's constant
// noise variance sigma2R, draw sigma2R from the replicates' within term
// alone, exp(-[repDf log r + SSW / r] / 2) = IG(repDf / 2 - 1, SSW / 2) in
// r, an independence proposal (the rest of the block as before) whose
// Metropolis-Hastings ratio keeps the posterior exact: the within term's
// repDf degrees of freedom pin sigma2R down (at 1,000 inputs x 100
// replicates to 0.5%), which a joint walk or t proposal of the block
// follows slowly, and a move of its own costs a second factorisation of
// the runs' system a sweep.
static void tail_sigma2R(BlockMove& mv, const Chain& ch) {
  const Posterior& post = ch.post;
  const std::vector<int>& idx = mv.b.idx;
  const int k = idx.size();
  if (k < 2 || !post.simNoise || post.latent || idx[k - 1] != post.iSigma2R ||
      !(post.repDf > 2) || !(post.repSSW > 0))
    return;
  mv.b.walked = k - 1;
  mv.tailR = true;
  mv.aR = 0.5 * post.repDf - 1.0;
  mv.bR = 0.5 * post.repSSW;
}

// The schedule of `moves` (R's sampler_moves()): the moves in sweep order.
// Each free parameter in the order of phi gets its block's move at the
// block's first parameter (the block continued from `state` when it has
// one, else started), the exact muB draw, or a single-site move; then the
// scale move. Each move's retained counts so far come from `state`.
static Schedule make_schedule(Chain& ch, const Rcpp::List& moves, const Rcpp::List& state,
                              int nBurn) {
  const Posterior& post = ch.post;
  const Priors& pr = ch.pr;
  const int d = post.d;
  const bool scaleMove = Rcpp::as<bool>(moves["scale"]);
  const bool gibbsMuB = Rcpp::as<bool>(moves["gibbsMuB"]);
  if (gibbsMuB && !(post.biasMean && pr.family[post.iMuB] == PF_GAUSSIAN && pr.a[post.iMuB] == 0 &&
                    pr.b[post.iMuB] == 1))
    Rcpp::stop("the exact muB move needs a gaussian prior on muB");
  if (scaleMove)
    for (int j : post.scaled)
      if (pr.family[j] == PF_FIXED)
        Rcpp::stop("the scale move needs the variances (sigma2S, sigma2B, sigma2E) all sampled");

  const Rcpp::List blockSpec = moves["blocks"];
  const std::vector<int> repeats = list_ints(moves, "repeats");
  // the blocks (1-based) that overlay parameters with moves of their own:
  // a joint walk made after the per-parameter moves, before the jumps
  const std::vector<int> overlay = list_ints(moves, "overlay");
  std::vector<Block> blocks = make_blocks(ch, blockSpec, overlay, state, nBurn);
  // the blocks (1-based) whose sigma2S is drawn from the runs' conditional
  const std::vector<int> collapse = list_ints(moves, "collapse");
  // the blocks (1-based) that switch to the independence proposal after warm-up
  const std::vector<int> independent = list_ints(moves, "independent");
  std::vector<int> blockAt(d, -1);  // blockAt[j]: block starting at parameter j
  std::vector<char> inBlock(d, 0);
  for (size_t b = 0; b < blocks.size(); ++b) {
    if (blocks[b].overlay) continue;
    for (int j : blocks[b].idx) inBlock[j] = 1;
    blockAt[blocks[b].idx[0]] = b;
  }
  SEXP bn = Rf_getAttrib(blockSpec, R_NamesSymbol);
  const Rcpp::CharacterVector blockNames = Rf_isNull(bn) ?
    Rcpp::CharacterVector(blockSpec.size()) : Rcpp::CharacterVector(bn);
  Schedule schedule;
  ch.blocks.assign(blocks.size(), nullptr);
  auto add_block = [&](int b) {
    BlockMove* mv = new BlockMove(std::move(blocks[b]), (int) repeats.size() > b ? std::max(1, repeats[b]) : 1);
    if (!mv->b.overlay) {
      collapse_sigma2S(*mv, ch, has(collapse, b + 1));
      tail_sigma2R(*mv, ch);
      mv->independent = has(independent, b + 1);
    }
    schedule.emplace_back(mv);
    ch.blocks[b] = &mv->b;
    const std::string nm(blockNames[b]);
    mv->name = nm.empty() ? "block" + std::to_string(b + 1) : nm;
  };
  for (int j = 0; j < d; ++j) {
    if (pr.family[j] == PF_FIXED) continue;
    if (post.latent && j >= post.iG && j < post.iG + post.m) {
      if (j == post.iG) {
        schedule.emplace_back(new LatentMove(ch));
        std::unique_ptr<LatentShiftMove> sh(new LatentShiftMove(ch, state));
        if (!sh->idx.empty()) schedule.emplace_back(std::move(sh));
      }
    } else if (inBlock[j]) {
      if (blockAt[j] >= 0) add_block(blockAt[j]);
    } else if (post.biasMean && j == post.iMuB && gibbsMuB) {
      schedule.emplace_back(new GibbsMuBMove(j, ch));
    } else {
      schedule.emplace_back(new SiteMove(j, ch));
    }
  }
  for (size_t b = 0; b < blocks.size(); ++b)
    if (blocks[b].overlay) add_block(b);
  // the jump moves (R's sampler_moves()$jump, 1-based, and $jumpRange, a
  // row per jump), after the walks
  const std::vector<int> jump = list_ints(moves, "jump");
  if (!jump.empty()) {
    if (!moves.containsElementNamed("jumpRange"))
      Rcpp::stop("the jump moves need their intervals (moves$jumpRange)");
    const Rcpp::NumericMatrix range = moves["jumpRange"];
    if (range.nrow() != (int) jump.size() || range.ncol() != 2)
      Rcpp::stop("moves$jumpRange must have a row per jump move and 2 columns");
    for (size_t r = 0; r < jump.size(); ++r)
      schedule.emplace_back(new JumpMove(jump[r] - 1, range(r, 0), range(r, 1), ch));
  }
  // (an input-dependent noise does not scale with the variances: no scale move)
  if (scaleMove && !post.latent) schedule.emplace_back(new ScaleMove(post, state));
  if (state.containsElementNamed("moves") && !Rf_isNull(state["moves"])) {
    const Rcpp::List old = state["moves"];
    const Rcpp::CharacterVector nm = old["name"];
    const Rcpp::NumericVector acc = old["accepted"], tries = old["tries"];
    for (auto& mv : schedule)
      for (int i = 0; i < nm.size(); ++i)
        if (mv->name == std::string(nm[i])) { mv->accepted = acc[i]; mv->tries = tries[i]; }
  }
  return schedule;
}

// One sweep: `repeats` steps of every move in the schedule's order.
static void sweep(Chain& ch, Schedule& schedule, bool burn, int it) {
  ch.burn = burn;
  for (auto& mv : schedule) {
    for (int r = 0; r < mv->repeats; ++r) {
      const bool acc = mv->step(ch);
      mv->after(burn, it, r);
      if (acc) mv->batchCount() += 1.0 / mv->repeats;
      if (!burn) {
        mv->tries += 1;
        if (acc) mv->accepted += 1;
      }
    }
  }
}

// Log SDs of every block's shape, blocks in order.
static arma::vec shapes(const Chain& ch) {
  arma::vec out;
  for (const Block* b : ch.blocks) out = arma::join_cols(out, b->log_shape());
  return out;
}

// Starts the window bookkeeping of a warm-up of data-dependent length.
static void start_windows(Chain& ch, const Schedule& schedule) {
  const int nm = schedule.size();
  if ((int) ch.winAcc.n_elem == nm && (int) ch.winScale.n_cols == nm) return;
  ch.winAcc.zeros(nm);
  ch.winScale.set_size(2, nm);
  ch.winScale.fill(NA_REAL);  // no window has ended
  ch.winShape = shapes(ch);
  ch.windows = 0;
}

// The end of warm-up window `it` (see the top): have the proposals settled
// over it? Then the window's bookkeeping starts afresh.
static bool window_settled(Chain& ch, const Schedule& schedule) {
  ++ch.windows;
  const double step = WARM_DRIFT * std::min(0.5, 1.0 / std::sqrt((double) std::max(ch.batch, 1)));
  bool ok = ch.windows >= 2;  // the log scales two windows back to compare with
  const int nm = schedule.size();
  for (int i = 0; i < nm; ++i) {
    const double target = schedule[i]->acceptGoal(), ls = schedule[i]->warmScale();
    if (!ISNAN(target)) {
      if (std::fabs(ch.winAcc[i] / (WINDOW / BATCH) - target) > WARM_BAND) ok = false;
      // the drift since two windows back (since the first window's end at
      // the second: the first window is the exploring one)
      const double ref = ISNAN(ch.winScale(0, i)) ? ch.winScale(1, i) : ch.winScale(0, i);
      if (!ISNAN(ref) && std::fabs(ls - ref) > step) ok = false;
    }
    ch.winScale(0, i) = ch.winScale(1, i);
    ch.winScale(1, i) = ls;
  }
  const arma::vec sh = shapes(ch);
  for (Block* b : ch.blocks) {
    if (!b->shaped) ok = false;
    // a joint block's shape learnt from enough effective draws
    const double ess = b->window_ess();
    const int k = b->walk_count();
    if (k >= WARM_ESS_K && ess < ch.warmESS * k) ok = false;
  }
  if (sh.n_elem != ch.winShape.n_elem || arma::any(arma::abs(sh - ch.winShape) > WARM_SHAPE))
    ok = false;
  ch.winShape = sh;
  ch.winAcc.zeros();
  return ok;
}

// The end of a batch of BATCH sweeps (sweep `it`): adapt every move during
// burn-in (and decide whether a warm-up of data-dependent length ends
// here), set the progress bar's status, start the next batch's counts.
static void end_batch(Chain& ch, Schedule& schedule, bool burn, SEXP bar, int it) {
  ++ch.batch;
  if (burn)
    for (auto& mv : schedule) mv->adapt(ch);
  if (burn && ch.adaptive) {
    for (size_t i = 0; i < schedule.size(); ++i)
      ch.winAcc[i] += schedule[i]->batchCount() / BATCH;
    if (it % WINDOW == 0) {
      ch.settled = window_settled(ch, schedule) ? ch.settled + 1 : 0;
      if (ch.settled >= 2 && it >= ch.warmMin) ch.warmup = it;
    }
    if (ch.warmup == 0 && it >= ch.warmMax) { ch.warmup = it; ch.warmCapped = true; }
  }
  if (!Rf_isNull(bar)) {
    double lo = 1, mean = 0;
    for (auto& mv : schedule) {
      const double rate = mv->batchCount() / BATCH;
      lo = std::min(lo, rate); mean += rate;
    }
    if (!schedule.empty()) mean /= schedule.size();
    char status[128];
    std::snprintf(status, sizeof status, "%s | acceptance min %.2f mean %.2f",
                  burn ? "burn-in" : "sampling", lo, mean);
    cli_progress_set_status(bar, status);
  }
  for (auto& mv : schedule) mv->batchCount() = 0;
}

// The per-move report: name, kind, parameters, repeats, retained
// acceptances and tries over every piece so far, adapted scale exp(s).
static Rcpp::List move_report(const Chain& ch, const Schedule& schedule) {
  const int nm = schedule.size();
  Rcpp::CharacterVector name(nm), kind(nm), params(nm);
  Rcpp::IntegerVector repeats(nm);
  Rcpp::NumericVector accepted(nm), tries(nm), scale(nm);
  for (int i = 0; i < nm; ++i) {
    const Move& mv = *schedule[i];
    name[i] = mv.name; kind[i] = mv.kind(); repeats[i] = mv.repeats;
    std::string ps;
    for (size_t k = 0; k < mv.idx.size(); ++k) ps += (k ? "," : "") + ch.param_name(mv.idx[k]);
    params[i] = ps;
    accepted[i] = mv.accepted; tries[i] = mv.tries;
    const double ls = mv.logScale();
    scale[i] = ISNA(ls) ? NA_REAL : std::exp(ls);
  }
  using Rcpp::_;
  return Rcpp::List::create(_["name"] = name, _["kind"] = kind, _["params"] = params,
                            _["repeats"] = repeats, _["accepted"] = accepted, _["tries"] = tries,
                            _["scale"] = scale);
}

// The chain's whole state, for the next piece (read_chain(), make_schedule()):
// the chain's own, and each move's where the state keeps it (per-parameter
// log SDs and batch counts, the scale move's; a parameter without a move
// of its own, and the scale move's entries without one, as `state` had them).
static Rcpp::List write_chain(const Chain& ch, const Schedule& schedule,
                              const Rcpp::List& state) {
  Rcpp::List blocks(ch.blocks.size());
  for (size_t b = 0; b < ch.blocks.size(); ++b) blocks[b] = ch.blocks[b]->write();
  using Rcpp::_;
  arma::vec logsd = ch.logsd, accBatch = ch.accBatch;
  Rcpp::List scale = Rcpp::List::create(
    _["scaleLogsd"] = list_num(state, "scaleLogsd", std::log(0.1)),
    _["scaleAccBatch"] = list_num(state, "scaleAccBatch", 0),
    _["scaleBatch"] = (int) list_num(state, "scaleBatch", 0));
  for (const auto& mv : schedule) mv->write(logsd, accBatch, scale);
  Rcpp::List out = Rcpp::List::create(
    _["phi"] = num(ch.post.phi), _["logsd"] = num(logsd), _["iter"] = ch.iter,
    _["batch"] = ch.batch, _["accBatch"] = num(accBatch), _["blocks"] = blocks,
    _["scaleLogsd"] = scale["scaleLogsd"], _["scaleAccBatch"] = scale["scaleAccBatch"],
    _["scaleBatch"] = scale["scaleBatch"], _["moves"] = move_report(ch, schedule),
    _["warmup"] = ch.warmup, _["warmMin"] = ch.warmMin, _["warmMax"] = ch.warmMax,
    _["warmESS"] = ch.warmESS, _["warmCapped"] = ch.warmCapped, _["settled"] = ch.settled,
    _["windows"] = ch.windows, _["winAcc"] = num(ch.winAcc),
    _["winScale"] = Rcpp::wrap(ch.winScale), _["winShape"] = num(ch.winShape));
  out.push_back(ch.warmForget, "warmForget");
  // (the latent noise's shift move's, when it has one)
  for (const char* nm : {"shiftLogsd", "shiftAccBatch", "shiftBatch"})
    if (scale.containsElementNamed(nm)) out.push_back(scale[nm], nm);
  return out;
}

// The chain continued from `state`: its own state, its moves' schedule, the
// warm-up's settings (nBurn < 0: of data-dependent length), the log priors
// and likelihood at its parameters.
static Schedule start_chain(Chain& ch, const Rcpp::List& moves, const Rcpp::List& state,
                            int nBurn) {
  const int d = ch.post.d;
  if (moves.containsElementNamed("params"))
    ch.params = Rcpp::as<Rcpp::CharacterVector>(moves["params"]);
  read_chain(ch, state, d);
  Schedule schedule = make_schedule(ch, moves, state, nBurn);
  ch.adaptive = nBurn < 0;
  if (ch.adaptive) {
    if (ch.warmMax % WINDOW != 0 || ch.warmMin < 0)
      Rcpp::stop("the warm-up bounds must be whole windows of 100 sweeps");
    start_windows(ch, schedule);
  } else {
    ch.warmup = nBurn;
  }
  ch.lp.set_size(d);
  for (int j = 0; j < d; ++j) ch.lp[j] = ch.pr(j, ch.post.phi[j]);
  ch.ll = ch.post.logLik();
  if (!std::isfinite(arma::accu(ch.lp)))
    Rcpp::stop("the initial values are outside the support of their priors");
  return schedule;
}

// The result of a call (the chain-result record of one piece; R's
// result_from_start() builds the run's from it): the `kept` retained draws
// (the first rows of draws, logPost, logLik), the retained sweeps `nPost`,
// the sweeps done and the state (acceptance: each move's counts in the
// state's `moves`, the only count; R's move_acceptance() reads them).
static Rcpp::List piece_result(const Chain& ch, const Schedule& schedule,
                               const Rcpp::List& state, Rcpp::NumericMatrix draws,
                               Rcpp::NumericVector logPost, Rcpp::NumericVector logLik,
                               int kept, int nPost, int done, bool interrupted) {
  const int d = ch.post.d, nKeep = draws.nrow();
  if (kept < nKeep) {  // a warm-up that ended in this piece
    Rcpp::NumericMatrix cut(kept, d);
    for (int j = 0; j < d; ++j)
      std::copy(draws.begin() + j * nKeep, draws.begin() + j * nKeep + kept, cut.begin() + j * kept);
    draws = cut;
    logPost = Rcpp::NumericVector(logPost.begin(), logPost.begin() + kept);
    logLik = Rcpp::NumericVector(logLik.begin(), logLik.begin() + kept);
  }
  using Rcpp::_;
  return Rcpp::List::create(_["draws"] = draws, _["logPost"] = logPost, _["logLik"] = logLik,
                            _["kept"] = kept, _["done"] = done, _["nPost"] = nPost,
                            _["interrupted"] = interrupted,
                            _["state"] = write_chain(ch, schedule, state));
}

// [[Rcpp::export(.fbc_sample_c)]]
Rcpp::List fbc_sample(const arma::mat& Xf, const arma::vec& yf,
                      const arma::mat& Xs, const arma::vec& ys,
                      const Rcpp::List& prior, const Rcpp::List& moves,
                      const Rcpp::List& state, int nIter, int nBurn, int thinning,
                      double nugget, SEXP progress, const Rcpp::List& model) {
  Rcpp::RNGScope rngScope;
  Priors pr{prior["family"], prior["transform"], prior["p1"], prior["p2"],
            prior["a"], prior["b"], prior["lconst"]};
  std::unique_ptr<Posterior> pp = make_posterior(Xf, yf, Xs, ys, nugget, model);
  Posterior& post = *pp;
  const int d = post.d;
  if (!post.init(Rcpp::as<arma::vec>(state["phi"])))
    Rcpp::stop("the covariance matrix is not positive definite at the initial values");
  if (thinning < 1) Rcpp::stop("thinning must be at least 1");

  Chain ch(post, pr);
  Schedule schedule = start_chain(ch, moves, state, nBurn);

  // Retained iterations in (iter, iter + nIter]: it > W, (it - W) % thinning
  // == 0, with W = nBurn, or the warm-up's length once it has ended (at
  // most as many as if it ended now).
  const int it0 = ch.iter, it1 = ch.iter + nIter;
  auto warm = [&]() { return ch.adaptive ? (ch.warmup > 0 ? ch.warmup : INT_MAX) : nBurn; };
  const int W0 = ch.adaptive ? (ch.warmup > 0 ? ch.warmup : it0) : nBurn;
  auto keptUpTo = [&](int it) { return it > W0 ? (it - W0) / thinning : 0; };
  const int nKeep = keptUpTo(it1) - keptUpTo(it0);
  Rcpp::NumericMatrix draws(nKeep, d);
  Rcpp::NumericVector logPost(nKeep), logLik(nKeep);
  int kept = 0, nPost = 0;
  bool interrupted = false;

  SEXP bar = R_NilValue;
  if (!Rf_isNull(progress)) bar = PROTECT(cli_progress_bar(nIter, progress));

  for (int it = it0 + 1; it <= it1; ++it) {
    const int W = warm();
    const bool burn = it <= W;
    sweep(ch, schedule, burn, it);
    if (!burn) ++nPost;
    if (it % BATCH == 0) {
      if (!Rf_isNull(bar) && user_interrupted()) interrupted = true;
      end_batch(ch, schedule, burn, interrupted ? R_NilValue : bar, it);
    }
    if (it > W && (it - W) % thinning == 0 && kept < nKeep) {
      for (int j = 0; j < d; ++j) draws(kept, j) = post.phi[j];
      logLik[kept] = ch.ll;
      logPost[kept] = ch.ll + arma::accu(ch.lp);
      ++kept;
    }
    ch.iter = it;
    // Poll Ctrl-C every 100 iterations, and before every progress update:
    // cli's update runs R code, which would otherwise take the interrupt
    // and unwind through this loop, losing the draws.
    const bool tick = !Rf_isNull(bar) && CLI_SHOULD_TICK;
    if (interrupted || ((it % 100 == 0 || tick) && user_interrupted())) {
      interrupted = true;
      break;
    }
    if (tick) cli_progress_set(bar, it - it0);
  }
  if (!Rf_isNull(bar)) { cli_progress_done(bar); UNPROTECT(1); }

  return piece_result(ch, schedule, state, draws, logPost, logLik, kept, nPost, ch.iter - it0,
                      interrupted);
}

// Log-likelihood log p(y | phi_s) at each row phi_s of `phis`, from
// scratch on one posterior (its workspaces reused; -Inf where the
// covariance is not positive definite); update(fit, sim = ) weighs the
// old draws by it (R/update_runs.R, reweight_runs()).
// [[Rcpp::export(.fbc_loglik_draws_c)]]
arma::vec fbc_loglik_draws(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                           const arma::vec& ys, const arma::mat& phis, double nugget,
                           const Rcpp::List& model) {
  std::unique_ptr<Posterior> post = make_posterior(Xf, yf, Xs, ys, nugget, model);
  arma::vec out(phis.n_rows);
  for (arma::uword s = 0; s < phis.n_rows; ++s) {
    if (s % 100 == 99) Rcpp::checkUserInterrupt();
    const arma::vec phi = phis.row(s).t();
    out[s] = post->init(phi) ? post->logLik() : R_NegInf;
  }
  return out;
}

// Log-likelihood at one parameter vector, computed from scratch
// (fbc_loglik_draws() of one row).
// [[Rcpp::export(.fbc_loglik_c)]]
double fbc_loglik(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                  const arma::vec& ys, const arma::vec& phi, double nugget,
                  const Rcpp::List& model) {
  return fbc_loglik_draws(Xf, yf, Xs, ys, phi.t(), nugget, model)[0];
}

// The warm-up's estimate of a block's covariance (Block::pooled()) from the
// walk positions W (one row per sweep 1, 2, ..., as a block records them
// during a warm-up of data-dependent length), each earlier epoch weighted
// `forget` times the next: mean, covariance (the open window included),
// the draws weighed, and the fewest effective draws per parameter at the
// last window's end (Block::window_ess(); over the first `walked` columns
// when positive, as for a block whose walk moves only those), for the tests.
// [[Rcpp::export(.fbc_block_estimate_c)]]
Rcpp::List fbc_block_estimate(const arma::mat& W, double forget, int walked = 0) {
  Block b;
  std::vector<int> idx(W.n_cols);
  for (size_t i = 0; i < idx.size(); ++i) idx[i] = i;
  b.start(idx, arma::zeros<arma::vec>(W.n_cols));
  b.restart = -1;
  b.forget = forget;
  b.walked = walked;
  double ess = 0;
  for (arma::uword it = 1; it <= W.n_rows; ++it) {
    b.w = W.row(it - 1).t();
    b.record_window(it);
    if (it % WINDOW == 0) ess = b.window_ess();
  }
  arma::vec mu;
  arma::mat C;
  const int count = b.pooled(true, mu, C);
  return Rcpp::List::create(Rcpp::Named("mean") = mu, Rcpp::Named("cov") = C,
                            Rcpp::Named("count") = count, Rcpp::Named("ess") = ess);
}
