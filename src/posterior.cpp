// The model as R hands it over (read_model()) and the algebra for the data
// at hand (make_posterior()): every entry point builds its posterior here,
// and nothing else names the algebras.
#include "fbc.h"

// The compiled core's code tables by name (walks, kernels, algebras,
// prediction types, what a move touches) and the names of the classes it
// computes with: R's tables (R/boundary.R) must agree and R's model_classes
// name every such class, which the package checks when it loads
// (check_model_codes()).
// [[Rcpp::export(.model_codes)]]
Rcpp::List model_codes() {
  using Rcpp::_;
  const std::vector<ClassNeed> need = class_needs(1, 1, 1, 1, 1, 1, 0, 0, 0);
  Rcpp::CharacterVector cls(need.size());
  for (size_t c = 0; c < need.size(); ++c) cls[c] = need[c].name;
  const Rcpp::List kern = kernel_table();
  return Rcpp::List::create(
      _["walk"] = Rcpp::IntegerVector::create(_["identity"] = TR_IDENTITY, _["log"] = TR_LOG,
                                              _["logit12"] = TR_LOGIT12, _["atanh"] = TR_ATANH),
      _["kernel"] = kern["code"], _["kernelAlpha"] = kern["alpha"],
      _["algebra"] = Rcpp::IntegerVector::create(_["auto"] = ALG_AUTO, _["dense"] = ALG_DENSE,
                                                 _["vecchia"] = ALG_VECCHIA),
      _["type"] = Rcpp::IntegerVector::create(_["field"] = PT_FIELD, _["mean"] = PT_MEAN,
                                              _["simulator"] = PT_SIMULATOR, _["bias"] = PT_BIAS),
      _["touch"] = Rcpp::IntegerVector::create(
          _["residual"] = TK_RESIDUAL, _["kappa"] = TK_KAPPA, _["sim"] = TK_SIM,
          _["simPow"] = TK_SIMPOW, _["simLevels"] = TK_SIMLEVELS, _["bias"] = TK_BIAS,
          _["biasPow"] = TK_BIASPOW, _["field"] = TK_FIELD, _["runs"] = TK_RUNS,
          _["latent"] = TK_LATENT, _["latentHyper"] = TK_LATENTHYPER, _["latentK"] = TK_LATENTK),
      _["class"] = cls);
}

// The Vecchia algebra's design (R/vecchia.R, vecchia_design()) into vd.
static void read_vecchia(const Rcpp::List& v, VecchiaDesign& vd) {
  vd.k = Rcpp::as<int>(v["k"]);
  vd.kf = Rcpp::as<int>(v["kf"]);
  const Rcpp::IntegerVector ord = v["order"];
  const Rcpp::IntegerMatrix nbr = v["neighbours"];
  if (vd.k < 1 || vd.kf < 0 || nbr.ncol() != vd.k || nbr.nrow() != ord.size())
    Rcpp::stop("the Vecchia design's neighbours must be an m x k matrix");
  vd.w = Rcpp::as<arma::vec>(v["scaling"]);
  vd.ord.resize(ord.size());
  vd.nbr.assign((size_t) ord.size() * vd.k, -1);
  for (int i = 0; i < ord.size(); ++i) {
    vd.ord[i] = ord[i] - 1;
    for (int c = 0; c < vd.k; ++c) {
      const int r = nbr(i, c);
      if (r == NA_INTEGER || r < 0 || r > ord.size())
        Rcpp::stop("the Vecchia design's neighbours must be row numbers");
      vd.nbr[(size_t) i * vd.k + c] = r - 1;  // 0 (none) becomes -1
    }
  }
}

// model[name], 1-based codes 1 .. hi (hi < 0: no bound), 0-based; empty
// when the model has none.
static std::vector<int> read_codes(const Rcpp::List& model, const char* name, int hi,
                                   const char* what) {
  std::vector<int> out;
  if (!model.containsElementNamed(name)) return out;
  const Rcpp::IntegerVector g = model[name];
  for (int v : g) {
    if (v == NA_INTEGER || v < 1 || (hi >= 0 && v > hi)) Rcpp::stop("%s must be 1, 2, ...", what);
    out.push_back(v - 1);
  }
  return out;
}

