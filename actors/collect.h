// Collecting detector data from a live environment: runs an env with a simple policy and
// records its transitions into a detector::TransitionSet (the `coins detect` tool and tests).
#pragma once

#include <cstdint>
#include <string>

#include "actors/envs/env.h"
#include "common/status.h"
#include "detector/transitions.h"

namespace coins::detector {

// How data is collected. policy: "random" (uniform actions), "goals" (a scripted stand-in for
// the learned skill with random goals: Breakout's paddle or pushing's gripper moves to a random
// target, a new one when reached or after goal_timeout steps; gripper targets have z in the
// lowest quarter of its range, the cube's height), or a file path holding one action
// per line (floats separated by spaces or commas), replayed in a cycle.
struct CollectOptions {
  std::string policy = "random";
  int64_t steps = 10000;
  uint64_t seed = 1;
  int goal_timeout = 30;
  Status Validate() const;
};

// runs the env for options.steps steps from Reset(seed), starting a new episode after each
// done/truncated step; errors from the env or the policy file are returned
Result<TransitionSet> CollectTransitions(envs::Env& env, const CollectOptions& options);

}  // namespace coins::detector
