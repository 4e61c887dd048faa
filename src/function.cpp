// The posterior of a simulator given as an R function f(x, kappa)
// (R/simulator_function.R builds the closures). No simulator GP: in the
// scaled space, with fs(kappa) the scaled f at the n field rows,
//   yf = fs(kappa) + delta + eps,
//   S = sigma2B Rb + sigma2E I   (with a bias GP: its mean muB when muB
//       has parameters, else 0; Rb -> Rz when scaled, lambdaZ; without
//       one S = sigma2E I),
//   log L = -0.5 [ n log 2pi + log|S| + v'v ],  v = F^-1 (yf - muB - fs),
// S = F F' (FieldFactor, field.cpp). f is called once per kappa proposal (the closure `field`,
// vectorised over the field rows) and its value kept on accept; a move of
// the bias or noise parameters reuses it. Rb lives on the nu distinct field
// rows (replicates share their bias).
#include "fbc.h"

class FunctionPosterior : public Posterior {
public:
  FunctionPosterior(const arma::mat& Xf, const arma::vec& yf, const Model& model,
                    const Rcpp::List& sim)
    : Xf_(Xf), yf_(yf), kernB_(model.kernB), fieldFn_(Rcpp::as<Rcpp::Function>(sim["field"])),
      atFn_(Rcpp::as<Rcpp::Function>(sim["at"])) {
    if (!model.levels.empty() || model.sourceL)
      Rcpp::stop("a function simulator takes no categorical inputs or bias per data set");
    set_sizes(Xf.n_rows, 0, Xf.n_cols, model.layout.length_of("kappa"), model);
    set_field(Xf, model);  // the distinct field rows, as SchurPosterior's
    for (int b = 0; b < 2; ++b) {
      f_.b[b].zeros(n); Rb_.b[b].zeros(nu_, nu_);
    }
    M_.zeros(nu_, nu_);
    dv_.zeros(n);
  }

  bool init(const arma::vec& phi0) override {
    set_phi(phi0);
    tk_ = tb_ = tf_ = true;
    sc_ = false;
    if (!std::isfinite(evaluate())) return false;
    flip();
    return true;
  }
  double logLik() const override { return loglik_.cur(); }

  double propose(const std::vector<int>& idx, const arma::vec& values) override {
    saveSet(idx, values);
    tk_ = tb_ = tf_ = sc_ = false;
    for (size_t i = 0; i < idx.size(); ++i) {
      // (the layout's touch: kappa calls f, the bias GP's correlation moves
      // S, the variances S's factor, muB only the residual)
      switch (layout.touch[layout.cls[idx[i]]]) {
      case TK_KAPPA: tk_ = true; break;
      case TK_BIAS: case TK_BIASPOW: tb_ = tf_ = true; break;
      case TK_FIELD: tf_ = true; break;
      default: break;
      }
    }
    return evaluate();
  }

  // S -> c S: log|S| + n log c, v'v / c (the variances sigma2B, sigma2E).
  double proposeScale(double c) override {
    saveScale(c);
    tk_ = tb_ = tf_ = false;
    sc_ = true;
    if (!(c > 0) || !std::isfinite(c)) return R_NegInf;
    ldS_.alt() = ldS_.cur() + n * std::log(c);
    vv_.alt() = vv_.cur() / c;
    loglik_.alt() = -0.5 * (n * LOG_2PI + ldS_.alt() + vv_.alt());
    return loglik_.alt();
  }

  void accept() override {
    if (sc_) {
      FS_.alt() = FS_.cur();
      FS_.alt().scale(pendingScale());
    }
    flip();
  }
  void reject() override { restore(); }

  // the log-likelihood is -0.5 |b - muB a|^2 + const, b = F^-1 (yf - fs)
  // (S = F F')
  void muBQuadratic(double& aa, double& ab) const override {
    mub_quadratic(FS_.cur(), grp_, yf_ - f_.cur(), aa, ab);
  }

  void condition(const arma::mat& Xnew, int type, double* mean, double* var,
                 const int* noise = nullptr, const int* source = nullptr) override;

  bool heldout(const std::vector<std::vector<int> >&, arma::vec&, arma::vec&) override {
    Rcpp::stop("a simulator given as a function has no runs to hold out");
  }

  // As SchurPosterior::fieldLoo (loo.cpp) with r = yf - muB - fs.
  void fieldLoo(const std::vector<std::vector<int> >& groups, arma::vec& logdens) const override {
    gaussian_loo(FS_.cur().inverse(grp_), yf_ - (biasMean ? phi[iMuB] : 0.0) - f_.cur(), groups,
                 logdens);
  }

  std::string algebra() const override { return "function"; }

private:
  const arma::mat& Xf_;
  const arma::vec& yf_;
  int kernB_;
  Rcpp::Function fieldFn_, atFn_;
  bool tk_ = false, tb_ = false, tf_ = false, sc_ = false;
  Buf2<arma::vec> f_;
  Buf2<arma::mat> Rb_;
  Buf2<FieldFactor> FS_;  // the field block's factor, S = D + Z s2B Rb Z'
  arma::mat M_;
  arma::vec dv_;
  Buf2<double> ldS_, vv_, loglik_;
  arma::mat Bz_, Wz_;