// The field rows' groups and the categorical inputs of `model` into `out`:
// each row's measurement-error group (`noise`), its distinct row
// (`fieldRows`), the categorical inputs' indicator columns and levels
// (`levels`), and with a bias per data set each row's data set (`source`,
// `sourceLevels`).
static void read_groups(const Rcpp::List& model, int p, Model& out) {
  out.noise = read_codes(model, "noise", -1, "noise groups");
  out.fieldRows = read_codes(model, "fieldRows", -1, "the field rows' groups");
  if (model.containsElementNamed("levels")) {
    const Rcpp::List lv = model["levels"];
    const Rcpp::IntegerVector col = lv["col"], ncol = lv["ncol"], L = lv["L"];
    if (col.size() != L.size() || ncol.size() != L.size())
      Rcpp::stop("the levels need col, ncol and L for each categorical input");
    for (int f = 0; f < L.size(); ++f) {
      LevelInput in;
      in.col = col[f] - 1; in.ncol = ncol[f]; in.L = L[f];
      if (in.L < 2 || in.col < 0 || in.col + in.ncol > p ||
          in.ncol != (in.L == 2 ? 1 : in.L))
        Rcpp::stop("categorical input %d: its indicator columns do not fit the inputs", f + 1);
      out.levels.push_back(in);
    }
  }
  if (model.containsElementNamed("source")) {
    out.sourceL = Rcpp::as<int>(model["sourceLevels"]);
    out.source = read_codes(model, "source", out.sourceL, "the field data sets");
  }
}

// The layout of `model` (offset and length named by class, R's table order).
static Layout read_layout(const Rcpp::List& model) {
  if (!model.containsElementNamed("touch") || !model.containsElementNamed("scaled"))
    Rcpp::stop("the layout needs what a move of each class touches and which the scale move scales");
  const Rcpp::IntegerVector off = model["offset"], len = model["length"], touch = model["touch"];
  const Rcpp::LogicalVector scaled = model["scaled"];
  if (off.size() != len.size() || off.size() != touch.size() || off.size() != scaled.size() ||
      Rf_isNull(off.names()))
    Rcpp::stop("the layout needs an offset, a length, a touch and a scaled named by class");
  const Rcpp::CharacterVector nm = off.names(), nl = len.names(), nt = touch.names(),
                              ns = scaled.names();
  Layout lay;
  for (int c = 0; c < off.size(); ++c) {
    if (nm[c] != nl[c] || nm[c] != nt[c] || nm[c] != ns[c])
      Rcpp::stop("the layout's offsets, lengths, touches and scales name different classes");
    if (touch[c] < TK_RESIDUAL || touch[c] > TK_LATENTK || scaled[c] == NA_LOGICAL)
      Rcpp::stop("class %s: unknown touch code %d", Rcpp::as<std::string>(nm[c]).c_str(), touch[c]);
    lay.names.push_back(Rcpp::as<std::string>(nm[c]));
    lay.offset.push_back(off[c]);
    lay.length.push_back(len[c]);
    lay.touch.push_back(touch[c]);
    lay.scaled.push_back(scaled[c]);
  }
  fill_layout(lay);
  return lay;
}

// The independent outputs' indicator columns of `model` into out.outputs.
static void read_outputs(const Rcpp::List& model, int p, Model& out) {
  if (!model.containsElementNamed("outputs")) return;
  const Rcpp::List ov = model["outputs"];
  LevelInput& o = out.outputs;
  o.col = Rcpp::as<int>(ov["col"]) - 1; o.ncol = Rcpp::as<int>(ov["ncol"]);
  o.L = Rcpp::as<int>(ov["L"]);
  if (o.L < 2 || o.col < 0 || o.col + o.ncol > p || o.ncol != (o.L == 2 ? 1 : o.L))
    Rcpp::stop("the outputs' indicator columns do not fit the inputs");
  if (out.algebra == ALG_VECCHIA)
    Rcpp::stop("independent outputs have no nearest-neighbour algebra");
  if (!out.emulator) Rcpp::stop("a simulator function has no independent outputs");
}

