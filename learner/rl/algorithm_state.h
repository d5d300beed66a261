// AlgorithmState: everything an RL algorithm needs to continue training exactly where it was
// (networks, target networks, optimiser moments, counters), as named parameter sets, so that
// learner checkpoints can write it with the weights format of common/nn/serialize.h.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "common/nn/adam.h"
#include "common/nn/params.h"
#include "common/status.h"

namespace coins::rl {

struct AlgorithmState {
  std::vector<nn::ParamSet> sets;  // in a fixed order per algorithm
  std::vector<int64_t> counters;   // likewise
};

// one block "name" holding v (for optimiser moments)
nn::ParamSet VectorSet(const std::string& name, const Eigen::VectorXf& v);
// appends an Adam's moments as two sets and its step count as a counter
void AppendAdam(const nn::Adam& adam, const std::string& name, AlgorithmState* state);
// restores an Adam from sets[*next], sets[*next + 1] and counters[*counter]
Status RestoreAdam(const AlgorithmState& state, size_t* next, size_t* counter, nn::Adam* adam);
// copies sets[*next] into params (shapes must match)
Status RestoreParams(const AlgorithmState& state, size_t* next, nn::ParamSet* params);

}  // namespace coins::rl
