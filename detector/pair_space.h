// PairSpace: the compact state a pair's detector works on, so that replay samples carry only
// the source and target factors instead of the whole state (Breakout: 10 of 517 features).
//
// sub is an EnvSpec holding just the source factor (none for the primitive action) and the
// target factor (every instance), with the env's action space; gather lists, for each feature
// of the compact state, its index in the full state. A PairLayout fitted on sub encodes compact
// states; an actor gathers the compact state from its full one with `gather`.
#pragma once

#include <string>
#include <vector>

#include "common/env_spec.h"
#include "common/status.h"

namespace coins::detector {

struct PairSpace {
  envs::EnvSpec sub;
  std::vector<int> gather;  // compact feature i = full state[gather[i]]
  int full_state_dim = 0;
  void Gather(const float* full, float* compact) const {
    for (size_t i = 0; i < gather.size(); ++i) compact[i] = full[gather[i]];
  }
};

// errors on unknown factors or source == target
Result<PairSpace> MakePairSpace(const envs::EnvSpec& spec, const std::string& source, const std::string& target);

}  // namespace coins::detector
