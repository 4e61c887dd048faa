// The transformations on which the random walks run, and their Jacobians.
#include "fbc.h"

// Random-walk scale w for a parameter x: identity, w = log x,
// w = log((x - 1) / (2 - x)) for alpha in (1, 2), or w = atanh x for a
// correlation in (-1, 1).
double to_walk(int transform, double x) {
  switch (transform) {
  case TR_LOG: return std::log(x);
  case TR_LOGIT12: return std::log((x - 1.0) / (2.0 - x));
  case TR_ATANH: return std::atanh(x);
  default: return x;
  }
}

double from_walk(int transform, double w) {
  switch (transform) {
  case TR_LOG: return std::exp(w);
  case TR_LOGIT12: return 1.0 + 1.0 / (1.0 + std::exp(-w));
  case TR_ATANH: return std::tanh(w);
  default: return w;
  }
}

// log |dx/dw|: the Jacobian that makes a symmetric walk on w target p(x):
// log x for the log walk, log((x - 1)(2 - x)) for the logit walk,
// log(1 - x^2) for the atanh walk.
double log_jacobian(int transform, double x) {
  switch (transform) {
  case TR_LOG: return std::log(x);
  case TR_LOGIT12: return std::log((x - 1.0) * (2.0 - x));
  case TR_ATANH: return std::log1p(-x * x);
  default: return 0.0;
  }
}
