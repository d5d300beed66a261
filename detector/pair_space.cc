#include "detector/pair_space.h"

namespace coins::detector {

Result<PairSpace> MakePairSpace(const envs::EnvSpec& spec, const std::string& source, const std::string& target) {
  if (source == target) return Errorf("source and target are both '{}'", source);
  PairSpace p;
  p.sub.name = spec.name;
  p.sub.action = spec.action;
  p.sub.max_episode_steps = spec.max_episode_steps;
  p.full_state_dim = spec.state_dim();
  std::vector<std::string> factors;
  if (source != "Action") factors.push_back(source);
  factors.push_back(target);
  for (const std::string& name : factors) {
    const int f = spec.factor_index(name);
    if (f < 0) return Errorf("env '{}' has no factor '{}'", spec.name, name);
    const envs::FactorSpec& fs = spec.factors[size_t(f)];
    const int offset = spec.factor_offset(f);
    for (int i = 0; i < fs.size(); ++i) p.gather.push_back(offset + i);
    p.sub.factors.push_back(fs);
  }
  // the env's labels of this pair keep their bit positions
  p.sub.interactions = spec.interactions;
  return p;
}

}  // namespace coins::detector
