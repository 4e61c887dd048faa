// Adaptive Metropolis-within-Gibbs sweep over phi (vignette 3.4, A.2).
//
// Each sampled parameter x_j moves by a Gaussian random walk on w = g(x_j)
// (identity for kappa and muB, log for theta and variances, logit of x - 1
// for alpha), accepted with
//   log r = log L(phi*) + log p(x*) - log L(phi) - log p(x)
//           + log|dx/dw|(x*) - log|dx/dw|(x).
// During burn-in the log proposal SD moves every 50 iterations by
// +-1/sqrt(batch) towards acceptance 0.44; afterwards it is frozen.
//
// Optional block move (blockSim = TRUE): all free thetaS/alphaS move at once,
// w* = w + exp(s) L e, e ~ N(0, I), on the same walk scales (one m x m
// factorization per sweep instead of 2(p+q)). L starts as diag(proposal SDs)
// and, after 100 burn-in sweeps, becomes the Cholesky factor of the running
// covariance of w over burn-in (refreshed every 50 sweeps, Haario et al.
// 2001); s moves by +-min(0.5, 1/sqrt(b)) per batch b towards acceptance
// 0.234. Both are frozen after burn-in; `blockInit` (a previous run's
// `block`) restarts from an adapted L and s.
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

// [[Rcpp::export(.fbc_sample)]]
Rcpp::List fbc_sample(const arma::mat& Xf, const arma::vec& yf,
                      const arma::mat& Xs, const arma::vec& ys,
                      const Rcpp::List& prior, const arma::vec& init,
                      const arma::vec& logsdInit, int nIter, int nBurn,
                      int thinning, bool adapt, int batchStart, double nugget,
                      SEXP progress, bool blockSim = false,
                      SEXP blockInit = R_NilValue) {
  Rcpp::RNGScope rngScope;
  Priors pr{prior["family"], prior["transform"], prior["p1"], prior["p2"],
            prior["a"], prior["b"], prior["lconst"]};
  Posterior post(Xf, yf, Xs, ys, nugget);
  const int d = post.d;
  if (!post.init(init))
    Rcpp::stop("the covariance matrix is not positive definite at the initial values");

  std::vector<int> free;
  for (int j = 0; j < d; ++j) if (pr.family[j] != PF_FIXED) free.push_back(j);

  // Block move of the free thetaS/alphaS (empty unless blockSim).
  std::vector<int> blk;
  if (blockSim)
    for (int j : free) if (j >= post.iThetaS && j < post.iThetaB) blk.push_back(j);
  const int nb = blk.size();
  arma::vec bW(nb), bNew(nb), bE(nb), bMean(nb, arma::fill::zeros), bLp(nb);
  arma::vec simVals(post.iThetaB - post.iThetaS);
  arma::mat bCov(nb, nb, arma::fill::zeros), bL(nb, nb, arma::fill::zeros), bTmp(nb, nb);
  for (int i = 0; i < nb; ++i) bL(i, i) = std::exp(logsdInit[blk[i]]);
  double bScale = nb > 0 ? -0.5 * std::log((double) nb) : 0.0, bAccBatch = 0, bAccKept = 0;
  int bN = 0, bBatch = 0;
  bool bShaped = false;  // L is the factor of the empirical covariance
  // Continuing a run (update()): start from the block proposal it adapted.
  if (nb > 0 && !Rf_isNull(blockInit)) {
    const Rcpp::List bi(blockInit);
    const arma::mat L0 = Rcpp::as<arma::mat>(bi["chol"]);
    if ((int) L0.n_rows != nb || (int) L0.n_cols != nb)
      Rcpp::stop("the block proposal to continue from has the wrong size");
    bL = L0;
    bScale = Rcpp::as<double>(bi["logscale"]);
    bShaped = Rcpp::as<bool>(bi["shaped"]);
  }

  arma::vec logsd = logsdInit;
  arma::vec lp(d);
  for (int j = 0; j < d; ++j) lp[j] = pr(j, post.phi[j]);
  double ll = post.logLik();
  if (!std::isfinite(arma::accu(lp)))
    Rcpp::stop("the initial values are outside the support of their priors");

  const int nKeep = (nIter - nBurn) / thinning;
  Rcpp::NumericMatrix draws(nKeep, d);
  Rcpp::NumericVector logPost(nKeep), logLik(nKeep);
  arma::vec accBatch(d, arma::fill::zeros), accKept(d, arma::fill::zeros);
  int batch = batchStart, kept = 0, done = 0;
  bool interrupted = false;

  SEXP bar = R_NilValue;
  if (!Rf_isNull(progress)) bar = PROTECT(cli_progress_bar(nIter, progress));
  char status[128];

  for (int it = 1; it <= nIter; ++it) {
    for (int j : free) {
      if (nb > 0 && j >= post.iThetaS && j < post.iThetaB) {
        if (j != blk[0]) continue;
        // Joint thetaS/alphaS move.
        for (int i = 0; i < nb; ++i) bE[i] = R::norm_rand();
        bool ok = true;
        double lpDiff = 0, jac = 0;
        const double sc = std::exp(bScale);
        for (int i = 0; i < nb; ++i) {
          const int k = blk[i], tr = pr.transform[k];
          bW[i] = to_walk(tr, post.phi[k]);
          double step = 0;
          for (int l = 0; l <= i; ++l) step += bL(i, l) * bE[l];
          bNew[i] = bW[i] + sc * step;
          const double xNew = from_walk(tr, bNew[i]);
          bLp[i] = pr(k, xNew);
          lpDiff += bLp[i] - lp[k];
          jac += log_jacobian(tr, xNew) - log_jacobian(tr, post.phi[k]);
          simVals[k - post.iThetaS] = xNew;
        }
        if (!std::isfinite(lpDiff) || !std::isfinite(jac)) ok = false;
        if (ok) {
          for (int k = post.iThetaS; k < post.iThetaB; ++k)
            if (pr.family[k] == PF_FIXED) simVals[k - post.iThetaS] = post.phi[k];
          const double llNew = post.proposeSim(simVals);
          if (std::isfinite(llNew) && std::log(R::unif_rand()) < llNew - ll + lpDiff + jac) {
            post.accept();
            ll = llNew;
            for (int i = 0; i < nb; ++i) {
              lp[blk[i]] = bLp[i]; bW[i] = bNew[i];
              accBatch[blk[i]] += 1;  // shown by the progress bar only
            }
            bAccBatch += 1;
            if (it > nBurn) bAccKept += 1;
          } else {
            post.reject();
          }
        }
        if (adapt && it <= nBurn) {  // running mean and covariance of w (Welford)
          ++bN;
          for (int i = 0; i < nb; ++i) bE[i] = bW[i] - bMean[i];
          bMean += bE / bN;
          for (int a = 0; a < nb; ++a)
            for (int b = 0; b <= a; ++b) bCov(a, b) += bE[a] * (bW[b] - bMean[b]);
        }
        continue;
      }
      const int tr = pr.transform[j];
      const double x = post.phi[j];
      const double xNew = from_walk(tr, to_walk(tr, x) + std::exp(logsd[j]) * R::norm_rand());
      const double lpNew = pr(j, xNew);
      if (!std::isfinite(lpNew)) continue;
      const double jac = log_jacobian(tr, xNew) - log_jacobian(tr, x);
      if (!std::isfinite(jac)) continue;
      const double llNew = post.propose(j, xNew);
      const double logr = llNew + lpNew - ll - lp[j] + jac;
      if (std::isfinite(llNew) && std::log(R::unif_rand()) < logr) {
        post.accept();
        ll = llNew; lp[j] = lpNew;
        accBatch[j] += 1;
        if (it > nBurn) accKept[j] += 1;
      } else {
        post.reject();
      }
    }

    if (it % BATCH == 0) {
      ++batch;
      if (adapt && it <= nBurn) {
        const double delta = 1.0 / std::sqrt((double) batch);
        for (int j : free)  // (the block's coordinates keep their single-site SDs)
          if (nb == 0 || j < post.iThetaS || j >= post.iThetaB)
            logsd[j] += (accBatch[j] / BATCH > 0.44) ? delta : -delta;
        if (nb > 0) {
          ++bBatch;
          bScale += (bAccBatch / BATCH > 0.234 ? 1 : -1) * std::min(0.5, 1.0 / std::sqrt((double) bBatch));
          if (bN >= 2 * BATCH) {
            bTmp = bCov / (bN - 1);  // lower triangle
            const double eps = 1e-10 * (1 + arma::max(bTmp.diag()));
            for (int i = 0; i < nb; ++i) bTmp(i, i) += eps;
            if (chol_lower(bTmp)) {
              bL = arma::trimatl(bTmp);
              if (!bShaped) bScale = std::log(2.38 / std::sqrt((double) nb));
              bShaped = true;
            }
          }
        }
      }
      if (!Rf_isNull(bar) && user_interrupted()) interrupted = true;
      if (!Rf_isNull(bar) && !interrupted) {
        double lo = 1, mean = 0;
        for (int j : free) { lo = std::min(lo, accBatch[j] / BATCH); mean += accBatch[j] / BATCH; }
        if (!free.empty()) mean /= free.size();
        std::snprintf(status, sizeof status, "%s | acceptance min %.2f mean %.2f",
                      it <= nBurn ? "burn-in" : "sampling", lo, mean);
        cli_progress_set_status(bar, status);
      }
      accBatch.zeros();
      bAccBatch = 0;
    }

    if (it > nBurn && (it - nBurn) % thinning == 0 && kept < nKeep) {
      for (int j = 0; j < d; ++j) draws(kept, j) = post.phi[j];
      logLik[kept] = ll;
      logPost[kept] = ll + arma::accu(lp);
      ++kept;
    }
    done = it;
    // Poll Ctrl-C every 100 iterations, and before every progress update:
    // cli's update runs R code, which would otherwise take the interrupt
    // and unwind through this loop, losing the draws.
    const bool tick = !Rf_isNull(bar) && CLI_SHOULD_TICK;
    if (interrupted || ((it % 100 == 0 || tick) && user_interrupted())) {
      interrupted = true;
      break;
    }
    if (tick) cli_progress_set(bar, it);
  }
  if (!Rf_isNull(bar)) { cli_progress_done(bar); UNPROTECT(1); }

  const int nPost = std::max(0, done - nBurn);
  Rcpp::NumericVector acceptance(d, NA_REAL);
  for (int j : free) acceptance[j] = nPost > 0 ? accKept[j] / nPost : NA_REAL;
  for (int j : blk) acceptance[j] = nPost > 0 ? bAccKept / nPost : NA_REAL;

  Rcpp::List out = Rcpp::List::create(
    Rcpp::Named("draws") = draws, Rcpp::Named("logPost") = logPost,
    Rcpp::Named("logLik") = logLik, Rcpp::Named("kept") = kept,
    Rcpp::Named("acceptance") = acceptance,
    Rcpp::Named("logsd") = Rcpp::NumericVector(logsd.begin(), logsd.end()),
    Rcpp::Named("last") = Rcpp::NumericVector(post.phi.begin(), post.phi.end()),
    Rcpp::Named("batch") = batch, Rcpp::Named("done") = done,
    Rcpp::Named("interrupted") = interrupted);
  if (nb > 0) {
    Rcpp::IntegerVector idx(nb);
    for (int i = 0; i < nb; ++i) idx[i] = blk[i] + 1;
    out.push_back(Rcpp::List::create(Rcpp::Named("index") = idx,
                                     Rcpp::Named("logscale") = bScale,
                                     Rcpp::Named("chol") = bL,
                                     Rcpp::Named("shaped") = bShaped), "block");
  }
  return out;
}

// Log-likelihood at one parameter vector, computed from scratch.
// [[Rcpp::export(.fbc_loglik)]]
double fbc_loglik(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                  const arma::vec& ys, const arma::vec& phi, double nugget) {
  Posterior post(Xf, yf, Xs, ys, nugget);
  return post.init(phi) ? post.logLik() : R_NegInf;
}