  // kappa as the named-by-R vector the closures take: q values copied from
  // phi (one object, so that begin() and end() bound the same memory).
  Rcpp::NumericVector kappa() const {
    return Rcpp::NumericVector(phi.begin() + iKappa, phi.begin() + iKappa + q);
  }
  // The scaled f at the field rows for the current kappa: false when the
  // closure returns NULL (a non-finite value the user asked to reject).
  bool callField(arma::vec& out) {
    SEXP r = fieldFn_(kappa());
    if (Rf_isNull(r)) return false;
    Rcpp::NumericVector v(r);
    if (v.size() != n) Rcpp::stop("the simulator's closure returned %d values for %d rows", (int) v.size(), n);
    out = Rcpp::as<arma::vec>(v);
    return true;
  }
  // The bias correlation on the distinct rows (the discrepancy model's).
  bool biasCorr(arma::mat& R) {
    R = corr_matrix(Xu_, Xu_, phi.subvec(iThetaB, iThetaB + p - 1),
                    phi.subvec(iAlphaB, iAlphaB + p - 1), kernB_);
    if (!biasModel(R, Bz_, Wz_)) return false;
    R = arma::symmatl(R);
    return true;
  }
  // The blocks the proposal touches into the scratch buffers; the
  // log-likelihood (the formula atop the file).
  double evaluate() {
    if (tk_ && !callField(f_.alt())) return R_NegInf;
    if (tb_ && bias && !biasCorr(Rb_.alt())) return R_NegInf;
    const arma::vec& f = tk_ ? f_.alt() : f_.cur();
    const arma::mat& Rb = tb_ ? Rb_.alt() : Rb_.cur();
    if (tf_) {
      const double s2B = bias ? phi[iSigma2B] : 0.0;
      for (int c = 0; c < nu_; ++c)
        for (int r = c; r < nu_; ++r) M_.at(r, c) = bias ? s2B * Rb.at(r, c) : 0.0;
      for (int j = 0; j < n; ++j) dv_[j] = phi[iSigma2E + noise_[j]];
      if (!FS_.alt().factor(M_, grp_, dv_, nu_ < n, 0.0)) return R_NegInf;
      ldS_.alt() = FS_.alt().logdet;
    } else {
      ldS_.alt() = ldS_.cur();
    }
    const FieldFactor& FS = tf_ ? FS_.alt() : FS_.cur();
    const double muB = biasMean ? phi[iMuB] : 0.0;
    arma::vec v = yf_ - muB - f;
    FS.whiten(v, grp_);
    vv_.alt() = arma::dot(v, v);
    loglik_.alt() = -0.5 * (n * LOG_2PI + ldS_.alt() + vv_.alt());
    return loglik_.alt();
  }
  void flip() {
    if (tk_) f_.flip();
    if (tb_) Rb_.flip();
    if (tf_ || sc_) FS_.flip();
    ldS_.flip(); vv_.flip(); loglik_.flip();
  }
};

// Prediction at new scaled inputs Xnew, at the current state. The bias
// part is the GP conditional given the field residual r = yf - muB - fs:
// with K the bias's cross-correlation (KOH: R(Xu, Xnew), r0 = 1; S-GaSP:
// the discretized kernel, as SchurPosterior::biasCross), h = F^-1 s2B K,
// v = F^-1 r:  bias mean = muB + h'v, variance s2B r0 - h'h. By type:
// 1 field = f(x*) + bias + eps (variance + sigma2E of its group),
// 2 mean = f(x*) + bias, 3 simulator = f(x*) (variance 0: f is known),
// 4 bias. f(x*) comes from the closure `at`, once per draw.
void FunctionPosterior::condition(const arma::mat& Xnew, int type, double* mean, double* var,
                                  const int* noise, const int*) {
  const int b = Xnew.n_rows;
  arma::vec fn(b, arma::fill::zeros);
  if (type != PT_BIAS) {
    Rcpp::NumericVector r = atFn_(Rcpp::wrap(Xnew), kappa());
    if (r.size() != b) Rcpp::stop("the simulator's closure returned %d values for %d points", (int) r.size(), b);
    fn = Rcpp::as<arma::vec>(r);
  }
  arma::vec bm(b, arma::fill::zeros), bv(b, arma::fill::zeros);
  if (type != PT_SIMULATOR && bias) {
    const double s2B = phi[iSigma2B], muB = biasMean ? phi[iMuB] : 0.0;
    const arma::vec thetaB = phi.subvec(iThetaB, iThetaB + p - 1);
    const arma::vec alphaB = phi.subvec(iAlphaB, iAlphaB + p - 1);
    arma::mat K = corr_matrix(Xu_, Xnew, thetaB, alphaB, kernB_);
    arma::vec r0;
    biasModelCross([&] { return corr_matrix(Xu_, Xu_, thetaB, alphaB, kernB_); }, K, r0);
    arma::mat H = s2B * K.rows(arma::conv_to<arma::uvec>::from(grp_));
    FS_.cur().whiten(H, grp_);
    arma::vec v = yf_ - muB - f_.cur();
    FS_.cur().whiten(v, grp_);
    bm = muB + H.t() * v;
    bv = s2B * r0 - arma::sum(arma::square(H), 0).t();
  }
  const int G = layout.length_of("sigma2E");
  for (int c = 0; c < b; ++c) {
    mean[c] = (type == PT_BIAS ? 0.0 : fn[c]) + (type == PT_SIMULATOR ? 0.0 : bm[c]);
    var[c] = type == PT_SIMULATOR ? 0.0 : bv[c];
    if (type == PT_FIELD) {
      const int g = noise ? noise[c] : 0;
      if (g < 0 || g >= G) Rcpp::stop("noise group %d of a new point is not one of the %d", g + 1, G);
      var[c] += phi[iSigma2E + g];
    }
  }
}

std::unique_ptr<Posterior> make_function_posterior(const arma::mat& Xf, const arma::vec& yf,
                                                   const Model& model, const Rcpp::List& sim) {
  return std::unique_ptr<Posterior>(new FunctionPosterior(Xf, yf, model, sim));
}
