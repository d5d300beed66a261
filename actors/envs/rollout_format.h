// The rollout line format of `coins env rollout` and `coins eval --out`: one JSON object per
// transition, {"t", "episode", "state", "action", "next_state", "reward", "done", "truncated",
// "interactions"}. States map each factor name to its features, or to a list of feature lists
// for multi-instance classes; interactions list the labels of the pairs that happened.
#pragma once

#include <span>
#include <string>

#include "actors/envs/env.h"

namespace coins::envs {

// appends the line (with its newline) to out
void AppendRolloutLine(const EnvSpec& spec, int64_t t, int64_t episode, std::span<const float> state,
                       std::span<const float> action, std::span<const float> next, const StepResult& r,
                       std::string* out);

}  // namespace coins::envs
