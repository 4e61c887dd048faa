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
//   during burn-in its log SD moves every 50 sweeps by +-1/sqrt(batch)
//   towards acceptance 0.44;
// * block (at the block's first parameter): all its parameters move at once,
//   w* = w + exp(s) L e, e ~ N(0, I), with the same acceptance ratio summed
//   over the block. L starts as diag(proposal SDs) and, after 100 burn-in
//   sweeps, becomes the Cholesky factor of the running covariance of w over
//   burn-in (refreshed every 50 sweeps, Haario et al. 2001); s moves by
//   +-min(0.5, 1/sqrt(b)) per batch b towards acceptance 0.234 (0.44 for one
//   parameter);
// * muB (gaussian prior N(m0, s0^2)): drawn exactly from its full conditional,
//   log L being Gaussian in muB (Posterior::muBQuadratic): precision
//   a'a + 1/s0^2, mean (a'b + m0/s0^2) / precision;
// * scale (after the sweep): sigma2S, sigma2B, sigma2E all multiplied by
//   c = exp(e), e ~ N(0, exp(2 s)): a joint random walk on their logs, whose
//   likelihood needs no factorization (C -> c C); log r adds the three prior
//   ratios and the Jacobian 3e. s adapts towards 0.44 like a single site.
// Every adapted scale is frozen after burn-in, so the retained draws come
// from one valid kernel. The sampler's whole state (parameters, proposals,
// adaptation sums, batch counters) goes in and comes out as a list: a run
// split into pieces (update(), checkpoints) is the same run, given R's RNG
// state.
#include "fbc.h"
#include <cli/progress.h>

static void check_interrupt_fn(void*) { R_CheckUserInterrupt(); }
// TRUE when the user pressed Ctrl-C (the interrupt is consumed here so the
// draws made so far can be returned).
static bool user_interrupted() {
  return !R_ToplevelExec(check_interrupt_fn, NULL);
}

static const int BATCH = 50;

// prior on parameter j: family code, parameters, and the affine map
// prior argument = a + b * phi_j (kappa is stored on the [0,1] scale).
struct Priors {
  Rcpp::IntegerVector family, transform;
  Rcpp::NumericVector p1, p2, a, b, lconst;
  double operator()(int j, double x) const {
    return log_prior(family[j], a[j] + b[j] * x, p1[j], p2[j]) + lconst[j];
  }
};

// An adaptive joint random walk over some parameters (see the top).
struct Block {
  std::vector<int> idx;
  int repeats = 1;  // moves per sweep
  arma::vec mean, w, wNew, e, lpNew, vals;
  arma::mat cov, L, tmp;  // cov: Welford sums of squares (lower triangle)
  double logscale = 0, accBatch = 0, accKept = 0;
  int n = 0, batch = 0, restart = 0;
  bool shaped = false;

  void start(const std::vector<int>& index, const arma::vec& logsd) {
    idx = index;
    const int k = idx.size();
    mean.zeros(k); cov.zeros(k, k); L.zeros(k, k);
    for (int i = 0; i < k; ++i) L(i, i) = std::exp(logsd[idx[i]]);
    logscale = -0.5 * std::log((double) k);
    alloc();
  }
  void alloc() {
    const int k = idx.size();
    w.set_size(k); wNew.set_size(k); e.set_size(k); lpNew.set_size(k); vals.set_size(k);
  }
  void read(const Rcpp::List& s) {
    const Rcpp::IntegerVector ix = s["index"];
    idx.assign(ix.begin(), ix.end());
    for (int& j : idx) j -= 1;
    mean = Rcpp::as<arma::vec>(s["mean"]);
    cov = Rcpp::as<arma::mat>(s["cov"]);
    L = Rcpp::as<arma::mat>(s["chol"]);
    logscale = s["logscale"]; accBatch = s["accBatch"];
    n = s["n"]; batch = s["batch"]; shaped = s["shaped"];
    alloc();
  }
  Rcpp::List write() const {
    Rcpp::IntegerVector ix(idx.size());
    for (size_t i = 0; i < idx.size(); ++i) ix[i] = idx[i] + 1;
    return Rcpp::List::create(
      Rcpp::Named("index") = ix, Rcpp::Named("logscale") = logscale,
      Rcpp::Named("chol") = L, Rcpp::Named("shaped") = shaped,
      Rcpp::Named("mean") = mean, Rcpp::Named("cov") = cov, Rcpp::Named("n") = n,
      Rcpp::Named("batch") = batch, Rcpp::Named("accBatch") = accBatch);
  }
  // Start the running mean and covariance afresh (L is kept).
  void forget() { n = 0; mean.zeros(); cov.zeros(); }
  // Welford update of the running mean and covariance of w.
  void record() {
    ++n;
    const int k = idx.size();
    for (int i = 0; i < k; ++i) e[i] = w[i] - mean[i];
    mean += e / n;
    for (int a = 0; a < k; ++a)
      for (int b = 0; b <= a; ++b) cov(a, b) += e[a] * (w[b] - mean[b]);
  }
  // End of a burn-in batch: scale towards the target acceptance, shape L.
  void adapt() {
    const int k = idx.size();
    ++batch;
    const double target = k == 1 ? 0.44 : 0.234;
    logscale += (accBatch / BATCH > target ? 1 : -1) * std::min(0.5, 1.0 / std::sqrt((double) batch));
    if (n >= 2 * BATCH) {
      tmp = cov / (n - 1);
      const double eps = 1e-10 * (1 + arma::max(tmp.diag()));
      for (int i = 0; i < k; ++i) tmp(i, i) += eps;
      if (chol_lower(tmp)) {
        L = arma::trimatl(tmp);
        if (!shaped) logscale = std::log(2.38 / std::sqrt((double) k));
        shaped = true;
      }
    }
  }
};