Model read_model(const Rcpp::List& model, int p, int q) {
  Model out;
  out.kernS = Rcpp::as<int>(model["kernS"]);
  out.kernB = Rcpp::as<int>(model["kernB"]);
  out.algebra = Rcpp::as<int>(model["algebra"]);
  if (model.containsElementNamed("threads")) out.threads = Rcpp::as<int>(model["threads"]);
  read_groups(model, p, out);
  // a simulator given as a function (function.cpp) has no simulator GP
  out.emulator = !model.containsElementNamed("simulator");
  // independent outputs: the perOutput classes (all but kappa and sigma2E)
  // hold one copy per output
  read_outputs(model, p, out);
  Layout& lay = out.layout;
  lay = read_layout(model);
  const int K = out.nOutputs();
  // a stochastic simulator's replicates (R/sim_noise.R): one emulated output
  if (model.containsElementNamed("replicates")) {
    const Rcpp::List rp = model["replicates"];
    out.repCount = Rcpp::as<std::vector<double> >(rp["count"]);
    // (one within sum of squares, or one per unique input with an
    // input-dependent noise)
    const std::vector<double> ssw = Rcpp::as<std::vector<double> >(rp["ssw"]);
    out.repSSW = 0.0;
    for (double v : ssw) out.repSSW += v;
    if (lay.length_of("gR") > 0) out.repSSWi = ssw;
    out.fieldRealization = rp.containsElementNamed("realization") && Rcpp::as<bool>(rp["realization"]);
    out.repDf = 0.0;
    for (double c : out.repCount) {
      if (!(c >= 1)) Rcpp::stop("the replicate counts must be 1, 2, ...");
      out.repDf += c - 1.0;
    }
  }
  // what each class expands over (class_needs()); a bias when sigma2B has
  // parameters
  const int b = lay.length_of("sigma2B") > 0 ? 1 : 0;
  const int G = out.noise.empty() ? 1 : *std::max_element(out.noise.begin(), out.noise.end()) + 1;
  for (const ClassNeed& c : class_needs(p, q, K, out.emulator ? 1 : 0, b, G, level_count(out.levels),
                                        out.sourceL * (out.sourceL - 1) / 2,
                                        (int) out.repCount.size())) {
    const int have = lay.length_of(c.name);
    if (have != c.length && !(c.optional && have == 0))
      Rcpp::stop("the layout gives %s %d entries where the data need %d", c.name, have, c.length);
  }
  // the algebra computes with every class the layout has (on a product
  // design make_block() takes the Kronecker algebra only where they allow)
  const unsigned kind = !out.emulator ? AK_FUNCTION
                        : (K > 1 ? AK_OUTPUTS : 0u) | (out.algebra == ALG_VECCHIA ? AK_VECCHIA : AK_DENSE);
  if (const char* cls = class_outside(lay, kind))
    Rcpp::stop("the model's algebra does not compute with %s", cls);
  // the noise: sigma2R (constant) or gR, one per unique input, with its GP's
  // muG, sigma2G and thetaG (input-dependent)
  const int nR = lay.length_of("sigma2R"), nG = lay.length_of("gR");
  const bool lat = nG > 0;
  if ((nR > 0 || lat) != !out.repCount.empty() || nR > 1 || (nR && lat) ||
      (lat && (nG != (int) out.repCount.size() || lay.length_of("muG") != 1 ||
               lay.length_of("sigma2G") != 1 || lay.length_of("thetaG") != p + q)) ||
      (!lat && lay.length_of("muG") + lay.length_of("sigma2G") + lay.length_of("thetaG") > 0))
    Rcpp::stop("the layout's noise classes (sigma2R %d, gR %d entries) do not fit the %d unique runs",
               nR, nG, (int) out.repCount.size());
  if (out.algebra == ALG_VECCHIA) {
    if (!model.containsElementNamed("vecchia"))
      Rcpp::stop("the Vecchia algebra needs its design (model$vecchia)");
    read_vecchia(model["vecchia"], out.vecchia);
  }
  return out;
}

// One output's algebra: Kronecker on a product design unless the model asks
// for the dense one, Vecchia when it asks for that, else dense.
static std::unique_ptr<Posterior> make_block(const arma::mat& Xf, const arma::vec& yf,
                                             const arma::mat& Xs, const arma::vec& ys,
                                             double nugget, const Model& model) {
  if (model.algebra == ALG_VECCHIA)
    return std::unique_ptr<Posterior>(new VecchiaPosterior(Xf, yf, Xs, ys, nugget, model));
  if (Xs.n_cols <= Xf.n_cols) Rcpp::stop("Xs needs more columns than Xf");
  // (the Kronecker algebra where its classes allow, class_needs())
  if (model.algebra == ALG_AUTO && !class_outside(model.layout, AK_KRONECKER)) {
    ProductDesign pd;
    if (product_design(Xs, Xf.n_cols, pd, model.levels.empty() && model.outputs.L == 0))
      return std::unique_ptr<Posterior>(new KroneckerPosterior(Xf, yf, Xs, ys, nugget, model, pd));
  }
  return std::unique_ptr<Posterior>(new DensePosterior(Xf, yf, Xs, ys, nugget, model));
}

