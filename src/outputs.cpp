// Independent outputs (calibrate(outputs = "independent"), R/outputs.R).
//
// Output o has its own simulator GP (thetaS_o, alphaS_o, sigma2S_o, ...) and
// its own bias GP, independent of the other outputs'; only kappa is shared
// (and sigma2E is per output x data set already). With the rows of y =
// (yf, ys) grouped by output, C = blockdiag(C_1, ..., C_K), so
//   log L(phi) = sum_o log L_o(kappa, phi_o),
// each term the KOH log-likelihood (model.cpp) of output o's rows alone.
// Each output's block is a posterior of its own (the factory's `block`:
// the Kronecker algebra on a product design, dense otherwise), over its own
// copy of its rows; its parameter vector phi_o is a map into phi (kappa,
// then its copy of each perOutput class, its own measurement-error groups).
// A move touches the outputs whose parameters it moves (kappa: all).
#include "fbc.h"

// Output o's model: the layout of one output (its classes in the layout's order,
// kappa first), its rows' measurement-error groups renumbered
// among its own, the data sets of its rows; map_[o] the place in phi of
// each of its parameters.
void OutputsPosterior::sub_model(const Model& model, int o, Model& sub) {
  sub = model;
  sub.outputs = LevelInput{0, 0, 0};
  const Layout& g = model.layout;
  // output o's measurement-error groups, in order of the global ones
  const int G = g.length_of("sigma2E");
  std::vector<int> has(G, 0);
  for (int i : rowsF_[o]) has[noise_.empty() ? 0 : noise_[i]] = 1;
  groupLocal_[o].assign(G, -1);
  std::vector<int> groups;
  for (int k = 0; k < G; ++k)
    if (has[k]) { groupLocal_[o][k] = groups.size(); groups.push_back(k); }
  sub.noise.resize(rowsF_[o].size());
  for (size_t i = 0; i < rowsF_[o].size(); ++i) sub.noise[i] = groupLocal_[o][noise_.empty() ? 0 : noise_[rowsF_[o][i]]];
  if (!model.source.empty()) {
    sub.source.resize(rowsF_[o].size());
    for (size_t i = 0; i < rowsF_[o].size(); ++i) sub.source[i] = model.source[rowsF_[o][i]];
  }
  // its rows' distinct rows, renumbered in order of first appearance
  if (!model.fieldRows.empty()) {
    std::vector<int> local(n, -1);
    int nu = 0;
    sub.fieldRows.resize(rowsF_[o].size());
    for (size_t i = 0; i < rowsF_[o].size(); ++i) {
      const int u = model.fieldRows[rowsF_[o][i]];
      if (u >= n) Rcpp::stop("the field rows' groups must be numbered in order");
      int& g = local[u];
      if (g < 0) g = nu++;
      sub.fieldRows[i] = g;
    }
  }
  Layout& lay = sub.layout;
  map_[o].clear();
  int at = 0;
  const int C = g.names.size();
  lay.names = g.names;
  lay.offset.assign(C, 0); lay.length.assign(C, 0);
  for (int c = 0; c < C; ++c) {
    // shared: kappa; sigma2E per measurement-error group (output o's own)
    const bool kappa = g.names[c] == "kappa", noise = g.names[c] == "sigma2E";
    const int len = noise ? (int) groups.size() : kappa ? g.length[c] : g.length[c] / K_;
    lay.offset[c] = at;
    lay.length[c] = len;
    for (int k = 0; k < len; ++k)
      map_[o].push_back(noise ? g.offset[c] + groups[k]
                        : kappa ? g.offset[c] + k : g.offset[c] + o * len + k);
    at += len;
  }
  // map_[o] is in the layout's class order; fill_layout() wants offsets
  fill_layout(lay);
}