// Everything a chain carries from one piece of a run to the next.
struct Chain {
  Posterior& post;
  const Priors& pr;
  arma::vec logsd, lp, accBatch, accKept;
  std::vector<Block> blocks;
  std::vector<int> blockAt;  // blockAt[j]: block starting at parameter j, else -1
  std::vector<char> inBlock;
  bool scaleMove = false, gibbsMuB = false;
  double scaleLogsd = std::log(0.1), scaleAccBatch = 0, scaleAccKept = 0;
  int scaleBatch = 0, iter = 0, batch = 0;
  double ll = 0;
  Chain(Posterior& p, const Priors& r) : post(p), pr(r) {}
};

// Single-site random-walk Metropolis move of parameter j.
static bool move_single(Chain& ch, int j) {
  Posterior& post = ch.post;
  const int tr = ch.pr.transform[j];
  const double x = post.phi[j];
  const double xNew = from_walk(tr, to_walk(tr, x) + std::exp(ch.logsd[j]) * R::norm_rand());
  const double lpNew = ch.pr(j, xNew);
  if (!std::isfinite(lpNew)) return false;
  const double jac = log_jacobian(tr, xNew) - log_jacobian(tr, x);
  if (!std::isfinite(jac)) return false;
  const double llNew = post.propose(j, xNew);
  const double logr = llNew + lpNew - ch.ll - ch.lp[j] + jac;
  if (std::isfinite(llNew) && std::log(R::unif_rand()) < logr) {
    post.accept();
    ch.ll = llNew; ch.lp[j] = lpNew;
    return true;
  }
  post.reject();
  return false;
}

// Joint random-walk move of a block (w* = w + exp(s) L e).
static bool move_block(Chain& ch, Block& b) {
  Posterior& post = ch.post;
  const int k = b.idx.size();
  for (int i = 0; i < k; ++i) b.e[i] = R::norm_rand();
  const double sc = std::exp(b.logscale);
  double lpDiff = 0, jac = 0;
  for (int i = 0; i < k; ++i) {
    const int j = b.idx[i], tr = ch.pr.transform[j];
    b.w[i] = to_walk(tr, post.phi[j]);
    double step = 0;
    for (int l = 0; l <= i; ++l) step += b.L(i, l) * b.e[l];
    b.wNew[i] = b.w[i] + sc * step;
    b.vals[i] = from_walk(tr, b.wNew[i]);
    b.lpNew[i] = ch.pr(j, b.vals[i]);
    lpDiff += b.lpNew[i] - ch.lp[j];
    jac += log_jacobian(tr, b.vals[i]) - log_jacobian(tr, post.phi[j]);
  }
  if (!std::isfinite(lpDiff) || !std::isfinite(jac)) return false;
  const double llNew = post.propose(b.idx, b.vals);
  if (std::isfinite(llNew) && std::log(R::unif_rand()) < llNew - ch.ll + lpDiff + jac) {
    post.accept();
    ch.ll = llNew;
    for (int i = 0; i < k; ++i) { ch.lp[b.idx[i]] = b.lpNew[i]; b.w[i] = b.wNew[i]; }
    return true;
  }
  post.reject();
  return false;
}

