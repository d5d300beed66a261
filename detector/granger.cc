#include "detector/granger.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <span>

#include <SuiteSparseQR_C.h>
#include <Eigen/Dense>

namespace coins::detector {

Status GrangerOptions::Validate() const {
  if (window < 1) return Errorf("granger window must be >= 1, got {}", window);
  if (!(alpha > 0.0 && alpha < 1.0)) return Errorf("granger alpha must be in (0, 1), got {}", alpha);
  if (static_instances_per_step < 0) {
    return Errorf("static_instances_per_step must be >= 0, got {}", static_instances_per_step);
  }
  return Status::Ok();
}

namespace {

// continued fraction of the regularised incomplete beta function (modified Lentz)
double BetaContinuedFraction(double a, double b, double x) {
  constexpr double kTiny = 1e-300;
  const double qab = a + b, qap = a + 1.0, qam = a - 1.0;
  double c = 1.0, d = 1.0 - qab * x / qap;
  if (std::abs(d) < kTiny) d = kTiny;
  d = 1.0 / d;
  double h = d;
  for (int m = 1; m <= 500; ++m) {
    const double m2 = 2.0 * m;
    double aa = m * (b - m) * x / ((qam + m2) * (a + m2));
    d = 1.0 + aa * d;
    if (std::abs(d) < kTiny) d = kTiny;
    c = 1.0 + aa / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    h *= d * c;
    aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
    d = 1.0 + aa * d;
    if (std::abs(d) < kTiny) d = kTiny;
    c = 1.0 + aa / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1.0) < 1e-14) break;
  }
  return h;
}

// regularised incomplete beta I_x(a, b)
double IncompleteBeta(double a, double b, double x) {
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return 1.0;
  const double lbt = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x);
  const double bt = std::exp(lbt);
  if (x < (a + 1.0) / (a + b + 2.0)) return bt * BetaContinuedFraction(a, b, x) / a;
  return 1.0 - bt * BetaContinuedFraction(b, a, 1.0 - x) / b;
}

// one target's regression problem
struct Block {
  std::string target;
  std::vector<std::string> names;            // modelled target features
  Eigen::MatrixXd restricted, unrestricted;  // n x p_r, n x p_u
  Eigen::MatrixXd y;                         // n x d
};

// the normalised source vector of a transition: the source factor's features scaled to [-1, 1]
// by their bounds, or the action (one-hot when discrete)
class SourceColumns {
 public:
  static Result<SourceColumns> Of(const envs::EnvSpec& spec, const std::string& source) {
    SourceColumns s;
    s.action_ = &spec.action;
    if (source == "Action") {
      s.dim_ = spec.action.discrete ? spec.action.n : spec.action.dim;
      return s;
    }
    const int f = spec.factor_index(source);
    if (f < 0) return Errorf("unknown source factor '{}' in env '{}'", source, spec.name);
    if (spec.factors[f].instances > 1 || spec.factors[f].multi_instance) {
      return Errorf("source '{}' is a multi-instance class", source);
    }
    s.factor_ = &spec.factors[f];
    s.offset_ = spec.factor_offset(f);
    s.dim_ = spec.factors[f].features;
    return s;
  }
  int dim() const { return dim_; }

  // writes dim() values for transition t
  void Fill(const TransitionSet& data, int64_t t, double* out) const {
    if (factor_ == nullptr) {
      const envs::ActionSpec& as = *action_;
      const auto a = data.action(t);
      if (as.discrete) {
        for (int i = 0; i < as.n; ++i) out[i] = 0.0;
        out[std::clamp(int(std::lround(a[0])), 0, as.n - 1)] = 1.0;
      } else {
        for (int i = 0; i < as.dim; ++i) {
          out[i] = (a[i] - 0.5 * (as.high[i] + as.low[i])) / (0.5 * (as.high[i] - as.low[i]));
        }
      }
      return;
    }
    const envs::FactorSpec& f = *factor_;
    const auto s = data.state(t);
    for (int i = 0; i < dim_; ++i) {
      out[i] = (s[offset_ + i] - 0.5 * (f.high[i] + f.low[i])) / (0.5 * (f.high[i] - f.low[i]));
    }
  }

 private:
  const envs::ActionSpec* action_ = nullptr;
  const envs::FactorSpec* factor_ = nullptr;  // null: the source is the action
  int offset_ = 0, dim_ = 0;
};

// the episode start of every transition, for history windows
std::vector<int64_t> EpisodeStarts(const TransitionSet& data) {
  const int64_t n = data.size();
  std::vector<int64_t> ep_start(n);
  for (int64_t t = 0; t < n; ++t) ep_start[t] = (t == 0 || data.episode_start(t)) ? t : ep_start[t - 1];
  return ep_start;
}