OutputsPosterior::OutputsPosterior(const arma::mat& Xf, const arma::vec& yf, const arma::mat& Xs,
                                   const arma::vec& ys, double nugget, const Model& model,
                                   BlockFactory block)
  : K_(model.nOutputs()), out_(model.outputs) {
  if (Xs.n_cols <= Xf.n_cols) Rcpp::stop("Xs needs more columns than Xf");
  set_sizes(Xf.n_rows, Xs.n_rows, Xf.n_cols, Xs.n_cols - Xf.n_cols, model);
  if (!model.noise.empty() && (int) model.noise.size() != n)
    Rcpp::stop("the noise groups must give one group per field row (%d)", n);
  noise_ = model.noise;
  rowsF_.assign(K_, {}); rowsS_.assign(K_, {});
  localF_.resize(n); localS_.resize(m);
  outF_.resize(n); outS_.resize(m);
  for (int i = 0; i < n; ++i) {
    const int o = outF_[i] = level_of(Xf, i, out_);
    localF_[i] = rowsF_[o].size();
    rowsF_[o].push_back(i);
  }
  for (int i = 0; i < m; ++i) {
    const int o = outS_[i] = level_of(Xs, i, out_);
    localS_[i] = rowsS_[o].size();
    rowsS_[o].push_back(i);
  }
  Xf_.resize(K_); yf_.resize(K_); Xs_.resize(K_); ys_.resize(K_);
  map_.resize(K_); groupLocal_.resize(K_);
  owner_.assign(d, -2); local_.assign(d, -1);
  for (int o = 0; o < K_; ++o) {
    if (rowsF_[o].empty() || rowsS_[o].size() < 2)
      Rcpp::stop("independent outputs: output %d needs field rows and simulator runs", o + 1);
    const arma::uvec rf = arma::conv_to<arma::uvec>::from(rowsF_[o]);
    const arma::uvec rs = arma::conv_to<arma::uvec>::from(rowsS_[o]);
    Xf_[o] = Xf.rows(rf); yf_[o] = yf.elem(rf);
    Xs_[o] = Xs.rows(rs); ys_[o] = ys.elem(rs);
  }
  subModel_.reserve(K_);
  for (int o = 0; o < K_; ++o) {
    subModel_.emplace_back();
    Model& sub = subModel_.back();
    sub_model(model, o, sub);
    for (size_t k = 0; k < map_[o].size(); ++k) {
      const int j = map_[o][k];
      owner_[j] = layout.is(j, "kappa") ? -1 : o;
      local_[j] = k;
    }
    sub_.push_back(block(Xf_[o], yf_[o], Xs_[o], ys_[o], nugget, sub));
  }
  for (int j = 0; j < d; ++j)
    if (owner_[j] == -2) Rcpp::stop("independent outputs: parameter %d belongs to no output", j + 1);
  llo_.assign(K_, 0.0); llNew_.assign(K_, 0.0); touched_.assign(K_, 0);
}

// Output o's parameters at phi.
static arma::vec local_phi(const arma::vec& phi, const std::vector<int>& map) {
  arma::vec out(map.size());
  for (size_t k = 0; k < map.size(); ++k) out[k] = phi[map[k]];
  return out;
}

// The rows of X in output o (read off its indicator columns `out`).
static arma::uvec output_rows(const arma::mat& X, const LevelInput& out, int o) {
  std::vector<arma::uword> r;
  for (arma::uword i = 0; i < X.n_rows; ++i)
    if (level_of(X, i, out) == o) r.push_back(i);
  return arma::uvec(r);
}

bool OutputsPosterior::init(const arma::vec& phi0) {
  set_phi(phi0);
  ll_ = 0.0;
  for (int o = 0; o < K_; ++o) {
    if (!sub_[o]->init(local_phi(phi, map_[o]))) return false;
    llo_[o] = sub_[o]->logLik();
    ll_ += llo_[o];
  }
  return true;
}

