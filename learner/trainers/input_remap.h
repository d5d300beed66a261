// Fine-tuning a task network in an env whose observation has more features than the one it was
// trained in (base Breakout -> breakout-prox, which adds a Target factor): the network's input
// rows named by the state features they carry, and an algorithm state re-laid onto a level that
// observes more of them.
//
// The re-laid first layer keeps the trained weights of every input the old level had, in the new
// input order, and gives each new input zero weights and zero optimiser moments; every other
// tensor is copied. So the re-laid network computes exactly what the trained one did on the
// features they share, until training moves it. Refused, with the feature named, when the new
// level lacks an input the trained one had or scales a shared one differently.
#pragma once

#include <string>
#include <vector>

#include "common/env_spec.h"
#include "common/policy/level_spec.h"
#include "common/status.h"
#include "learner/rl/algorithm_state.h"

namespace coins {

// one per network input row, in order: "Paddle.x" for a state feature, "Paddle.x-Ball.x" for a
// relative pair, "goal.Ball.vy" for a goal row. With a pair network, the inputs of one point:
// the rows outside the instances, then one instance's features ("Block.x"), then its relative
// features ("Ball.x-Block.x").
std::vector<std::string> NetworkInputNames(const policy::LevelSpec& spec, const envs::EnvSpec& env);

// for each input row of `to`, the input row of `from` carrying the same feature (-1: new in `to`)
Result<std::vector<int>> MatchNetworkInputs(const policy::LevelSpec& from, const envs::EnvSpec& from_env,
                                            const policy::LevelSpec& to, const envs::EnvSpec& to_env);

// `trained` (exported by a trainer of the old level) re-laid onto the shapes of `fresh` (exported
// by a new trainer of the new level), input_of from MatchNetworkInputs. Networks are the sets of
// several tensors; a one-tensor set (optimiser moments) follows the first network of its size.
Result<rl::AlgorithmState> RelayInputs(const rl::AlgorithmState& trained, const rl::AlgorithmState& fresh,
                                       const std::vector<int>& input_of);

}  // namespace coins