// Exact draw of muB from its Gaussian full conditional (gaussian prior).
static void move_muB(Chain& ch) {
  Posterior& post = ch.post;
  const int j = post.iMuB;
  double aa, ab;
  post.muBQuadratic(aa, ab);
  const double m0 = ch.pr.p1[j], s0 = ch.pr.p2[j];
  const double prec = aa + 1.0 / (s0 * s0);
  const double mu = (ab + m0 / (s0 * s0)) / prec + R::norm_rand() / std::sqrt(prec);
  const double llNew = post.propose(j, mu);
  post.accept();
  ch.ll = llNew;
  ch.lp[j] = ch.pr(j, mu);
}

// sigma2S, sigma2B, sigma2E multiplied by one factor c = exp(e).
static bool move_scale(Chain& ch) {
  Posterior& post = ch.post;
  const double e = std::exp(ch.scaleLogsd) * R::norm_rand(), c = std::exp(e);
  double lpNew[3], lpDiff = 0;
  for (int i = 0; i < 3; ++i) {
    const int j = post.iSigma2S + i;
    lpNew[i] = ch.pr(j, post.phi[j] * c);
    lpDiff += lpNew[i] - ch.lp[j];
  }
  if (!std::isfinite(lpDiff)) return false;
  const double llNew = post.proposeScale(c);
  if (std::isfinite(llNew) && std::log(R::unif_rand()) < llNew - ch.ll + lpDiff + 3 * e) {
    post.accept();
    ch.ll = llNew;
    for (int i = 0; i < 3; ++i) ch.lp[post.iSigma2S + i] = lpNew[i];
    return true;
  }
  post.reject();
  return false;
}

static double list_num(const Rcpp::List& s, const char* name, double dflt) {
  return s.containsElementNamed(name) ? Rcpp::as<double>(s[name]) : dflt;
}