// Each touched output proposes its own parameters among idx; log L moves by
// the touched outputs' changes.
double OutputsPosterior::propose(const std::vector<int>& idx, const arma::vec& values) {
  saveSet(idx, values);
  scaleMove_ = false;
  std::vector<std::vector<int> > li(K_);
  std::vector<std::vector<double> > lv(K_);
  for (size_t i = 0; i < idx.size(); ++i) {
    const int j = idx[i];
    for (int o = 0; o < K_; ++o)
      if (owner_[j] == -1 || owner_[j] == o) { li[o].push_back(local_[j]); lv[o].push_back(values[i]); }
  }
  llProp_ = ll_;
  for (int o = 0; o < K_; ++o) {
    touched_[o] = !li[o].empty();
    if (!touched_[o]) continue;
    llNew_[o] = sub_[o]->propose(li[o], arma::vec(lv[o]));
    llProp_ += llNew_[o] - llo_[o];
  }
  return std::isfinite(llProp_) ? llProp_ : R_NegInf;
}

// Every output's variances times c.
double OutputsPosterior::proposeScale(double c) {
  saveScale(c);
  scaleMove_ = true;
  llProp_ = 0.0;
  for (int o = 0; o < K_; ++o) {
    touched_[o] = 1;
    llNew_[o] = sub_[o]->proposeScale(c);
    llProp_ += llNew_[o];
  }
  return std::isfinite(llProp_) ? llProp_ : R_NegInf;
}

void OutputsPosterior::accept() {
  for (int o = 0; o < K_; ++o)
    if (touched_[o]) { sub_[o]->accept(); llo_[o] = llNew_[o]; }
  ll_ = 0.0;
  for (int o = 0; o < K_; ++o) ll_ += llo_[o];
}

void OutputsPosterior::reject() {
  for (int o = 0; o < K_; ++o)
    if (touched_[o]) sub_[o]->reject();
  restore();
}

// The exact muB draw moves the first output's muB (iMuB), its quadratic.
void OutputsPosterior::muBQuadratic(double& aa, double& ab) const {
  sub_[0]->muBQuadratic(aa, ab);
}

// Each new point is predicted by its output's block (its output read off
// its indicator columns; a field point's noise group must be its output's).
void OutputsPosterior::condition(const arma::mat& Xnew, int type, double* mean, double* var,
                                 const int* noise, const int* source) {
  for (int o = 0; o < K_; ++o) {
    const arma::uvec r = output_rows(Xnew, out_, o);
    if (r.is_empty()) continue;
    const arma::mat Xo = Xnew.rows(r);
    std::vector<int> no(r.size()), so(r.size());
    for (size_t i = 0; i < r.size(); ++i) {
      if (noise && type == PT_FIELD) {
        const int g = noise[r[i]];
        if (g < 0 || g >= (int) groupLocal_[o].size() || groupLocal_[o][g] < 0)
          Rcpp::stop("noise group %d of a new point is not one of output %d's", g + 1, o + 1);
        no[i] = groupLocal_[o][g];
      }
      if (source) so[i] = source[r[i]];
    }
    arma::vec mo(r.size()), vo(r.size());
    sub_[o]->condition(Xo, type, mo.memptr(), vo.memptr(), noise ? no.data() : nullptr,
                       source ? so.data() : nullptr);
    for (size_t i = 0; i < r.size(); ++i) { mean[r[i]] = mo[i]; var[r[i]] = vo[i]; }
  }
}

// A fold's runs of different outputs are independent: each output's part
// of each fold is held out in its own block.
bool OutputsPosterior::heldout(const std::vector<std::vector<int> >& folds, arma::vec& mean,
                               arma::vec& var) {
  mean.set_size(m);
  var.set_size(m);
  for (int o = 0; o < K_; ++o) {
    std::vector<std::vector<int> > lf;
    for (const std::vector<int>& B : folds) {
      std::vector<int> b;
      for (int r : B)
        if (outS_[r] == o) b.push_back(localS_[r]);
      if (!b.empty()) lf.push_back(b);
    }
    arma::vec mo, vo;
    if (!sub_[o]->heldout(lf, mo, vo)) return false;
    for (size_t k = 0; k < rowsS_[o].size(); ++k) { mean[rowsS_[o][k]] = mo[k]; var[rowsS_[o][k]] = vo[k]; }
  }
  return true;
}

