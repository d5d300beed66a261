#include "common/env_spec.h"

namespace coins::envs {

int EnvSpec::state_dim() const {
  int n = 0;
  for (const FactorSpec& f : factors) n += f.size();
  return n;
}

int EnvSpec::factor_index(const std::string& factor_name) const {
  for (int i = 0; i < static_cast<int>(factors.size()); ++i)
    if (factors[i].name == factor_name) return i;
  return -1;
}

int EnvSpec::factor_offset(int i) const {
  int off = 0;
  for (int k = 0; k < i; ++k) off += factors[k].size();
  return off;
}

std::string EnvSpec::feature_name(int index) const {
  int off = 0;
  for (const FactorSpec& f : factors) {
    if (index >= off && index < off + f.size()) {
      const int within = index - off;
      const std::string& feature = f.feature_names[size_t(within % f.features)];
      if (!f.multi_instance) return f.name + "." + feature;
      return f.name + "[" + std::to_string(within / f.features) + "]." + feature;
    }
    off += f.size();
  }
  return "outside the state";
}

}  // namespace coins::envs
