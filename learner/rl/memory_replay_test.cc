// The in-memory replay: n-step returns and relabelled rewards worked out by hand.
#include <gtest/gtest.h>

#include "learner/rl/memory_replay.h"

namespace coins::rl {
namespace {

// a 1-d walk: obs = position, achieved goal = next position
void AddWalk(MemoryReplay* replay, std::vector<float> positions, float goal, bool end_segment) {
  for (size_t i = 0; i + 1 < positions.size(); ++i) {
    float obs = positions[i], next = positions[i + 1], act = 1.0f;
    ReplayStep s;
    s.obs = {&obs, 1};
    s.next_obs = {&next, 1};
    s.action = {&act, 1};
    s.goal = {&goal, 1};
    s.achieved = {&next, 1};
    s.segment_end = end_segment && i + 2 == positions.size();
    replay->Add(s);
  }
}

TEST(MemoryReplay, NStepReturnsWithOriginalGoals) {
  MemoryReplayOptions o;
  o.obs_dim = 1;
  o.goal_dim = 1;
  o.n_step = 3;
  o.gamma = 0.5f;
  o.goal_epsilon = 0.1f;
  o.her = HerStrategy::kNone;
  MemoryReplay replay(o);
  // positions 0,1,2,3,4 with goal 3: steps 0,1 miss; step 2 reaches 3 (terminal)
  AddWalk(&replay, {0, 1, 2, 3, 4}, 3.0f, true);
  Batch batch;
  ASSERT_TRUE(replay.Sample(256, &batch).ok());
  bool seen[4] = {};
  for (int b = 0; b < batch.size(); ++b) {
    const int t = int(batch.keys[size_t(b)]);
    seen[t] = true;
    EXPECT_EQ(batch.obs(1, b), 3.0f);  // the goal is appended
    switch (t) {
      case 0:  // -1, -0.5, then the reach (0) at k = 2: terminal
        EXPECT_FLOAT_EQ(batch.rewards(0, b), -1.5f);
        EXPECT_FLOAT_EQ(batch.discounts(0, b), 0.0f);
        EXPECT_EQ(batch.next_obs(0, b), 3.0f);
        break;
      case 1:
        EXPECT_FLOAT_EQ(batch.rewards(0, b), -1.0f);
        EXPECT_FLOAT_EQ(batch.discounts(0, b), 0.0f);
        break;
      case 2:
        EXPECT_FLOAT_EQ(batch.rewards(0, b), 0.0f);
        EXPECT_FLOAT_EQ(batch.discounts(0, b), 0.0f);
        break;
      case 3:  // 3 -> 4 moves away from the goal; the window ends with the segment
        EXPECT_FLOAT_EQ(batch.rewards(0, b), -1.0f);
        EXPECT_FLOAT_EQ(batch.discounts(0, b), 0.5f);
        EXPECT_EQ(batch.next_obs(0, b), 4.0f);
        break;
    }
  }
  EXPECT_TRUE(seen[0] && seen[1] && seen[2] && seen[3]);
}

TEST(MemoryReplay, FinalStrategyRelabelsWithTheSegmentsLastAchievedGoal) {
  MemoryReplayOptions o;
  o.obs_dim = 1;
  o.goal_dim = 1;
  o.n_step = 1;
  o.goal_epsilon = 0.1f;
  o.her = HerStrategy::kFinal;
  o.her_ratio = 1.0f;
  MemoryReplay replay(o);
  AddWalk(&replay, {0, 1, 2}, 9.0f, true);   // segment A ends at 2
  AddWalk(&replay, {5, 6, 7}, 9.0f, false);  // segment B still open, last achieved 7
  Batch batch;
  ASSERT_TRUE(replay.Sample(200, &batch).ok());
  for (int b = 0; b < batch.size(); ++b) {
    const int t = int(batch.keys[size_t(b)]);
    const float goal = batch.obs(1, b);
    EXPECT_EQ(goal, t < 2 ? 2.0f : 7.0f) << t;
    const bool last = t == 1 || t == 3;
    EXPECT_FLOAT_EQ(batch.rewards(0, b), last ? 0.0f : -1.0f) << t;
    EXPECT_FLOAT_EQ(batch.discounts(0, b), last ? 0.0f : 0.99f) << t;
  }
}

TEST(MemoryReplay, RingKeepsTheNewestSteps) {
  MemoryReplayOptions o;
  o.obs_dim = 1;
  o.capacity = 4;
  MemoryReplay replay(o);
  for (int i = 0; i < 10; ++i) {
    float obs = float(i), next = float(i + 1), act = 0.0f;
    ReplayStep s;
    s.obs = {&obs, 1};
    s.next_obs = {&next, 1};
    s.action = {&act, 1};
    s.reward = float(i);
    replay.Add(s);
  }
  EXPECT_EQ(replay.size(), 4);
  Batch batch;
  ASSERT_TRUE(replay.Sample(64, &batch).ok());
  for (int b = 0; b < batch.size(); ++b) {
    EXPECT_GE(batch.obs(0, b), 6.0f);
    EXPECT_EQ(batch.rewards(0, b), batch.obs(0, b));
  }
  MemoryReplayOptions bad = o;
  bad.n_step = 0;
  EXPECT_FALSE(bad.Validate().ok());
}

TEST(MemoryReplay, AStepThatDoesNotStartWhereTheLastEndedStartsASegment) {
  MemoryReplayOptions o;
  o.obs_dim = 1;
  o.n_step = 3;
  o.gamma = 0.5f;
  MemoryReplay replay(o);
  // 0 -> 1, then 5 -> 6 and 6 -> 7 without a segment end in between: two segments
  const float steps[3][2] = {{0, 1}, {5, 6}, {6, 7}};
  for (const auto& st : steps) {
    float act = 0.0f;
    ReplayStep s;
    s.obs = {&st[0], 1};
    s.next_obs = {&st[1], 1};
    s.action = {&act, 1};
    s.reward = 1.0f;
    replay.Add(s);
  }
  Batch batch;
  ASSERT_TRUE(replay.Sample(64, &batch).ok());
  for (int b = 0; b < batch.size(); ++b) {
    const uint64_t t = batch.keys[size_t(b)];
    EXPECT_EQ(batch.obs(0, b), steps[t][0]);
    EXPECT_EQ(batch.next_obs(0, b), t == 0 ? 1.0f : 7.0f) << t;
    EXPECT_FLOAT_EQ(batch.rewards(0, b), t == 1 ? 1.5f : 1.0f) << t;
    EXPECT_FLOAT_EQ(batch.discounts(0, b), t == 1 ? 0.25f : 0.5f) << t;
  }
}

TEST(MemoryReplay, RefusesWhatTheReplayServiceDoesNotDo) {
  MemoryReplayOptions o;
  o.obs_dim = 1;
  o.goal_dim = 1;
  ASSERT_TRUE(o.Validate().ok());
  MemoryReplayOptions episode = o;
  episode.her = HerStrategy::kEpisode;
  EXPECT_NE(episode.Validate().message().find("episode"), std::string::npos);
  MemoryReplayOptions no_stop = o;
  no_stop.terminate_on_success = false;
  EXPECT_NE(no_stop.Validate().message().find("terminate_on_success"), std::string::npos);
  MemoryReplay replay(o);
  Batch batch;
  EXPECT_FALSE(replay.Sample(8, &batch).ok());  // empty
  AddWalk(&replay, {0, 1}, 1.0f, true);
  EXPECT_TRUE(replay.Sample(8, &batch).ok());
  EXPECT_NE(replay.Sample(5000, &batch).message().find("batch_size"), std::string::npos);
}

}  // namespace
}  // namespace coins::rl
