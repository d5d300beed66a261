// The detector on real pushing data (MuJoCo) with fixed seeds: Action->Gripper passes with a
// continuous x, y, z goal space; Gripper->Block passes with the mask x, y.
#include <gtest/gtest.h>

#include "actors/collect.h"
#include "actors/envs/env.h"
#include "detector/interaction.h"
#include "learner/detect/detector_test_data.h"

namespace coins::detector {
namespace {

TransitionSet Collect(const std::string& policy, int64_t steps, uint64_t seed) {
  return testing::CollectFrom("pushing", policy, steps, seed);
}

DetectorOptions FastOptions() { return testing::FastOptionsFor("pushing"); }

TEST(PushingDetector, ActionGripperPassesWithContinuousXYZ) {
  auto env = envs::MakeEnv("pushing");
  const TransitionSet data = Collect("random", 5000, 1);
  Result<PairDetector> det =
      PairDetector::Train((*env)->spec(), data.Slice(0, 4000), "Action", "Gripper", FastOptions());
  ASSERT_TRUE(det.ok()) << det.status().message();
  const PairScores s = det->Score(data.Slice(4000, 5000));
  EXPECT_TRUE(s.pass) << "Sc_I " << s.score;
  EXPECT_EQ(s.mask, (std::vector<int>{1, 1, 1}));
  EXPECT_EQ(s.goals.kind, GoalSet::Kind::kContinuous);
  ASSERT_EQ(s.goals.low.size(), 3u);
  EXPECT_LT(s.goals.low[0], -0.1f);
  EXPECT_GT(s.goals.high[0], 0.1f);
}

TEST(PushingDetector, GripperBlockPassesWithMaskXY) {
  auto env = envs::MakeEnv("pushing");
  const TransitionSet data = Collect("goals", 24000, 1);
  Result<PairDetector> det =
      PairDetector::Train((*env)->spec(), data.Slice(0, 16000), "Gripper", "Block", FastOptions());
  ASSERT_TRUE(det.ok()) << det.status().message();
  const PairScores s = det->Score(data.Slice(16000, 24000));
  EXPECT_TRUE(s.pass) << "Sc_I " << s.score << " N_int " << s.interactions;
  EXPECT_GE(s.interactions, 10);
  EXPECT_EQ(s.mask, (std::vector<int>{1, 1, 0}));
  // a few pushes in 8000 steps: fewer than n_disc goals is a discrete space (the paper's rule);
  // with more data it is continuous (README)
  EXPECT_NE(s.goals.kind, GoalSet::Kind::kEmpty);
  EXPECT_EQ(s.goals.features, (std::vector<int>{0, 1}));

  // Obstacles never move: nothing to model, no link
  Result<PairDetector> obs =
      PairDetector::Train((*env)->spec(), data.Slice(0, 2000), "Gripper", "Obstacle", FastOptions());
  ASSERT_TRUE(obs.ok());
  EXPECT_FALSE(obs->trained());
  EXPECT_FALSE(obs->Score(data.Slice(2000, 3000)).pass);
}

}  // namespace
}  // namespace coins::detector