// [[Rcpp::export(.fbc_sample)]]
Rcpp::List fbc_sample(const arma::mat& Xf, const arma::vec& yf,
                      const arma::mat& Xs, const arma::vec& ys,
                      const Rcpp::List& prior, const Rcpp::List& moves,
                      const Rcpp::List& state, int nIter, int nBurn, int thinning,
                      double nugget, SEXP progress, int kernS = 1, int kernB = 1,
                      int algebra = 0) {
  Rcpp::RNGScope rngScope;
  Priors pr{prior["family"], prior["transform"], prior["p1"], prior["p2"],
            prior["a"], prior["b"], prior["lconst"]};
  std::unique_ptr<Posterior> pp = make_posterior(Xf, yf, Xs, ys, nugget, kernS, kernB, algebra);
  Posterior& post = *pp;
  const int d = post.d;
  if (!post.init(Rcpp::as<arma::vec>(state["phi"])))
    Rcpp::stop("the covariance matrix is not positive definite at the initial values");
  if (thinning < 1) Rcpp::stop("thinning must be at least 1");

  Chain ch(post, pr);
  ch.logsd = Rcpp::as<arma::vec>(state["logsd"]);
  ch.iter = (int) list_num(state, "iter", 0);
  ch.batch = (int) list_num(state, "batch", 0);
  ch.accBatch = state.containsElementNamed("accBatch") ?
    Rcpp::as<arma::vec>(state["accBatch"]) : arma::vec(d, arma::fill::zeros);
  ch.accKept.zeros(d);
  ch.scaleMove = Rcpp::as<bool>(moves["scale"]);
  ch.gibbsMuB = Rcpp::as<bool>(moves["gibbsMuB"]);
  if (ch.gibbsMuB && !(pr.family[post.iMuB] == PF_GAUSSIAN && pr.a[post.iMuB] == 0 &&
                       pr.b[post.iMuB] == 1))
    Rcpp::stop("the exact muB move needs a gaussian prior on muB");
  ch.scaleLogsd = list_num(state, "scaleLogsd", std::log(0.1));
  ch.scaleAccBatch = list_num(state, "scaleAccBatch", 0);
  ch.scaleBatch = (int) list_num(state, "scaleBatch", 0);

  std::vector<int> free;
  for (int j = 0; j < d; ++j) if (pr.family[j] != PF_FIXED) free.push_back(j);
  // Blocks: continue the adapted ones of `state`, else start the ones of `moves`.
  const Rcpp::List blockSpec = moves["blocks"];
  const Rcpp::IntegerVector repeats = moves.containsElementNamed("repeats") ?
    Rcpp::as<Rcpp::IntegerVector>(moves["repeats"]) : Rcpp::IntegerVector(0);
  // The joint proposals' covariance is estimated afresh from the middle of
  // burn-in (when burn-in has at least 400 sweeps), so the first sweeps'
  // drift from the starting point does not inflate it.
  const int restartAt = nBurn >= 400 ? nBurn / 2 : 0;
  Rcpp::List blockState;
  if (state.containsElementNamed("blocks") && !Rf_isNull(state["blocks"]))
    blockState = Rcpp::as<Rcpp::List>(state["blocks"]);
  const bool haveBlocks = blockState.size() > 0 && blockState.size() == blockSpec.size();
  ch.blocks.resize(blockSpec.size());
  for (int b = 0; b < blockSpec.size(); ++b) {
    if (haveBlocks) {
      ch.blocks[b].read(Rcpp::as<Rcpp::List>(blockState[b]));
    } else {
      const Rcpp::IntegerVector ix = blockSpec[b];
      std::vector<int> idx(ix.begin(), ix.end());
      for (int& j : idx) j -= 1;
      ch.blocks[b].start(idx, ch.logsd);
    }
    const Rcpp::IntegerVector ix = blockSpec[b];
    if ((int) ch.blocks[b].idx.size() != ix.size())
      Rcpp::stop("the block proposal to continue from has the wrong size");
    if (repeats.size() > b) ch.blocks[b].repeats = std::max(1, repeats[b]);
    ch.blocks[b].restart = restartAt;
  }
  ch.blockAt.assign(d, -1);
  ch.inBlock.assign(d, 0);
  for (int b = 0; b < (int) ch.blocks.size(); ++b) {
    for (int j : ch.blocks[b].idx) {
      if (j < 0 || j >= d || pr.family[j] == PF_FIXED || ch.inBlock[j])
        Rcpp::stop("a block holds a fixed, repeated or unknown parameter");
      ch.inBlock[j] = 1;
    }
    ch.blockAt[ch.blocks[b].idx[0]] = b;
  }
  if (ch.scaleMove)
    for (int i = 0; i < 3; ++i)
      if (pr.family[post.iSigma2S + i] == PF_FIXED)
        Rcpp::stop("the scale move needs sigma2S, sigma2B and sigma2E all sampled");

  ch.lp.set_size(d);
  for (int j = 0; j < d; ++j) ch.lp[j] = pr(j, post.phi[j]);
  ch.ll = post.logLik();
  if (!std::isfinite(arma::accu(ch.lp)))
    Rcpp::stop("the initial values are outside the support of their priors");

  // Retained iterations in (iter, iter + nIter]: it > nBurn, (it - nBurn) % thinning == 0.
  const int it0 = ch.iter, it1 = ch.iter + nIter;
  auto keptUpTo = [&](int it) { return it > nBurn ? (it - nBurn) / thinning : 0; };
  const int nKeep = keptUpTo(it1) - keptUpTo(it0);
  Rcpp::NumericMatrix draws(nKeep, d);
  Rcpp::NumericVector logPost(nKeep), logLik(nKeep);
  int kept = 0, nPost = 0;
  double scaleAccKept = 0;
  bool interrupted = false;

  SEXP bar = R_NilValue;
  if (!Rf_isNull(progress)) bar = PROTECT(cli_progress_bar(nIter, progress));
  char status[128];

  for (int it = it0 + 1; it <= it1; ++it) {
    const bool burn = it <= nBurn;
    for (int j : free) {
      if (ch.inBlock[j]) {
        if (ch.blockAt[j] < 0) continue;
        Block& b = ch.blocks[ch.blockAt[j]];
        for (int r = 0; r < b.repeats; ++r) {
          if (move_block(ch, b)) {
            b.accBatch += 1.0 / b.repeats;
            if (!burn) b.accKept += 1.0 / b.repeats;
            for (int k : b.idx) ch.accBatch[k] += 1.0 / b.repeats;  // progress bar only
          }
          if (burn) {
            if (it == b.restart && r == 0) b.forget();
            b.record();
          }
        }
      } else if (j == post.iMuB && ch.gibbsMuB) {
        move_muB(ch);
        ch.accBatch[j] += 1;
        if (!burn) ch.accKept[j] += 1;
      } else if (move_single(ch, j)) {
        ch.accBatch[j] += 1;
        if (!burn) ch.accKept[j] += 1;
      }
    }
    if (ch.scaleMove && move_scale(ch)) {
      ch.scaleAccBatch += 1;
      if (!burn) scaleAccKept += 1;
    }
    if (!burn) ++nPost;

    if (it % BATCH == 0) {
      ++ch.batch;
      if (burn) {
        const double delta = 1.0 / std::sqrt((double) ch.batch);
        for (int j : free)
          if (!ch.inBlock[j] && !(j == post.iMuB && ch.gibbsMuB))
            ch.logsd[j] += (ch.accBatch[j] / BATCH > 0.44) ? delta : -delta;
        for (Block& b : ch.blocks) b.adapt();
        if (ch.scaleMove) {
          ++ch.scaleBatch;
          ch.scaleLogsd += (ch.scaleAccBatch / BATCH > 0.44 ? 1 : -1) *
            std::min(0.5, 1.0 / std::sqrt((double) ch.scaleBatch));
        }
      }
      if (!Rf_isNull(bar) && user_interrupted()) interrupted = true;
      if (!Rf_isNull(bar) && !interrupted) {
        double lo = 1, mean = 0;
        for (int j : free) { lo = std::min(lo, ch.accBatch[j] / BATCH); mean += ch.accBatch[j] / BATCH; }
        if (!free.empty()) mean /= free.size();
        std::snprintf(status, sizeof status, "%s | acceptance min %.2f mean %.2f",
                      burn ? "burn-in" : "sampling", lo, mean);
        cli_progress_set_status(bar, status);
      }
      ch.accBatch.zeros();
      for (Block& b : ch.blocks) b.accBatch = 0;
      ch.scaleAccBatch = 0;
    }

    if (it > nBurn && (it - nBurn) % thinning == 0 && kept < nKeep) {
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

  Rcpp::NumericVector acceptance(d, NA_REAL);
  for (int j : free) acceptance[j] = nPost > 0 ? ch.accKept[j] / nPost : NA_REAL;
  for (const Block& b : ch.blocks)
    for (int j : b.idx) acceptance[j] = nPost > 0 ? b.accKept / nPost : NA_REAL;

  Rcpp::List blocksOut(ch.blocks.size());
  for (size_t b = 0; b < ch.blocks.size(); ++b) blocksOut[b] = ch.blocks[b].write();
  Rcpp::List stateOut = Rcpp::List::create(
    Rcpp::Named("phi") = Rcpp::NumericVector(post.phi.begin(), post.phi.end()),
    Rcpp::Named("logsd") = Rcpp::NumericVector(ch.logsd.begin(), ch.logsd.end()),
    Rcpp::Named("iter") = ch.iter, Rcpp::Named("batch") = ch.batch,
    Rcpp::Named("accBatch") = Rcpp::NumericVector(ch.accBatch.begin(), ch.accBatch.end()),
    Rcpp::Named("blocks") = blocksOut,
    Rcpp::Named("scaleLogsd") = ch.scaleLogsd,
    Rcpp::Named("scaleAccBatch") = ch.scaleAccBatch,
    Rcpp::Named("scaleBatch") = ch.scaleBatch);
  return Rcpp::List::create(
    Rcpp::Named("draws") = draws, Rcpp::Named("logPost") = logPost,
    Rcpp::Named("logLik") = logLik, Rcpp::Named("kept") = kept,
    Rcpp::Named("acceptance") = acceptance,
    Rcpp::Named("scaleAcceptance") = (ch.scaleMove && nPost > 0) ? scaleAccKept / nPost : NA_REAL,
    Rcpp::Named("done") = ch.iter - it0, Rcpp::Named("nPost") = nPost,
    Rcpp::Named("interrupted") = interrupted, Rcpp::Named("state") = stateOut);
}

// Log-likelihood at one parameter vector, computed from scratch.
// [[Rcpp::export(.fbc_loglik)]]
double fbc_loglik(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                  const arma::vec& ys, const arma::vec& phi, double nugget,
                  int kernS = 1, int kernB = 1, int algebra = 0) {
  std::unique_ptr<Posterior> post = make_posterior(Xf, yf, Xs, ys, nugget, kernS, kernB, algebra);
  return post->init(phi) ? post->logLik() : R_NegInf;
}
