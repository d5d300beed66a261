#include "learner/rl/algorithm_state.h"

namespace coins::rl {

nn::ParamSet VectorSet(const std::string& name, const Eigen::VectorXf& v) {
  nn::ParamSet p;
  p.Add(name, int(v.size()), 1);
  p.values = v;
  p.grads = Eigen::VectorXf::Zero(v.size());
  return p;
}

void AppendAdam(const nn::Adam& adam, const std::string& name, AlgorithmState* state) {
  state->sets.push_back(VectorSet(name + ".m", adam.first_moment()));
  state->sets.push_back(VectorSet(name + ".v", adam.second_moment()));
  state->counters.push_back(adam.steps());
}

Status RestoreAdam(const AlgorithmState& state, size_t* next, size_t* counter, nn::Adam* adam) {
  if (*next + 2 > state.sets.size() || *counter >= state.counters.size())
    return Errorf("algorithm state: optimiser moments missing");
  const bool ok = adam->Restore(state.sets[*next].values, state.sets[*next + 1].values, state.counters[*counter]);
  if (!ok) return Errorf("algorithm state: optimiser '{}' has the wrong size", state.sets[*next].blocks().front().name);
  *next += 2;
  *counter += 1;
  return Status::Ok();
}

Status RestoreParams(const AlgorithmState& state, size_t* next, nn::ParamSet* params) {
  if (*next >= state.sets.size()) return Errorf("algorithm state: a network is missing");
  const nn::ParamSet& src = state.sets[*next];
  if (!src.SameShape(*params)) return Errorf("algorithm state: network {} has another shape", *next);
  params->values = src.values;
  *next += 1;
  return Status::Ok();
}

}  // namespace coins::rl
