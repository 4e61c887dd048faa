// Adaptive Metropolis-within-Gibbs sweep over phi (vignette 3.4, A.2).
//
// Each sampled parameter x_j moves by a Gaussian random walk on w = g(x_j)
// (identity for kappa and muB, log for theta and variances, logit of x - 1
// for alpha), accepted with
//   log r = log L(phi*) + log p(x*) - log L(phi) - log p(x)
//           + log|dx/dw|(x*) - log|dx/dw|(x).
// During burn-in the log proposal SD moves every 50 iterations by
// +-1/sqrt(batch) towards acceptance 0.44; afterwards it is frozen.
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
                      SEXP progress) {
  Rcpp::RNGScope rngScope;
  Priors pr{prior["family"], prior["transform"], prior["p1"], prior["p2"],
            prior["a"], prior["b"], prior["lconst"]};
  Posterior post(Xf, yf, Xs, ys, nugget);
  const int d = post.d;
  if (!post.init(init))
    Rcpp::stop("the covariance matrix is not positive definite at the initial values");

  std::vector<int> free;
  for (int j = 0; j < d; ++j) if (pr.family[j] != PF_FIXED) free.push_back(j);

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
        for (int j : free) logsd[j] += (accBatch[j] / BATCH > 0.44) ? delta : -delta;
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

  return Rcpp::List::create(
    Rcpp::Named("draws") = draws, Rcpp::Named("logPost") = logPost,
    Rcpp::Named("logLik") = logLik, Rcpp::Named("kept") = kept,
    Rcpp::Named("acceptance") = acceptance,
    Rcpp::Named("logsd") = Rcpp::NumericVector(logsd.begin(), logsd.end()),
    Rcpp::Named("last") = Rcpp::NumericVector(post.phi.begin(), post.phi.end()),
    Rcpp::Named("batch") = batch, Rcpp::Named("done") = done,
    Rcpp::Named("interrupted") = interrupted);
}

// Log-likelihood at one parameter vector, computed from scratch.
// [[Rcpp::export(.fbc_loglik)]]
double fbc_loglik(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                  const arma::vec& ys, const arma::vec& phi, double nugget) {
  Posterior post(Xf, yf, Xs, ys, nugget);
  return post.init(phi) ? post.logLik() : R_NegInf;
}
