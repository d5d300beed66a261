// The reply merge (checks, next_state decoding, keys), the batch split and the rl::Batch view.
#include "learner/replay_client/sample_source.h"

#include <gtest/gtest.h>

#include "idl/transition.h"

namespace coins {
namespace {

// a reply of n samples over feature_dim 3, action_dim 1, goal_dim 1; sample i's state is
// (base + i, 10, 20) and its next state moves features 0 and 2
msg::SampleReply Reply(uint32_t shard, uint32_t n, float base) {
  msg::SampleReply r;
  r.schema_version(msg::SAMPLING_SCHEMA);
  r.shard_id(shard);
  r.status(msg::SAMPLE_OK);
  r.n(n);
  r.state_dim(8);
  r.feature_dim(3);
  r.action_dim(1);
  r.goal_dim(1);
  for (uint32_t i = 0; i < n; ++i) {
    float s = base + float(i);
    r.state().insert(r.state().end(), {s, 10, 20});
    r.next_index().insert(r.next_index().end(), {0, 2});
    r.next_value().insert(r.next_value().end(), {s + 1, 21});
    r.next_end().push_back(uint32_t(r.next_index().size()));
    r.action().push_back(float(i % 4));
    r.goal().push_back(-s);
    r.reward().push_back(s / 2);
    r.discount().push_back(0.9f);
    r.weight().push_back(1);
    r.key().push_back(100 + i);
    r.interactions().push_back(i);
    r.flags().push_back(uint16_t(i ? msg::ROW_INTERACTION : 0));
    r.skill_level().push_back(uint8_t(1 + i % 2));
    r.policy_version().push_back(7 + i);
  }
  return r;
}

TEST(SampleSource, MergeDecodesNextStatesAndRoutesKeys) {
  msg::SampleReply a = Reply(0, 2, 0), b = Reply(1, 3, 50);
  SampleColumns c;
  std::vector<ShardReply> replies{{&a, 0}, {&b, 1}};
  Status s = MergeReplies(replies, &c);
  ASSERT_TRUE(s.ok()) << s.message();
  ASSERT_EQ(c.n, 5u);
  EXPECT_EQ(c.feature_dim, 3u);
  EXPECT_EQ(c.state_dim, 8u);
  EXPECT_EQ(c.state, (std::vector<float>{0, 10, 20, 1, 10, 20, 50, 10, 20, 51, 10, 20, 52, 10, 20}));
  EXPECT_EQ(c.next_state, (std::vector<float>{1, 10, 21, 2, 10, 21, 51, 10, 21, 52, 10, 21, 53, 10, 21}));
  EXPECT_EQ(c.goal, (std::vector<float>{0, -1, -50, -51, -52}));
  EXPECT_EQ(c.key[1], SampleKey(0, 101));
  EXPECT_EQ(c.key[4], SampleKey(1, 102));
  EXPECT_EQ(KeyShard(c.key[4]), 1u);
  EXPECT_EQ(KeyRow(c.key[4]), 102u);
  EXPECT_EQ(c.policy_version, (std::vector<uint64_t>{7, 8, 7, 8, 9}));
  EXPECT_EQ(c.skill_level, (std::vector<uint8_t>{1, 2, 1, 2, 1}));
  EXPECT_EQ(c.flags[0], 0);
  EXPECT_EQ(c.flags[3], msg::ROW_INTERACTION);
  EXPECT_EQ(c.interactions[4], 2u);
  EXPECT_EQ(c.reward[2], 25.0f);

  // merged again into the same columns: no reallocation
  const float* before = c.state.data();
  ASSERT_TRUE(MergeReplies(replies, &c).ok());
  EXPECT_EQ(c.state.data(), before);
}

TEST(SampleSource, MergeRefusesMalformedRepliesNamingShardAndColumn) {
  auto expect = [](auto mutate, const char* what) {
    msg::SampleReply a = Reply(0, 2, 0), b = Reply(1, 2, 5);
    mutate(b);
    SampleColumns c;
    std::vector<ShardReply> replies{{&a, 0}, {&b, 1}};
    Status s = MergeReplies(replies, &c);
    EXPECT_FALSE(s.ok()) << what;
    EXPECT_NE(s.message().find("replay shard 1"), std::string::npos) << s.message();
    EXPECT_NE(s.message().find(what), std::string::npos) << s.message();
  };
  expect([](auto& r) { r.next_index()[1] = 3; }, "next_index 3 outside the 3 feature columns");
  expect([](auto& r) { r.flags().pop_back(); }, "flags has 1 values, expected 2");
  expect([](auto& r) { r.policy_version().clear(); }, "policy_version");
  expect([](auto& r) { r.state().pop_back(); }, "state has 5 values");
  expect([](auto& r) { r.next_end()[0] = 9; }, "next_end");
  expect([](auto& r) { r.feature_dim(2), r.state().resize(4), r.next_index().assign(4, 0); }, "differ from shard 0");
  expect([](auto& r) { r.status(msg::SAMPLE_NOT_READY), r.error("limiter"); }, "status 1: limiter");
  expect([](auto& r) { r.schema_version(2); }, "schema_version 2");
}

TEST(SampleSource, SplitFollowsShardSizes) {
  std::vector<uint32_t> counts;
  SplitBatch(std::vector<uint64_t>{100, 300}, 8, &counts);
  EXPECT_EQ(counts, (std::vector<uint32_t>{2, 6}));
  SplitBatch(std::vector<uint64_t>{0, 0, 0}, 10, &counts);
  EXPECT_EQ(counts, (std::vector<uint32_t>{4, 3, 3}));
  SplitBatch(std::vector<uint64_t>{1, 1, 1}, 2, &counts);
  EXPECT_EQ(counts, (std::vector<uint32_t>{1, 1, 0}));
  SplitBatch(std::vector<uint64_t>{5, 0}, 7, &counts);
  EXPECT_EQ(counts, (std::vector<uint32_t>{7, 0}));
}

TEST(SampleSource, FillRequestCarriesEverySpecField) {
  SampleSpec s;
  s.strategy = msg::SAMPLE_PRIORITIZED;
  s.skill_level = 2;
  s.level_mask = 6;
  s.n_step = 3;
  s.gamma = 0.5f;
  s.her_strategy = msg::HER_FUTURE;
  s.her_ratio = 0.25f;
  s.goal_mask = {1, 0};
  s.target_offset = 9;
  s.goal_epsilon = 0.1f;
  s.goal_norm = msg::GOAL_NORM_L1;
  s.features = {4, 1};
  s.step_reward = -2;
  s.success_reward = 3;
  s.interaction_reward = 1;
  s.require_interaction = true;
  s.terminate_on_interaction = true;
  msg::SampleRequest q;
  FillRequest(s, &q);
  EXPECT_EQ(q.schema_version(), msg::SAMPLING_SCHEMA);
  EXPECT_EQ(q.strategy(), msg::SAMPLE_PRIORITIZED);
  EXPECT_EQ(q.skill_level(), 2);
  EXPECT_EQ(q.level_mask(), 6u);
  EXPECT_EQ(q.n_step(), 3u);
  EXPECT_EQ(q.gamma(), 0.5f);
  EXPECT_EQ(q.her_strategy(), msg::HER_FUTURE);
  EXPECT_EQ(q.her_ratio(), 0.25f);
  EXPECT_EQ(q.goal_mask(), (std::vector<float>{1, 0}));
  EXPECT_EQ(q.target_offset(), 9u);
  EXPECT_EQ(q.goal_epsilon(), 0.1f);
  EXPECT_EQ(q.goal_norm(), msg::GOAL_NORM_L1);
  EXPECT_EQ(q.features(), (std::vector<uint16_t>{4, 1}));
  EXPECT_EQ(q.step_reward(), -2.0f);
  EXPECT_EQ(q.success_reward(), 3.0f);
  EXPECT_EQ(q.interaction_reward(), 1.0f);
  EXPECT_TRUE(q.require_interaction());
  EXPECT_TRUE(q.terminate_on_interaction());
}

TEST(SampleSource, BatchViewAppendsTheGoal) {
  msg::SampleReply a = Reply(0, 2, 0);
  SampleColumns c;
  std::vector<ShardReply> replies{{&a, 3}};
  ASSERT_TRUE(MergeReplies(replies, &c).ok());
  rl::Batch b;
  ColumnsToBatch(c, &b);
  ASSERT_EQ(b.obs.rows(), 4);
  ASSERT_EQ(b.size(), 2);
  EXPECT_EQ(b.obs(0, 1), 1.0f);
  EXPECT_EQ(b.obs(2, 1), 20.0f);
  EXPECT_EQ(b.obs(3, 1), -1.0f);  // the goal
  EXPECT_EQ(b.next_obs(2, 1), 21.0f);
  EXPECT_EQ(b.next_obs(3, 1), -1.0f);  // the same goal
  EXPECT_EQ(b.actions(0, 1), 1.0f);
  EXPECT_EQ(b.rewards(0, 1), 0.5f);
  EXPECT_EQ(b.discounts(0, 0), 0.9f);
  EXPECT_EQ(b.keys[1], SampleKey(3, 101));
}

}  // namespace
}  // namespace coins
