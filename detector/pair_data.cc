#include "detector/pair_data.h"

#include <algorithm>
#include <cmath>
#include <random>

namespace coins::detector {

float PairLayout::mask_unit(int k) const {
  auto half = [&](size_t i) { return 0.5f * (target_high[i] - target_low[i]); };
  auto is_position = [&](size_t i) {
    return i < target_feature_names.size() &&
           (target_feature_names[i] == "x" || target_feature_names[i] == "y" || target_feature_names[i] == "z");
  };
  if (!is_position(size_t(k))) return half(size_t(k));
  float unit = 0.0f;
  for (size_t i = 0; i < target_high.size(); ++i)
    if (is_position(i)) unit = std::max(unit, half(i));
  return unit;
}

int PairLayout::source_input_dim() const {
  if (source_is_action) return action_input_dim();
  return source_features + (source_action ? action_input_dim() : 0);
}

Result<PairLayout> FitPairLayout(const envs::EnvSpec& spec, const TransitionSet& data, const std::string& source,
                                 const std::string& target, const DetectorOptions& options) {
  if (data.size() == 0) return Errorf("no transitions to fit the {}->{} pair on", source, target);
  if (data.state_dim() != spec.state_dim()) {
    return Errorf("transitions have state_dim {}, env '{}' has {}", data.state_dim(), spec.name, spec.state_dim());
  }
  if (source == target) return Errorf("source and target are both '{}'", source);
  PairLayout L;
  L.source = source;
  L.target = target;
  L.action = spec.action;
  L.close_distance = options.close_distance < 0 ? EnvCloseDistance(spec.name) : options.close_distance;
  L.source_is_action = source == "Action";

  // target factor
  L.target_factor = spec.factor_index(target);
  if (L.target_factor < 0) return Errorf("unknown target factor '{}' in env '{}'", target, spec.name);
  const envs::FactorSpec& tf = spec.factors[L.target_factor];
  L.target_offset = spec.factor_offset(L.target_factor);
  L.target_features = tf.features;
  L.instances = tf.instances;
  L.multi_instance = tf.multi_instance || tf.instances > 1;
  L.target_low = tf.low;
  L.target_high = tf.high;
  L.target_feature_names = tf.feature_names;

  // source factor (or the primitive action)
  if (!L.source_is_action) {
    L.source_factor = spec.factor_index(source);
    if (L.source_factor < 0) return Errorf("unknown source factor '{}' in env '{}'", source, spec.name);
    const envs::FactorSpec& sf = spec.factors[L.source_factor];
    if (sf.multi_instance || sf.instances > 1) {
      return Errorf("source '{}' is a multi-instance class; sources must be single factors", source);
    }
    L.source_offset = spec.factor_offset(L.source_factor);
    L.source_features = sf.features;
    L.source_low = sf.low;
    L.source_high = sf.high;
    L.source_action = options.source_action;
    // positions shared by name
    for (int i = 0; i < sf.features; ++i) {
      const std::string& n = sf.feature_names[i];
      if (n != "x" && n != "y" && n != "z") continue;
      for (int j = 0; j < tf.features; ++j) {
        if (tf.feature_names[j] == n) L.positions.push_back({i, j});
      }
    }
  }

  // modelled features and their change scales
  const int64_t n = data.size();
  std::vector<float> mags;
  for (int k = 0; k < tf.features; ++k) {
    const float tiny = 1e-6f * (tf.high[k] - tf.low[k]);
    mags.clear();
    for (int64_t t = 0; t < n; ++t) {
      const auto s = data.state(t), s2 = data.next_state(t);
      for (int i = 0; i < L.instances; ++i) {
        const int idx = L.target_offset + i * tf.features + k;
        const float d = std::abs(s2[idx] - s[idx]);
        if (d > tiny) mags.push_back(d);
      }
    }
    if (mags.empty()) continue;
    const size_t q = std::min(mags.size() - 1, size_t(options.delta_quantile * float(mags.size())));
    std::nth_element(mags.begin(), mags.begin() + q, mags.end());
    L.dims.push_back(k);
    L.scale.push_back(1.5f * mags[q]);
  }
  return L;
}

namespace {

// writes the source block of the active input into col: the source factor (or nothing for the
// action source) normalised, then the action (one-hot when discrete)
void WriteSource(const PairLayout& L, std::span<const float> s, std::span<const float> a, float* col) {
  int r = 0;
  if (!L.source_is_action) {
    for (int i = 0; i < L.source_features; ++i) {
      const float lo = L.source_low[i], hi = L.source_high[i];
      col[r++] = (s[L.source_offset + i] - 0.5f * (hi + lo)) / (0.5f * (hi - lo));
    }
    if (!L.source_action) return;
  }
  if (L.action.discrete) {
    for (int i = 0; i < L.action.n; ++i) col[r + i] = 0.0f;
    const int ai = std::clamp(int(std::lround(a[0])), 0, L.action.n - 1);
    col[r + ai] = 1.0f;
  } else {
    for (int i = 0; i < L.action.dim; ++i) {
      const float lo = L.action.low[i], hi = L.action.high[i];
      col[r + i] = (a[i] - 0.5f * (hi + lo)) / (0.5f * (hi - lo));
    }
  }
}

}  // namespace

bool EncodeSample(const PairLayout& L, const PairTransition& src, const PairTransition& tgt, int instance,
                  float* passive, float* active, float* target) {
  const int tfeat = L.target_features, sdim = L.source_input_dim();
  const int base = L.target_offset + instance * tfeat;
  WriteSource(L, src.state, src.action, active);
  for (int k = 0; k < tfeat; ++k) {
    const float lo = L.target_low[k], hi = L.target_high[k];
    const float v = (tgt.state[base + k] - 0.5f * (hi + lo)) / (0.5f * (hi - lo));
    passive[k] = v;
    active[sdim + k] = v;
  }
  float dist = 0.0f, dist_next = 0.0f;
  const int np = int(L.positions.size());
  for (int p = 0; p < np; ++p) {
    const auto [ia, ib] = L.positions[p];
    const float diff = src.state[L.source_offset + ia] - tgt.state[base + ib];
    active[sdim + tfeat + p] = diff / L.relative_scale(p);
    active[sdim + tfeat + np + p] = (src.next_state[L.source_offset + ia] - tgt.state[base + ib]) / L.relative_scale(p);
    dist += std::abs(diff);
    dist_next += std::abs(src.next_state[L.source_offset + ia] - tgt.next_state[base + ib]);
  }
  for (int d = 0; d < L.output_dim(); ++d) {
    const int k = L.dims[d];
    target[d] = std::clamp((tgt.next_state[base + k] - tgt.state[base + k]) / L.scale[d], -1.0f, 1.0f);
  }
  // close: near before and after the transition (always, for a pair without proximity)
  return !L.has_proximity() || (dist <= L.close_distance && dist_next <= L.close_distance);
}

PairSamples EncodePairs(const PairLayout& L, const TransitionSet& data, const DetectorOptions& options,
                        bool all_instances, uint64_t seed) {
  PairSamples out;
  const int64_t n = data.size();
  const int tfeat = L.target_features;

  // choose the samples: (transition, instance)
  std::mt19937_64 rng(seed);
  std::vector<int> unchanged;
  for (int64_t t = 0; t < n; ++t) {
    if (!L.multi_instance || all_instances) {
      for (int i = 0; i < L.instances; ++i) {
        out.transition.push_back(t);
        out.instance.push_back(i);
      }
      continue;
    }
    const auto s = data.state(t), s2 = data.next_state(t);
    unchanged.clear();
    for (int i = 0; i < L.instances; ++i) {
      const int base = L.target_offset + i * tfeat;
      bool changed = false;
      for (int k = 0; k < tfeat && !changed; ++k) changed = s[base + k] != s2[base + k];
      if (changed) {
        out.transition.push_back(t);
        out.instance.push_back(i);
      } else {
        unchanged.push_back(i);
      }
    }
    for (int j = 0; j < options.static_instances_per_step && !unchanged.empty(); ++j) {
      const size_t pick = std::uniform_int_distribution<size_t>(0, unchanged.size() - 1)(rng);
      out.transition.push_back(t);
      out.instance.push_back(unchanged[pick]);
      unchanged[pick] = unchanged.back();
      unchanged.pop_back();
    }
  }

  // encode every sample
  const int64_t m = out.size();
  out.passive_in.resize(L.passive_input_dim(), m);
  out.active_in.resize(L.active_input_dim(), m);
  out.target.resize(L.output_dim(), m);
  out.close.assign(m, 1);
  for (int64_t j = 0; j < m; ++j) {
    const int64_t t = out.transition[j];
    const PairTransition tr{data.state(t), data.action(t), data.next_state(t)};
    out.close[j] = EncodeSample(L, tr, tr, out.instance[j], out.passive_in.col(j).data(), out.active_in.col(j).data(),
                                out.target.col(j).data())
                       ? 1
                       : 0;
  }
  return out;
}

}  // namespace coins::detector
