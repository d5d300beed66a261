// Prioritised sampling: the sum tree's proportional draw, and MemoryReplay's priority hook
// and importance weights.
#include <gtest/gtest.h>

#include "common/sum_tree.h"
#include "learner/rl/memory_replay.h"

namespace coins::rl {
namespace {

TEST(SumTree, FindFollowsPrefixSums) {
  SumTree tree(5);
  const double p[5] = {1.0, 0.0, 2.0, 3.0, 4.0};
  for (int i = 0; i < 5; ++i) tree.Set(i, p[i]);
  EXPECT_DOUBLE_EQ(tree.Total(), 10.0);
  EXPECT_EQ(tree.Find(0.0), 0);
  EXPECT_EQ(tree.Find(0.99), 0);
  EXPECT_EQ(tree.Find(1.0), 2);  // slot 1 is empty
  EXPECT_EQ(tree.Find(2.99), 2);
  EXPECT_EQ(tree.Find(3.0), 3);
  EXPECT_EQ(tree.Find(6.5), 4);
  EXPECT_EQ(tree.Find(10.0), 4);  // clamped to the last non-empty slot
  tree.Set(4, 0.0);
  EXPECT_EQ(tree.Find(9.0), 3);
}

TEST(MemoryReplay, PrioritiesSteerSamplingAndWeights) {
  MemoryReplayOptions o;
  o.obs_dim = 1;
  o.capacity = 8;
  o.prioritized = true;
  o.priority_alpha = 1.0f;
  o.priority_beta = 1.0f;
  MemoryReplay replay(o);
  for (int i = 0; i < 12; ++i) {  // wraps: steps 4..11 remain
    float obs = float(i), act = 0.0f;
    ReplayStep s;
    s.obs = {&obs, 1};
    s.next_obs = {&obs, 1};
    s.action = {&act, 1};
    s.terminal = true;
    replay.Add(s);
  }
  // step 9 gets priority ~100, the others ~1 (eps included); step 2 is gone and ignored
  std::vector<uint64_t> keys = {4, 5, 6, 7, 8, 9, 10, 11, 2};
  std::vector<float> prio = {1, 1, 1, 1, 1, 100, 1, 1, 50};
  replay.UpdatePriorities(keys, prio);
  Batch batch;
  ASSERT_TRUE(replay.Sample(1000, &batch).ok());
  int nine = 0;
  for (int b = 0; b < batch.size(); ++b) {
    const uint64_t k = batch.keys[size_t(b)];
    ASSERT_GE(k, 4u);
    ASSERT_LE(k, 11u);
    EXPECT_EQ(batch.obs(0, b), float(k));  // the slot maps back to its step
    if (k == 9) {
      ++nine;
      // (N P)^-1 normalised by the largest weight (a priority-1 step): 1.001 / 100.001
      EXPECT_NEAR(batch.weights(0, b), 1.001f / 100.001f, 1e-4f);
    } else {
      EXPECT_NEAR(batch.weights(0, b), 1.0f, 1e-4f);
    }
  }
  // P(9) = 100 / 107 -> about 935 of 1000
  EXPECT_NEAR(nine, 935, 20);
}

}  // namespace
}  // namespace coins::rl
