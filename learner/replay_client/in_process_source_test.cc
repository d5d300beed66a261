// InProcessSource over ReplayService shards: the full request -> reply -> merge path, shares
// moved from a refusing shard, priority updates routed by key, and the rl::BatchSource view.
#include "learner/replay_client/in_process_source.h"

#include <gtest/gtest.h>

#include "learner/replay_client/test_goal_stream.h"

namespace coins {
namespace {

using testing::CheckGoalSample;
using testing::GoalStream;

std::unique_ptr<ReplayService> Shard(uint32_t id, int64_t min_size = 1) {
  ReplayOptions o;
  o.capacity = 100000;
  o.capacity_mb = 16;
  o.min_size = min_size;
  ResumeReport report;
  auto s = ReplayService::Open(id, o, &report);
  EXPECT_TRUE(s.ok()) << s.status().message();
  return std::move(*s);
}

// shard k holds `batches` batches of GoalStream actor k; returns the newest step
int64_t Fill(ReplayService* service, uint32_t actor, int batches) {
  GoalStream stream(actor);
  for (int i = 0; i < batches; ++i)
    EXPECT_EQ(service->Insert(*stream.Next(64), std::chrono::seconds(1)), ReplayService::InsertResult::kStored);
  return stream.t();
}

TEST(InProcessSource, GoalConditionedFeatureSubsetsMatchTheStream) {
  auto a = Shard(0), b = Shard(1);
  const int64_t last_a = Fill(a.get(), 0, 20), last_b = Fill(b.get(), 1, 10);
  InProcessSource source({a.get(), b.get()});
  SampleColumns c;
  Status s = source.Sample(GoalStream::Spec(), 600, &c);
  ASSERT_TRUE(s.ok()) << s.message();
  ASSERT_EQ(c.n, 600u);
  int per_shard[2] = {0, 0}, relabelled = 0, terminal = 0, level[3] = {0, 0, 0};
  for (uint32_t i = 0; i < c.n; ++i) {
    uint32_t shard = KeyShard(c.key[i]);
    ASSERT_LT(shard, 2u);
    per_shard[shard]++;
    bool r = false;
    std::string why = CheckGoalSample(c, i, shard == 0 ? last_a : last_b, &r);
    ASSERT_EQ(why, "") << "shard " << shard;
    relabelled += r;
    terminal += c.discount[i] == 0;
    level[c.skill_level[i]]++;
  }
  // split by size (about 2:1), about half relabelled, both levels, some successes
  EXPECT_NEAR(per_shard[0], 400, 10);
  EXPECT_GT(relabelled, 150);
  EXPECT_LT(relabelled, 450);
  EXPECT_EQ(level[0], 0);
  EXPECT_GT(level[1], 100);
  EXPECT_GT(level[2], 100);
  EXPECT_GT(terminal, 50);
}

TEST(InProcessSource, RefusedSharesMoveAndErrorsNameTheShards) {
  auto ready = Shard(0), waiting = Shard(1, /*min_size=*/1'000'000);
  Fill(ready.get(), 0, 4);
  Fill(waiting.get(), 1, 4);
  InProcessSource source({ready.get(), waiting.get()}, {.timeout = std::chrono::milliseconds(20)});
  SampleColumns c;
  Status s = source.Sample(GoalStream::Spec(), 100, &c);
  ASSERT_TRUE(s.ok()) << s.message();
  for (uint32_t i = 0; i < c.n; ++i) EXPECT_EQ(KeyShard(c.key[i]), 0u);

  // a request every shard refuses
  SampleSpec bad = GoalStream::Spec();
  bad.features = {1, 99};
  s = source.Sample(bad, 100, &c);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("shard 0: sample request"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("features[1] = 99"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("shard 1: sample request"), std::string::npos) << s.message();
}

TEST(InProcessSource, PriorityUpdatesReachTheKeysShard) {
  auto a = Shard(0), b = Shard(1);
  Fill(a.get(), 0, 8);
  Fill(b.get(), 1, 8);
  InProcessSource source({a.get(), b.get()});
  SampleSpec spec;
  spec.strategy = msg::SAMPLE_PRIORITIZED;
  SampleColumns c;
  ASSERT_TRUE(source.Sample(spec, 64, &c).ok());
  uint64_t hot = 0;
  for (uint64_t k : c.key)
    if (KeyShard(k) == 1) hot = k;
  ASSERT_EQ(KeyShard(hot), 1u);
  const float high[] = {1e9f};
  source.UpdatePriorities(std::span<const uint64_t>(&hot, 1), high);
  ASSERT_TRUE(source.Sample(spec, 400, &c).ok());
  int shard1 = 0, hits = 0;
  for (uint32_t i = 0; i < c.n; ++i)
    if (KeyShard(c.key[i]) == 1) {
      shard1++;
      hits += c.key[i] == hot;
      if (c.key[i] != hot) {
        EXPECT_FLOAT_EQ(c.weight[i], 1.0f);
      }
    }
  EXPECT_GT(shard1, 150);
  EXPECT_GT(hits, shard1 * 9 / 10);
}

TEST(InProcessSource, AsBatchSourceObservationsAreFeaturesThenGoal) {
  auto a = Shard(0);
  const int64_t last = Fill(a.get(), 0, 6);
  InProcessSource source({a.get()});
  SampleBatchSource batches(&source, GoalStream::Spec());
  rl::Batch batch;
  ASSERT_TRUE(batches.Sample(128, &batch).ok());
  ASSERT_EQ(batch.obs.rows(), 5);  // (tx, ty, t) and the 2-float goal
  const SampleColumns& c = batches.last();
  for (int j = 0; j < 128; ++j) {
    bool r;
    ASSERT_EQ(CheckGoalSample(c, uint32_t(j), last, &r), "");
    EXPECT_EQ(batch.obs(2, j), c.state[size_t(j) * 3 + 2]);
    EXPECT_EQ(batch.next_obs(2, j), c.next_state[size_t(j) * 3 + 2]);
    EXPECT_EQ(batch.obs(3, j), c.goal[size_t(j) * 2]);
    EXPECT_EQ(batch.next_obs(4, j), c.goal[size_t(j) * 2 + 1]);
    EXPECT_EQ(batch.rewards(0, j), c.reward[size_t(j)]);
  }
}

}  // namespace
}  // namespace coins
