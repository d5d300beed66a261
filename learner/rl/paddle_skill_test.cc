// The Breakout paddle skill on the real env: from a fixed seed, the greedy policy reaches
// >= 95% of random paddle-x goals within the budget of 20k env steps.
#include <cstdio>

#include <gtest/gtest.h>

#include "learner/rl/paddle_skill.h"

namespace coins::rl {
namespace {

TEST(PaddleSkill, Reaches95PercentOfRandomGoals) {
  PaddleSkillOptions o;
  o.seed = 1;
  ASSERT_TRUE(o.Validate().ok());
  auto result = TrainPaddleSkill(o);
  ASSERT_TRUE(result.ok()) << result.status().message();
  for (auto [steps, success] : result->curve)
    std::printf("steps %lld greedy success %.2f\n", static_cast<long long>(steps), success);
  std::printf("env steps to 95%%: %lld, wall %.1f s\n", static_cast<long long>(result->env_steps_to_target),
              result->seconds_to_target);
  EXPECT_GE(result->env_steps_to_target, 0);
  EXPECT_LE(result->env_steps_to_target, 20000);
  EXPECT_GE(result->final_success, 0.95);
}

TEST(PaddleSkill, ValidateNamesBadOptions) {
  PaddleSkillOptions o;
  o.timeout = 0;
  Status s = o.Validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("timeout"), std::string::npos);
}

}  // namespace
}  // namespace coins::rl