std::unique_ptr<Posterior> make_posterior(const arma::mat& Xf, const arma::vec& yf,
                                          const arma::mat& Xs, const arma::vec& ys,
                                          double nugget, const Model& model) {
  check_kernel(model.kernS);
  check_kernel(model.kernB);
  if (model.algebra != ALG_AUTO && model.algebra != ALG_DENSE && model.algebra != ALG_VECCHIA)
    Rcpp::stop("unknown algebra code %d", model.algebra);
  if (model.nOutputs() > 1)
    return std::unique_ptr<Posterior>(new OutputsPosterior(Xf, yf, Xs, ys, nugget, model,
                                                           make_block));
  return make_block(Xf, yf, Xs, ys, nugget, model);
}

std::unique_ptr<Posterior> make_posterior(const arma::mat& Xf, const arma::vec& yf,
                                          const arma::mat& Xs, const arma::vec& ys,
                                          double nugget, const Rcpp::List& model) {
  if (Xs.n_cols <= Xf.n_cols) Rcpp::stop("Xs needs more columns than Xf");
  const Model mod = read_model(model, Xf.n_cols, Xs.n_cols - Xf.n_cols);
  if (!mod.emulator) return make_function_posterior(Xf, yf, mod, model["simulator"]);
  return make_posterior(Xf, yf, Xs, ys, nugget, mod);
}


// Log-likelihood at each row of `phis`, reached by moves from the previous
// row, so that the cached block updates can be checked against a dense
// formula. `groups[j]` > 0 puts parameter j in a group moved jointly (one
// propose() of the group's changed coordinates); 0 moves it alone.
// scale: when the scaled variances (Posterior::scaled) all change by one
// factor, move them by proposeScale(). decoys: before each move, propose
// another value and reject it. model: the model description (read_model()).
// [[Rcpp::export(.loglik_path_c)]]
Rcpp::NumericVector loglik_path(const arma::mat& Xf, const arma::vec& yf,
                                const arma::mat& Xs, const arma::vec& ys,
                                const arma::mat& phis, double nugget,
                                SEXP groups, bool decoys, bool scale,
                                const Rcpp::List& model) {
  std::unique_ptr<Posterior> pp = make_posterior(Xf, yf, Xs, ys, nugget, model);
  Posterior& post = *pp;
  Rcpp::NumericVector out(phis.n_rows, NA_REAL);
  if (!post.init(phis.row(0).t())) return out;
  out[0] = post.logLik();
  const int d = post.d;
  std::vector<int> grp(d, 0);
  if (!Rf_isNull(groups)) {
    const Rcpp::IntegerVector g(groups);
    for (int j = 0; j < std::min<int>(d, g.size()); ++j) grp[j] = g[j];
  }
  const int nG = *std::max_element(grp.begin(), grp.end());
  auto move = [&](const std::vector<int>& idx, const arma::vec& vals) {
    if (decoys) {
      arma::vec dv(vals.n_elem);
      for (size_t i = 0; i < idx.size(); ++i) dv[i] = 0.5 * (vals[i] + post.phi[idx[i]]) + 0.01;
      post.propose(idx, dv);
      post.reject();
    }
    const double ll = post.propose(idx, vals);
    if (!std::isfinite(ll)) { post.reject(); return false; }
    post.accept();
    return true;
  };
  for (arma::uword r = 1; r < phis.n_rows; ++r) {
    const arma::vec row = phis.row(r).t();
    if (scale) {
      const std::vector<int>& v = post.scaled;
      const double c = row[v[0]] / post.phi[v[0]];
      bool same = c != 1.0;
      for (int j : v) same = same && std::fabs(row[j] / post.phi[j] - c) < 1e-12 * c;
      if (same) {
        if (decoys) { post.proposeScale(1.3); post.reject(); }
        if (!std::isfinite(post.proposeScale(c))) { post.reject(); return out; }
        post.accept();
        for (int j : v) post.phi[j] = row[j];  // exact values
      }
    }
    for (int g = 1; g <= nG; ++g) {
      std::vector<int> idx;
      for (int j = 0; j < d; ++j) if (grp[j] == g && row[j] != post.phi[j]) idx.push_back(j);
      if (idx.empty()) continue;
      arma::vec vals(idx.size());
      for (size_t i = 0; i < idx.size(); ++i) vals[i] = row[idx[i]];
      if (!move(idx, vals)) return out;
    }
    for (int j = 0; j < d; ++j) {
      if (row[j] == post.phi[j]) continue;
      if (!move(std::vector<int>{j}, arma::vec{row[j]})) return out;
    }
    out[r] = post.logLik();
  }
  return out;
}
