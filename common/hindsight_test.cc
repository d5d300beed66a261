// Hindsight functions: goal tests and the hindsight index choice, worked out by hand.
#include <gtest/gtest.h>

#include "common/hindsight.h"

namespace coins {
namespace {

TEST(Her, MaskedGoalAndDistances) {
  std::vector<float> state = {10, 42, 0, 0, 1}, mask = {0, 1, 0, 0, 0}, goal(5), compact(5);
  MaskedGoal(state, mask, goal);
  EXPECT_EQ(goal, (std::vector<float>{0, 42, 0, 0, 0}));
  EXPECT_EQ(GatherMasked(state, mask, compact), 1);
  EXPECT_EQ(compact[0], 42.0f);
  std::vector<float> a = {1.0f, 2.0f, 3.0f}, g = {1.5f, 1.0f, 0.0f}, m = {1, 1, 0};
  EXPECT_FLOAT_EQ(GoalDistance(a, g, m, GoalNorm::kL1), 1.5f);
  EXPECT_FLOAT_EQ(GoalDistance(a, g, m, GoalNorm::kLinf), 1.0f);
  EXPECT_FLOAT_EQ(GoalDistance(a, g, {}, GoalNorm::kLinf), 3.0f);
  EXPECT_TRUE(GoalReached(a, g, m, 1.0f, GoalNorm::kLinf));
  EXPECT_FALSE(GoalReached(a, g, m, 1.0f, GoalNorm::kL1));
  EXPECT_EQ(SkillReward(true), 0.0f);
  EXPECT_EQ(SkillReward(false), -1.0f);
}

TEST(Her, HindsightIndexStaysInsideTheSegment) {
  std::mt19937_64 rng(1);
  EXPECT_EQ(SelectHindsightIndex(HerStrategy::kFinal, 12, 10, 20, &rng), 19);
  EXPECT_EQ(SelectHindsightIndex(HerStrategy::kNone, 12, 10, 20, &rng), 12);
  bool saw_t = false, saw_last = false;
  for (int i = 0; i < 2000; ++i) {
    const int64_t f = SelectHindsightIndex(HerStrategy::kFuture, 12, 10, 20, &rng);
    ASSERT_GE(f, 12);
    ASSERT_LT(f, 20);
    saw_t |= f == 12;
    saw_last |= f == 19;
    const int64_t e = SelectHindsightIndex(HerStrategy::kEpisode, 12, 10, 20, &rng);
    ASSERT_GE(e, 10);
    ASSERT_LT(e, 20);
  }
  EXPECT_TRUE(saw_t && saw_last);
  EXPECT_FALSE(ParseHerStrategy("past").ok());
  EXPECT_EQ(*ParseHerStrategy("final"), HerStrategy::kFinal);
}

}  // namespace
}  // namespace coins