// the target factor's place in the state
struct TargetFactor {
  const envs::FactorSpec* spec;
  int off, nf;  // offset of instance 0, features per instance
  float Feature(std::span<const float> s, int inst, int k) const { return s[off + inst * nf + k]; }
  double Norm(float v, int k) const {
    return (v - 0.5 * (spec->high[k] + spec->low[k])) / (0.5 * (spec->high[k] - spec->low[k]));
  }
};

// samples (t, instance) with a full window: the changed instances of each transition plus up to
// static_instances_per_step unchanged ones
std::vector<std::pair<int64_t, int>> SampleInstances(const TransitionSet& data, const TargetFactor& tf,
                                                     const std::vector<int64_t>& ep_start,
                                                     const GrangerOptions& options, std::mt19937_64& rng) {
  std::vector<std::pair<int64_t, int>> samples;
  std::vector<int> unchanged;
  const int instances = tf.spec->instances;
  for (int64_t t = 0; t < data.size(); ++t) {
    if (t - (options.window - 1) < ep_start[t]) continue;
    const auto s = data.state(t), s2 = data.next_state(t);
    unchanged.clear();
    for (int i = 0; i < instances; ++i) {
      bool changed = instances == 1;
      for (int k = 0; k < tf.nf && !changed; ++k) changed = tf.Feature(s, i, k) != tf.Feature(s2, i, k);
      if (changed)
        samples.push_back({t, i});
      else
        unchanged.push_back(i);
    }
    for (int j = 0; j < options.static_instances_per_step && !unchanged.empty(); ++j) {
      const size_t p = std::uniform_int_distribution<size_t>(0, unchanged.size() - 1)(rng);
      samples.push_back({t, unchanged[p]});
      unchanged[p] = unchanged.back();
      unchanged.pop_back();
    }
  }
  return samples;
}

// the source columns that vary over the samples
std::vector<int> VaryingSourceColumns(const TransitionSet& data, const SourceColumns& source,
                                      const std::vector<std::pair<int64_t, int>>& samples) {
  std::vector<double> sv(source.dim()), first(source.dim());
  std::vector<uint8_t> varies(source.dim(), 0);
  source.Fill(data, samples[0].first, first.data());
  for (const auto& [t, i] : samples) {
    source.Fill(data, t, sv.data());
    for (int c = 0; c < source.dim(); ++c) varies[c] |= sv[c] != first[c];
  }
  std::vector<int> cols;
  for (int c = 0; c < source.dim(); ++c) {
    if (varies[c]) cols.push_back(c);
  }
  return cols;
}

// one target's regression problem: its modelled features (those that change) as outputs, its
// varying features over the window (restricted) and then the source's (unrestricted) as inputs
Result<Block> BuildBlock(const envs::EnvSpec& spec, const TransitionSet& data, const std::string& source,
                         const SourceColumns& src, const std::string& target, const std::vector<int64_t>& ep_start,
                         const GrangerOptions& options, std::mt19937_64& rng) {
  const int tf_i = spec.factor_index(target);
  if (tf_i < 0) return Errorf("unknown target factor '{}' in env '{}'", target, spec.name);
  if (target == source) return Errorf("source and target are both '{}'", source);
  const TargetFactor tf{&spec.factors[tf_i], spec.factor_offset(tf_i), spec.factors[tf_i].features};
  const auto samples = SampleInstances(data, tf, ep_start, options, rng);
  const int64_t n = int64_t(samples.size());
  Block b;
  b.target = target;
  // modelled outputs (features that change) and varying input features
  std::vector<int> outs, ins;
  for (int k = 0; k < tf.nf; ++k) {
    bool changes = false, varies = false;
    float first = n ? tf.Feature(data.state(samples[0].first), samples[0].second, k) : 0.0f;
    for (const auto& [t, i] : samples) {
      const float v = tf.Feature(data.state(t), i, k), v2 = tf.Feature(data.next_state(t), i, k);
      changes |= v != v2;
      varies |= v != first;
      if (changes && varies) break;
    }
    if (changes) {
      outs.push_back(k);
      b.names.push_back(tf.spec->feature_names[k]);
    }
    if (varies) ins.push_back(k);
  }
  if (n == 0 || outs.empty()) return b;
  const std::vector<int> src_cols = VaryingSourceColumns(data, src, samples);
  const int w = options.window;
  const int pr = 1 + w * int(ins.size());
  const int pu = pr + w * int(src_cols.size());
  b.unrestricted.resize(n, pu);
  b.y.resize(n, outs.size());
  std::vector<double> sv(src.dim());
  for (int64_t r = 0; r < n; ++r) {
    const auto [t, inst] = samples[r];
    int c = 0;
    b.unrestricted(r, c++) = 1.0;
    for (int lag = 0; lag < w; ++lag) {
      const auto s = data.state(t - lag);
      for (int k : ins) b.unrestricted(r, c++) = tf.Norm(tf.Feature(s, inst, k), k);
    }
    for (int lag = 0; lag < w; ++lag) {
      src.Fill(data, t - lag, sv.data());
      for (int sc : src_cols) b.unrestricted(r, c++) = sv[sc];
    }
    const auto s2 = data.next_state(t);
    for (size_t q = 0; q < outs.size(); ++q) b.y(r, q) = tf.Norm(tf.Feature(s2, inst, outs[q]), outs[q]);
  }
  b.restricted = b.unrestricted.leftCols(pr);
  return b;
}

