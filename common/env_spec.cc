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

}  // namespace coins::envs
