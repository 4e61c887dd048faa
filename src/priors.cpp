// Prior log-densities (the sampler's, and prior_builder()'s through .log_prior)
// and the table of family codes R/priors.R's registry is checked against.
#include "fbc.h"

// log p(x) for a prior family; -Inf outside the support.
//   uniform(a, b) 1/(b-a); gaussian(mean, sd); gamma(shape, rate);
//   beta(s1, s2); lognormal(meanlog, sdlog); logistic(location, scale);
//   betashift = beta(s1, s2) of x - 1; exponential(rate);
//   inversegamma(shape a, scale b) b^a/Gamma(a) x^-(a+1) exp(-b/x);
//   jeffreys 1/x (x > 0); fixed: log 1 = 0;
//   halft_sd(df, scale): sqrt(x) (a variance's sd) is half-t(df, scale), so
//   p(x) = 2 t_df(sqrt(x) / scale) / scale * 1 / (2 sqrt(x)).
double log_prior(int family, double x, double p1, double p2) {
  const double ninf = R_NegInf;
  if (ISNAN(x)) return ninf;
  switch (family) {
  case PF_UNIFORM:
    return (x >= p1 && x <= p2) ? -std::log(p2 - p1) : ninf;
  case PF_GAUSSIAN:
    return R::dnorm(x, p1, p2, 1);
  case PF_GAMMA:
    return x > 0 ? R::dgamma(x, p1, 1.0 / p2, 1) : ninf;
  case PF_BETA:
    return (x >= 0 && x <= 1) ? R::dbeta(x, p1, p2, 1) : ninf;
  case PF_LOGNORMAL:
    return x > 0 ? R::dlnorm(x, p1, p2, 1) : ninf;
  case PF_LOGISTIC:
    return R::dlogis(x, p1, p2, 1);
  case PF_BETASHIFT:
    return (x >= 1 && x <= 2) ? R::dbeta(x - 1.0, p1, p2, 1) : ninf;
  case PF_EXPONENTIAL:
    return x >= 0 ? R::dexp(x, 1.0 / p1, 1) : ninf;
  case PF_INVGAMMA:
    return x > 0 ? p1 * std::log(p2) - R::lgammafn(p1) - (p1 + 1.0) * std::log(x) - p2 / x
                 : ninf;
  case PF_JEFFREYS:
    return x > 0 ? -std::log(x) : ninf;
  case PF_FIXED:
    return 0.0;
  case PF_HALFT_SD:
    return x > 0 ? R::dt(std::sqrt(x) / p2, p1, 1) - std::log(p2) - 0.5 * std::log(x) : ninf;
  }
  Rcpp::stop("unknown prior family code %d", family);
}

// Vectorised log prior for R's prior_builder(): x is in the prior's units.
// [[Rcpp::export(.log_prior)]]
Rcpp::NumericVector log_prior_vec(const Rcpp::NumericVector& x, int family,
                                  double p1, double p2) {
  Rcpp::NumericVector out(x.size());
  for (R_xlen_t i = 0; i < x.size(); ++i) out[i] = log_prior(family, x[i], p1, p2);
  return out;
}

// The family codes by name, the one place C++ spells the families' names: the
// registry in R/priors.R must give each family the same code (the package
// checks it when it loads, check_prior_codes()).
// [[Rcpp::export(.prior_codes)]]
Rcpp::IntegerVector prior_codes() {
  using Rcpp::_;
  return Rcpp::IntegerVector::create(
      _["uniform"] = PF_UNIFORM, _["gaussian"] = PF_GAUSSIAN, _["gamma"] = PF_GAMMA,
      _["beta"] = PF_BETA, _["lognormal"] = PF_LOGNORMAL, _["logistic"] = PF_LOGISTIC,
      _["betashift"] = PF_BETASHIFT, _["exponential"] = PF_EXPONENTIAL,
      _["inversegamma"] = PF_INVGAMMA, _["jeffreys"] = PF_JEFFREYS, _["fixed"] = PF_FIXED,
      _["halft_sd"] = PF_HALFT_SD);
}
