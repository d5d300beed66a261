#include "learner/trainers/input_remap.h"

#include <algorithm>

namespace coins {

namespace {

// an input row: the feature it carries and the bounds it is scaled by
struct InputRow {
  std::string name;
  float low = 0, high = 0;
};

// the observation rows of a level, in order (level_spec.h: features, relative pairs, goal)
std::vector<InputRow> ObservationRows(const policy::LevelSpec& s, const envs::EnvSpec& env) {
  std::vector<InputRow> rows;
  for (size_t i = 0; i < s.obs_index.size(); ++i)
    rows.push_back({env.feature_name(s.obs_index[i]), s.obs_low[i], s.obs_high[i]});
  for (size_t k = 0; k < s.relative.size(); ++k) {
    const std::string a = env.feature_name(s.obs_index[size_t(s.relative[k].first)]);
    const std::string b = env.feature_name(s.obs_index[size_t(s.relative[k].second)]);
    rows.push_back({a + "-" + b, -s.relative_scale[k], s.relative_scale[k]});
  }
  for (int g = 0; g < s.goal.dim(); ++g)
    rows.push_back({"goal." + env.feature_name(s.goal.offset + s.goal.masked[size_t(g)]), s.goal.scale_low[size_t(g)],
                    s.goal.scale_high[size_t(g)]});
  return rows;
}

// "Block[0].x" -> "Block.x"
std::string InstanceFeature(std::string name) {
  const size_t open = name.find('['), close = name.find(']');
  if (open != std::string::npos && close != std::string::npos && close > open) name.erase(open, close - open + 1);
  return name;
}

// the network's input rows: the observation, or with a pair network one point's inputs (the
// rows outside the instances, one instance, its relative features "Block.x-Obstacle.x" in the
// instance feature's units)
std::vector<InputRow> NetworkInputs(const policy::LevelSpec& s, const envs::EnvSpec& env) {
  std::vector<InputRow> obs = ObservationRows(s, env);
  if (!s.pair.enabled()) return obs;
  const size_t first = size_t(s.pair.offset), end = first + size_t(s.pair.instances) * size_t(s.pair.instance_dim);
  std::vector<InputRow> point(obs.begin(), obs.begin() + long(first));
  point.insert(point.end(), obs.begin() + long(end), obs.end());
  for (size_t j = first; j < first + size_t(s.pair.instance_dim); ++j)
    point.push_back({InstanceFeature(obs[j].name), obs[j].low, obs[j].high});
  for (const nn::RelativeFeature& r : s.pair.relative) {
    const InputRow& i = obs[first + size_t(r.instance)];
    const float half = 0.5f * (i.high - i.low);
    point.push_back({obs[size_t(r.source)].name + "-" + InstanceFeature(i.name), -half, half});
  }
  return point;
}

// the re-laid copy of one network's flat values: a tensor of the same shape is copied, the
// first layer's weights (same rows, more input columns) take their columns by input_of
Result<Eigen::VectorXf> RelayNetwork(const nn::ParamSet& old_layout, const nn::ParamSet& new_layout,
                                     const Eigen::VectorXf& old_values, const std::vector<int>& input_of) {
  if (old_layout.blocks().size() != new_layout.blocks().size())
    return Errorf("networks of {} and {} tensors", old_layout.blocks().size(), new_layout.blocks().size());
  Eigen::VectorXf out = Eigen::VectorXf::Zero(new_layout.size());
  for (size_t i = 0; i < new_layout.blocks().size(); ++i) {
    const nn::ParamBlock &a = old_layout.blocks()[i], &b = new_layout.blocks()[i];
    if (a.name != b.name) return Errorf("tensor {} is '{}' in one network and '{}' in the other", i, a.name, b.name);
    const Eigen::Map<const Eigen::MatrixXf> from(old_values.data() + a.offset, a.rows, a.cols);
    Eigen::Map<Eigen::MatrixXf> to(out.data() + b.offset, b.rows, b.cols);
    if (a.rows == b.rows && a.cols == b.cols) {
      to = from;
      continue;
    }
    if (i != 0 || a.rows != b.rows || size_t(b.cols) != input_of.size())
      return Errorf("tensor '{}' is {}x{} trained and {}x{} now: only the first layer's inputs may differ", a.name,
                    a.rows, a.cols, b.rows, b.cols);
    for (int c = 0; c < b.cols; ++c)
      if (input_of[size_t(c)] >= 0) to.col(c) = from.col(input_of[size_t(c)]);
  }
  return out;
}

}  // namespace

std::vector<std::string> NetworkInputNames(const policy::LevelSpec& spec, const envs::EnvSpec& env) {
  std::vector<std::string> names;
  for (const InputRow& r : NetworkInputs(spec, env)) names.push_back(r.name);
  return names;
}

Result<std::vector<int>> MatchNetworkInputs(const policy::LevelSpec& from, const envs::EnvSpec& from_env,
                                            const policy::LevelSpec& to, const envs::EnvSpec& to_env) {
  if (from.pair.enabled() != to.pair.enabled())
    return Errorf("one network is a pair network over {} and the other is not",
                  from.pair.enabled() ? from.pair_factor : to.pair_factor);
  const std::vector<InputRow> old_rows = NetworkInputs(from, from_env), new_rows = NetworkInputs(to, to_env);
  std::vector<int> input_of(new_rows.size(), -1);
  for (size_t i = 0; i < old_rows.size(); ++i) {
    const InputRow& o = old_rows[i];
    auto it = std::find_if(new_rows.begin(), new_rows.end(), [&](const InputRow& r) { return r.name == o.name; });
    if (it == new_rows.end())
      return Errorf("input {} of the network trained on {} is not observed in {}", o.name, from_env.name, to_env.name);
    if (it->low != o.low || it->high != o.high)
      return Errorf("input {} is scaled by [{}, {}] in {} and by [{}, {}] in {}", o.name, o.low, o.high, from_env.name,
                    it->low, it->high, to_env.name);
    input_of[size_t(it - new_rows.begin())] = int(i);
  }
  return input_of;
}

Result<rl::AlgorithmState> RelayInputs(const rl::AlgorithmState& trained, const rl::AlgorithmState& fresh,
                                       const std::vector<int>& input_of) {
  if (trained.sets.size() != fresh.sets.size() || trained.counters.size() != fresh.counters.size())
    return Errorf("algorithm states of {} and {} tensor sets", trained.sets.size(), fresh.sets.size());
  rl::AlgorithmState out = fresh;
  out.counters = trained.counters;
  for (size_t s = 0; s < fresh.sets.size(); ++s) {
    const nn::ParamSet &a = trained.sets[s], &b = fresh.sets[s];
    const nn::ParamSet *old_layout = &a, *new_layout = &b;
    if (b.blocks().size() == 1) {  // optimiser moments: laid out like the first network of their size
      for (size_t n = 0; n < fresh.sets.size(); ++n)
        if (fresh.sets[n].blocks().size() > 1 && fresh.sets[n].size() == b.size() &&
            trained.sets[n].size() == a.size()) {
          old_layout = &trained.sets[n], new_layout = &fresh.sets[n];
          break;
        }
      if (old_layout == &a && a.size() != b.size())
        return Errorf("set '{}' of {} values follows no network", b.blocks().front().name, b.size());
    }
    auto values = RelayNetwork(*old_layout, *new_layout, a.values, input_of);
    if (!values.ok()) return values.status().WithContext("set " + b.blocks().front().name);
    out.sets[s].values = std::move(*values);
  }
  return out;
}

}  // namespace coins
