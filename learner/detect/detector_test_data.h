// What the detector tests on real env data share: data collected with fixed seeds, and detector
// options with training shortened (a few thousand Adam steps) to keep the tests fast.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <utility>

#include "actors/collect.h"
#include "actors/envs/env.h"
#include "detector/options.h"
#include "detector/transitions.h"

namespace coins::detector::testing {

inline TransitionSet CollectFrom(const std::string& env_name, const std::string& policy, int64_t steps, uint64_t seed) {
  Result<std::unique_ptr<envs::Env>> env = envs::MakeEnv(env_name);
  EXPECT_TRUE(env.ok());
  CollectOptions co;
  co.policy = policy;
  co.steps = steps;
  co.seed = seed;
  Result<TransitionSet> data = CollectTransitions(**env, co);
  EXPECT_TRUE(data.ok()) << data.status().message();
  return std::move(data.value());
}

inline DetectorOptions FastOptionsFor(const std::string& env_name) {
  DetectorOptions o = DefaultDetectorOptions(env_name);
  o.passive_steps = 1500;
  o.passive_hard_steps = 1500;
  o.active_steps = 3000;
  o.seed = 7;
  return o;
}

}  // namespace coins::detector::testing