// owns a CHOLMOD workspace and frees what it allocated: objects are held by CholmodPtr, which
// are destroyed before the workspace when declared after it
class CholmodWorkspace {
 public:
  CholmodWorkspace() { cholmod_l_start(&cc_); }
  ~CholmodWorkspace() { cholmod_l_finish(&cc_); }
  CholmodWorkspace(const CholmodWorkspace&) = delete;
  CholmodWorkspace& operator=(const CholmodWorkspace&) = delete;
  cholmod_common* get() { return &cc_; }

 private:
  cholmod_common cc_;
};
struct CholmodFree {
  cholmod_common* cc;
  void operator()(cholmod_triplet* p) const { cholmod_l_free_triplet(&p, cc); }
  void operator()(cholmod_sparse* p) const { cholmod_l_free_sparse(&p, cc); }
  void operator()(cholmod_dense* p) const { cholmod_l_free_dense(&p, cc); }
};
template <typename T>
using CholmodPtr = std::unique_ptr<T, CholmodFree>;

// the coefficients of every block's restricted and unrestricted regression
struct Betas {
  std::vector<Eigen::MatrixXd> restricted, unrestricted;
};

// solves every regression at once as one block-diagonal sparse least-squares problem
Status SolveBlocks(const std::vector<Block>& blocks, Betas* betas) {
  betas->restricted.assign(blocks.size(), {});
  betas->unrestricted.assign(blocks.size(), {});
  int64_t rows = 0, cols = 0, nnz = 0;
  int kmax = 0;
  for (const Block& b : blocks) {
    if (b.y.size() == 0) continue;
    rows += 2 * b.y.rows();
    cols += b.restricted.cols() + b.unrestricted.cols();
    nnz += (b.restricted.array() != 0.0).count() + (b.unrestricted.array() != 0.0).count();
    kmax = std::max(kmax, int(b.y.cols()));
  }
  if (rows == 0) return Status::Ok();
  CholmodWorkspace ws;
  cholmod_common* cc = ws.get();
  CholmodPtr<cholmod_triplet> tri(cholmod_l_allocate_triplet(rows, cols, nnz, 0, CHOLMOD_REAL, cc), {cc});
  CholmodPtr<cholmod_dense> rhs(cholmod_l_zeros(rows, kmax, CHOLMOD_REAL, cc), {cc});
  if (tri == nullptr || rhs == nullptr)
    return Errorf("granger: cholmod could not allocate a {} x {} problem", rows, cols);
  auto* ti = static_cast<SuiteSparse_long*>(tri->i);
  auto* tj = static_cast<SuiteSparse_long*>(tri->j);
  auto* tx = static_cast<double*>(tri->x);
  auto* bx = static_cast<double*>(rhs->x);
  int64_t r0 = 0, c0 = 0, e = 0;
  auto put = [&](const Eigen::MatrixXd& m, const Eigen::MatrixXd& y) {
    for (int64_t c = 0; c < m.cols(); ++c) {
      for (int64_t r = 0; r < m.rows(); ++r) {
        if (m(r, c) == 0.0) continue;
        ti[e] = r0 + r;
        tj[e] = c0 + c;
        tx[e] = m(r, c);
        ++e;
      }
    }
    for (int64_t q = 0; q < y.cols(); ++q) {
      for (int64_t r = 0; r < y.rows(); ++r) bx[q * rows + r0 + r] = y(r, q);
    }
    r0 += m.rows();
    c0 += m.cols();
  };
  for (const Block& b : blocks) {
    if (b.y.size() == 0) continue;
    put(b.restricted, b.y);
    put(b.unrestricted, b.y);
  }
  tri->nnz = e;
  CholmodPtr<cholmod_sparse> a(cholmod_l_triplet_to_sparse(tri.get(), e, cc), {cc});
  CholmodPtr<cholmod_dense> x(a ? SuiteSparseQR_C_backslash_default(a.get(), rhs.get(), cc) : nullptr, {cc});
  if (x == nullptr) return Errorf("granger: SuiteSparseQR failed on a {} x {} problem", rows, cols);
  const auto* xx = static_cast<const double*>(x->x);
  int64_t c = 0;
  for (size_t bi = 0; bi < blocks.size(); ++bi) {
    const Block& b = blocks[bi];
    if (b.y.size() == 0) continue;
    auto take = [&](int64_t p, Eigen::MatrixXd* beta) {
      beta->resize(p, b.y.cols());
      for (int64_t q = 0; q < b.y.cols(); ++q) {
        for (int64_t r = 0; r < p; ++r) (*beta)(r, q) = xx[q * cols + c + r];
      }
      c += p;
    };
    take(b.restricted.cols(), &betas->restricted[bi]);
    take(b.unrestricted.cols(), &betas->unrestricted[bi]);
  }
  return Status::Ok();
}

