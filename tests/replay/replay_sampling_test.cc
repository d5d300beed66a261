// System test of the sampling fields across processes: a feature-subset, level-masked,
// goal-conditioned n-step request with hindsight round-trips through two real coins-replay
// processes, and every sample matches the stream the test published (learner/replay_client/
// test_goal_stream.h); the prefetcher over the DDS client delivers the same kind of batches.
#include <set>

#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "idl/transitionPubSubTypes.h"
#include "learner/replay_client/prefetcher.h"
#include "learner/replay_client/test_goal_stream.h"
#include "tests/replay/replay_cluster.h"

namespace coins {
namespace {

using namespace coins::testing;
using namespace std::chrono_literals;

// publishes `batches` GoalStream batches of actor k to shard k; returns the newest step
int64_t Publish(ReplayCluster& c, int batches, int64_t* transitions) {
  DdsOptions dds;
  dds.domain = c.domain;
  int64_t last = 0;
  for (int k = 0; k < c.shards_n; ++k) {
    auto w = c.node->MakeWriter<msg::TransitionBatchPubSubType>(dds::kTransitionTopic, dds::TransitionWriterQos(dds),
                                                                dds::ShardPartition(k));
    EXPECT_TRUE(w.ok());
    if (!w.ok()) return 0;
    EXPECT_TRUE(WaitUntil([&] { return w->matched() > 0; }, 20s));
    GoalStream stream{uint32_t(k)};
    transitions[k] = 0;
    for (int i = 0; i < batches; ++i) {
      auto b = stream.Next(64);
      transitions[k] += CountTransitions(*b);
      EXPECT_TRUE(w->Write(*b));
    }
    EXPECT_TRUE(w->WaitAcked(20s));
    last = stream.t();
  }
  return last;
}

void ExpectStreamSamples(const SampleColumns& c, int64_t last_t, int* relabelled) {
  for (uint32_t i = 0; i < c.n; ++i) {
    bool r = false;
    ASSERT_EQ(CheckGoalSample(c, i, last_t, &r), "") << "shard " << KeyShard(c.key[i]);
    *relabelled += r;
  }
}

TEST(ReplaySampling, FeatureSubsetLevelMaskedGoalRequestsRoundTripThroughShards) {
  ReplayCluster c{TempDir("replay-goal-sampling"), TestDomain(51)};
  c.StartShards();
  c.Join();
  int64_t transitions[2];
  const int64_t last_t = Publish(c, 30, transitions);
  ASSERT_TRUE(WaitUntil(
      [&] { return c.Stats(0).size() == uint64_t(transitions[0]) && c.Stats(1).size() == uint64_t(transitions[1]); },
      20s));

  ReplayClientOptions o;
  o.timeout = 5s;
  auto client = c.Client(o);
  ASSERT_TRUE(client->WaitForShards(Scaled(20s)));
  SampleColumns cols;
  Status s;
  // a batch from both shards (on a loaded machine a shard's first reply can miss the client's
  // first round, which then samples the other shard alone)
  auto from_both = [&] {
    std::set<uint32_t> shards;
    for (uint32_t i = 0; i < cols.n; ++i) shards.insert(KeyShard(cols.key[i]));
    return shards.size() == 2;
  };
  ASSERT_TRUE(WaitUntil([&] { return (s = client->Sample(GoalStream::Spec(), 512, &cols)).ok() && from_both(); }, 20s))
      << s.message();
  ASSERT_EQ(cols.n, 512u);
  EXPECT_EQ(cols.state_dim, GoalStream::kStateDim);
  int relabelled = 0;
  ExpectStreamSamples(cols, last_t, &relabelled);
  EXPECT_GT(relabelled, 128);
  EXPECT_LT(relabelled, 384);
  std::set<uint32_t> shards, levels;
  for (uint32_t i = 0; i < cols.n; ++i) {
    shards.insert(KeyShard(cols.key[i]));
    levels.insert(cols.skill_level[i]);
  }
  EXPECT_EQ(shards, (std::set<uint32_t>{0, 1}));
  EXPECT_EQ(levels, (std::set<uint32_t>{1, 2}));
  // what went over the wire is the feature subset: 3 columns a sample, deltas among them
  for (const msg::SampleReply* r : client->last_replies()) {
    EXPECT_EQ(r->feature_dim(), 3u);
    EXPECT_EQ(r->state().size(), size_t(r->n()) * 3);
  }

  // the prefetcher over the DDS client: the same checks, batches sampled ahead
  auto prefetch = PrefetchingSource::Create(client.get(), {.depth = 2});
  ASSERT_TRUE(prefetch.ok());
  relabelled = 0;
  for (int round = 0; round < 5; ++round) {
    s = (*prefetch)->Sample(GoalStream::Spec(), 256, &cols);
    ASSERT_TRUE(s.ok()) << s.message();
    ExpectStreamSamples(cols, last_t, &relabelled);
    std::vector<float> priorities(cols.n, 1.0f);
    (*prefetch)->UpdatePriorities(cols.key, priorities);
  }
  EXPECT_EQ((*prefetch)->stats().batches, 5u);
  prefetch->reset();

  // a request a shard refuses names the field
  SampleSpec bad = GoalStream::Spec();
  bad.goal_norm = 9;
  s = client->Sample(bad, 64, &cols);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("unknown goal_norm 9"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace coins