// log p(y_G | the rest) = sum over outputs of their rows' part (independent).
void OutputsPosterior::fieldLoo(const std::vector<std::vector<int> >& groups,
                                arma::vec& logdens) const {
  logdens.zeros(groups.size());
  for (int o = 0; o < K_; ++o) {
    std::vector<std::vector<int> > lg;
    std::vector<int> which;
    for (size_t g = 0; g < groups.size(); ++g) {
      std::vector<int> b;
      for (int i : groups[g])
        if (outF_[i] == o) b.push_back(localF_[i]);
      if (!b.empty()) { lg.push_back(b); which.push_back(g); }
    }
    if (lg.empty()) continue;
    arma::vec lo;
    sub_[o]->fieldLoo(lg, lo);
    for (size_t k = 0; k < which.size(); ++k) logdens[which[k]] += lo[k];
  }
}

std::string OutputsPosterior::algebra() const {
  std::string s = "independent outputs:";
  for (int o = 0; o < K_; ++o) s += (o ? ", " : " ") + sub_[o]->algebra();
  return s;
}

// Each output's block answers for its candidates and targets; A's rows are
// the blocks' rows one after the other (a candidate's column zero outside its
// output's), CTU zero between outputs.
void OutputsPosterior::runConditional(const arma::mat& U, const arma::mat& XT,
                                      RunConditional& out) {
  std::vector<RunConditional> rc(K_);
  std::vector<arma::uvec> uo(K_), to(K_);
  int N = 0;
  for (int o = 0; o < K_; ++o) {
    uo[o] = output_rows(U, out_, o); to[o] = output_rows(XT, out_, o);
    sub_[o]->runConditional(U.rows(uo[o]), XT.rows(to[o]), rc[o]);
    N += rc[o].A.n_rows;
  }
  out.A.zeros(N, U.n_rows);
  out.mu.set_size(U.n_rows); out.v.set_size(U.n_rows); out.v0.set_size(U.n_rows);
  out.mT.set_size(XT.n_rows); out.VT.set_size(XT.n_rows);
  out.CTU.zeros(XT.n_rows, U.n_rows);
  int at = 0;
  for (int o = 0; o < K_; ++o) {
    const RunConditional& r = rc[o];
    if (uo[o].n_elem) {
      out.A.submat(arma::regspace<arma::uvec>(at, at + r.A.n_rows - 1), uo[o]) = r.A;
      out.mu.elem(uo[o]) = r.mu; out.v.elem(uo[o]) = r.v; out.v0.elem(uo[o]) = r.v0;
    }
    if (to[o].n_elem) {
      out.mT.elem(to[o]) = r.mT; out.VT.elem(to[o]) = r.VT;
      if (uo[o].n_elem) out.CTU.submat(to[o], uo[o]) = r.CTU;
    }
    at += r.A.n_rows;
  }
}

// Output o's prior between rows of output o, 0 between outputs.
void OutputsPosterior::runPrior(const arma::vec& ph, const arma::mat& X, const arma::mat& Y,
                                arma::mat& K) const {
  K.zeros(X.n_rows, Y.n_rows);
  arma::mat Ko;
  for (int o = 0; o < K_; ++o) {
    const arma::uvec ra = output_rows(X, out_, o), rb = output_rows(Y, out_, o);
    if (ra.is_empty() || rb.is_empty()) continue;
    sub_[o]->runPrior(local_phi(ph, map_[o]), X.rows(ra), Y.rows(rb), Ko);
    K.submat(ra, rb) = Ko;
  }
}