// the block's F-tests from the residual sums of squares
GrangerResult FTest(const std::string& source, const Block& b, const Eigen::MatrixXd& beta_r,
                    const Eigen::MatrixXd& beta_u, double alpha) {
  GrangerResult g;
  g.source = source;
  g.target = b.target;
  g.feature_names = b.names;
  g.samples = b.y.rows();
  if (b.y.size() == 0) return g;
  const int64_t n = b.y.rows();
  const int pr = int(b.restricted.cols()), pu = int(b.unrestricted.cols());
  g.df1 = pu - pr;
  g.df2 = int(n - pu);
  const Eigen::MatrixXd er = b.y - b.restricted * beta_r;
  const Eigen::MatrixXd eu = b.y - b.unrestricted * beta_u;
  double best_p = 1.0;
  for (int64_t q = 0; q < b.y.cols(); ++q) {
    const double rss_r = er.col(q).squaredNorm(), rss_u = eu.col(q).squaredNorm();
    double f = 0.0;
    if (g.df1 > 0 && g.df2 > 0) {
      const double denom = std::max(rss_u, 1e-300) / g.df2;
      f = std::max(0.0, rss_r - rss_u) / g.df1 / denom;
      // differences at rounding level are no evidence
      if (rss_r - rss_u <= 1e-9 * std::max(rss_r, 1e-12)) f = 0.0;
    }
    g.feature_f.push_back(f);
    const double p = g.df1 > 0 && g.df2 > 0 ? FDistributionUpperTail(f, g.df1, g.df2) : 1.0;
    if (f > g.f_stat || g.feature.empty()) {
      if (f >= g.f_stat) {
        g.f_stat = f;
        g.feature = b.names[q];
      }
    }
    best_p = std::min(best_p, p);
  }
  g.p_value = std::min(1.0, best_p * double(b.y.cols()));
  g.causes = g.p_value < alpha;
  return g;
}

}  // namespace

double FDistributionUpperTail(double f, double d1, double d2) {
  if (!(f > 0.0)) return 1.0;
  if (std::isinf(f)) return 0.0;
  return IncompleteBeta(0.5 * d2, 0.5 * d1, d2 / (d2 + d1 * f));
}

Result<std::vector<GrangerResult>> LinearGrangerTest(const envs::EnvSpec& spec, const TransitionSet& data,
                                                     const std::string& source, const std::vector<std::string>& targets,
                                                     const GrangerOptions& options) {
  COINS_RETURN_IF_ERROR(options.Validate());
  Result<SourceColumns> src = SourceColumns::Of(spec, source);
  if (!src.ok()) return src.status();
  const std::vector<int64_t> ep_start = EpisodeStarts(data);
  std::vector<Block> blocks;
  std::mt19937_64 rng(options.seed);
  for (const std::string& target : targets) {
    Result<Block> b = BuildBlock(spec, data, source, *src, target, ep_start, options, rng);
    if (!b.ok()) return b.status();
    blocks.push_back(std::move(*b));
  }
  Betas betas;
  COINS_RETURN_IF_ERROR(SolveBlocks(blocks, &betas));
  std::vector<GrangerResult> results;
  for (size_t bi = 0; bi < blocks.size(); ++bi) {
    results.push_back(FTest(source, blocks[bi], betas.restricted[bi], betas.unrestricted[bi], options.alpha));
  }
  return results;
}

}  // namespace coins::detector
