#include "detector/granger.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Dense>
#include <SuiteSparseQR_C.h>

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
  const double lbt = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) +
                     b * std::log1p(-x);
  const double bt = std::exp(lbt);
  if (x < (a + 1.0) / (a + b + 2.0)) return bt * BetaContinuedFraction(a, b, x) / a;
  return 1.0 - bt * BetaContinuedFraction(b, a, 1.0 - x) / b;
}

// one target's regression problem
struct Block {
  std::string target;
  std::vector<std::string> names;  // modelled target features
  Eigen::MatrixXd restricted, unrestricted;  // n x p_r, n x p_u
  Eigen::MatrixXd y;                          // n x d
};

}  // namespace

double FDistributionUpperTail(double f, double d1, double d2) {
  if (!(f > 0.0)) return 1.0;
  if (std::isinf(f)) return 0.0;
  return IncompleteBeta(0.5 * d2, 0.5 * d1, d2 / (d2 + d1 * f));
}

Result<std::vector<GrangerResult>> LinearGrangerTest(const envs::EnvSpec& spec,
                                                     const TransitionSet& data,
                                                     const std::string& source,
                                                     const std::vector<std::string>& targets,
                                                     const GrangerOptions& options) {
  COINS_RETURN_IF_ERROR(options.Validate());
  const int w = options.window;
  const int64_t n_all = data.size();
  const bool src_action = source == "Action";
  int src_factor = -1, src_off = 0, src_feat = 0;
  if (!src_action) {
    src_factor = spec.factor_index(source);
    if (src_factor < 0) return Errorf("unknown source factor '{}' in env '{}'", source, spec.name);
    if (spec.factors[src_factor].instances > 1 || spec.factors[src_factor].multi_instance) {
      return Errorf("source '{}' is a multi-instance class", source);
    }
    src_off = spec.factor_offset(src_factor);
    src_feat = spec.factors[src_factor].features;
  }
  const envs::ActionSpec& as = spec.action;
  const int src_dim = src_action ? (as.discrete ? as.n : as.dim) : src_feat;

  // episode start of every transition, for history windows
  std::vector<int64_t> ep_start(n_all);
  for (int64_t t = 0; t < n_all; ++t) {
    ep_start[t] = (t == 0 || data.episode_start(t)) ? t : ep_start[t - 1];
  }
  // the normalised source vector of transition t
  auto source_vec = [&](int64_t t, double* out) {
    if (src_action) {
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
    const auto& f = spec.factors[src_factor];
    const auto s = data.state(t);
    for (int i = 0; i < src_feat; ++i) {
      out[i] = (s[src_off + i] - 0.5 * (f.high[i] + f.low[i])) / (0.5 * (f.high[i] - f.low[i]));
    }
  };

  // build each target's design matrices
  std::vector<Block> blocks;
  std::mt19937_64 rng(options.seed);
  for (const std::string& target : targets) {
    const int tf_i = spec.factor_index(target);
    if (tf_i < 0) return Errorf("unknown target factor '{}' in env '{}'", target, spec.name);
    if (target == source) return Errorf("source and target are both '{}'", source);
    const envs::FactorSpec& tf = spec.factors[tf_i];
    const int off = spec.factor_offset(tf_i), nf = tf.features;

    // samples (t, instance) with a full window
    std::vector<std::pair<int64_t, int>> samples;
    std::vector<int> unchanged;
    for (int64_t t = 0; t < n_all; ++t) {
      if (t - (w - 1) < ep_start[t]) continue;
      const auto s = data.state(t), s2 = data.next_state(t);
      unchanged.clear();
      for (int i = 0; i < tf.instances; ++i) {
        bool changed = tf.instances == 1;
        for (int k = 0; k < nf && !changed; ++k) changed = s[off + i * nf + k] != s2[off + i * nf + k];
        if (changed) samples.push_back({t, i});
        else unchanged.push_back(i);
      }
      for (int j = 0; j < options.static_instances_per_step && !unchanged.empty(); ++j) {
        const size_t p = std::uniform_int_distribution<size_t>(0, unchanged.size() - 1)(rng);
        samples.push_back({t, unchanged[p]});
        unchanged[p] = unchanged.back();
        unchanged.pop_back();
      }
    }
    const int64_t n = int64_t(samples.size());
    Block b;
    b.target = target;
    auto norm = [&](float v, int k) {
      return (v - 0.5 * (tf.high[k] + tf.low[k])) / (0.5 * (tf.high[k] - tf.low[k]));
    };
    // modelled outputs (features that change) and varying input features
    std::vector<int> outs, ins;
    for (int k = 0; k < nf; ++k) {
      bool changes = false, varies = false;
      float first = n ? data.state(samples[0].first)[off + samples[0].second * nf + k] : 0.0f;
      for (const auto& [t, i] : samples) {
        const float v = data.state(t)[off + i * nf + k], v2 = data.next_state(t)[off + i * nf + k];
        changes |= v != v2;
        varies |= v != first;
        if (changes && varies) break;
      }
      if (changes) {
        outs.push_back(k);
        b.names.push_back(tf.feature_names[k]);
      }
      if (varies) ins.push_back(k);
    }
    if (n == 0 || outs.empty()) {
      blocks.push_back(std::move(b));
      continue;
    }
    // source columns that vary
    std::vector<double> sv(src_dim);
    std::vector<uint8_t> src_varies(src_dim, 0);
    std::vector<double> src_first(src_dim);
    source_vec(samples[0].first, src_first.data());
    for (const auto& [t, i] : samples) {
      source_vec(t, sv.data());
      for (int c = 0; c < src_dim; ++c) src_varies[c] |= sv[c] != src_first[c];
    }
    std::vector<int> src_cols;
    for (int c = 0; c < src_dim; ++c) {
      if (src_varies[c]) src_cols.push_back(c);
    }
    const int pr = 1 + w * int(ins.size());
    const int pu = pr + w * int(src_cols.size());
    b.restricted.resize(n, pr);
    b.unrestricted.resize(n, pu);
    b.y.resize(n, outs.size());
    for (int64_t r = 0; r < n; ++r) {
      const auto [t, inst] = samples[r];
      int c = 0;
      b.unrestricted(r, c++) = 1.0;
      for (int lag = 0; lag < w; ++lag) {
        const auto s = data.state(t - lag);
        for (int k : ins) b.unrestricted(r, c++) = norm(s[off + inst * nf + k], k);
      }
      for (int lag = 0; lag < w; ++lag) {
        source_vec(t - lag, sv.data());
        for (int sc : src_cols) b.unrestricted(r, c++) = sv[sc];
      }
      const auto s2 = data.next_state(t);
      for (size_t q = 0; q < outs.size(); ++q) b.y(r, q) = norm(s2[off + inst * nf + outs[q]], outs[q]);
    }
    b.restricted = b.unrestricted.leftCols(pr);
    blocks.push_back(std::move(b));
  }

  // one block-diagonal sparse least-squares problem for every regression
  int64_t rows = 0, cols = 0, nnz = 0;
  int kmax = 0;
  for (const Block& b : blocks) {
    if (b.y.size() == 0) continue;
    rows += 2 * b.y.rows();
    cols += b.restricted.cols() + b.unrestricted.cols();
    nnz += (b.restricted.array() != 0.0).count() + (b.unrestricted.array() != 0.0).count();
    kmax = std::max(kmax, int(b.y.cols()));
  }
  std::vector<Eigen::MatrixXd> betas_r(blocks.size()), betas_u(blocks.size());
  if (rows > 0) {
    cholmod_common cc;
    cholmod_l_start(&cc);
    cholmod_triplet* tri = cholmod_l_allocate_triplet(rows, cols, nnz, 0, CHOLMOD_REAL, &cc);
    cholmod_dense* rhs = cholmod_l_zeros(rows, kmax, CHOLMOD_REAL, &cc);
    if (tri == nullptr || rhs == nullptr) {
      cholmod_l_free_triplet(&tri, &cc);
      cholmod_l_free_dense(&rhs, &cc);
      cholmod_l_finish(&cc);
      return Errorf("granger: cholmod could not allocate a {} x {} problem", rows, cols);
    }
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
    cholmod_sparse* a = cholmod_l_triplet_to_sparse(tri, e, &cc);
    cholmod_dense* x = a ? SuiteSparseQR_C_backslash_default(a, rhs, &cc) : nullptr;
    if (x != nullptr) {
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
        take(b.restricted.cols(), &betas_r[bi]);
        take(b.unrestricted.cols(), &betas_u[bi]);
      }
    }
    const bool failed = x == nullptr;
    cholmod_l_free_dense(&x, &cc);
    cholmod_l_free_sparse(&a, &cc);
    cholmod_l_free_triplet(&tri, &cc);
    cholmod_l_free_dense(&rhs, &cc);
    cholmod_l_finish(&cc);
    if (failed) return Errorf("granger: SuiteSparseQR failed on a {} x {} problem", rows, cols);
  }

  // F-tests from the residual sums of squares
  std::vector<GrangerResult> results;
  for (size_t bi = 0; bi < blocks.size(); ++bi) {
    const Block& b = blocks[bi];
    GrangerResult g;
    g.source = source;
    g.target = b.target;
    g.feature_names = b.names;
    g.samples = b.y.rows();
    if (b.y.size() == 0) {
      results.push_back(g);
      continue;
    }
    const int64_t n = b.y.rows();
    const int pr = int(b.restricted.cols()), pu = int(b.unrestricted.cols());
    g.df1 = pu - pr;
    g.df2 = int(n - pu);
    const Eigen::MatrixXd er = b.y - b.restricted * betas_r[bi];
    const Eigen::MatrixXd eu = b.y - b.unrestricted * betas_u[bi];
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
    g.causes = g.p_value < options.alpha;
    results.push_back(g);
  }
  return results;
}

}  // namespace coins::detector
