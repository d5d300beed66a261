// System tests of the replay service: real coins-actor and coins-replay processes, a sampling
// client over DDS, the rate limiter across processes, and malformed input.
#include <cmath>
#include <fstream>
#include <functional>
#include <iterator>
#include <set>
#include <sstream>

#include "common/dds/qos.h"
#include "common/transition_batch.h"
#include "idl/samplingPubSubTypes.h"
#include "idl/transitionPubSubTypes.h"
#include "replay/sampling_topics.h"
#include "tests/replay/replay_cluster.h"

namespace coins {
namespace {

using namespace coins::testing;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

// a raw transition writer to shard 0 of c, matched (c's one shard started)
Result<dds::Writer<msg::TransitionBatch>> StartOneShardWithWriter(ReplayCluster& c) {
  c.shards_n = 1;
  c.StartShards();
  c.Join();
  DdsOptions dds;
  dds.domain = c.domain;
  auto writer = c.node->MakeWriter<msg::TransitionBatchPubSubType>(dds::kTransitionTopic, dds::TransitionWriterQos(dds),
                                                                   dds::ShardPartition(0));
  if (writer.ok() && !WaitUntil([&] { return writer->matched() > 0; }, 20s))
    return Errorf("the writer matched no shard in 20 s");
  return writer;
}

// one segment of `rows` rows with state_dim features: feature 0 of row r is first(r), the
// others are 1, 2, ...
std::unique_ptr<TransitionBatch> SegmentBatch(const BatchHeader& header, uint32_t rows,
                                              const std::function<float(uint32_t)>& first) {
  auto b = std::make_unique<TransitionBatch>();
  BatchBuilder builder;
  builder.Begin(b.get(), header, rows);
  std::vector<float> s(header.state_dim);
  const float a[1] = {0};
  for (uint32_t r = 0; r < rows; ++r) {
    for (uint32_t j = 0; j < header.state_dim; ++j) s[j] = j == 0 ? first(r) : float(j);
    builder.AddRow(s, a, {}, 1.0f, r == 0 ? msg::ROW_SEGMENT_START : 0, 0, 0);
  }
  builder.Finish();
  return b;
}

TEST(ReplayService, ActorsToTwoShardsToASamplingClient) {
  ReplayCluster c{TempDir("replay-sampling"), TestDomain(31)};
  c.StartShards();
  const int64_t steps = 15000;
  c.StartActors(steps);
  c.Join();
  for (auto& a : c.actors) {
    ASSERT_TRUE(a.WaitFor(Scaled(90s))) << a.name() << " did not finish";
    ASSERT_TRUE(a.succeeded()) << a.name() << " " << a.Describe();
  }
  ASSERT_TRUE(WaitUntil([&] { return c.Stats(0).size() > 0 && c.Stats(1).size() > 0; }, 20s));

  ReplayClientOptions o;
  o.gamma = 0.9f;
  o.n_step = 3;
  o.timeout = 5s;
  auto client = c.Client(o);
  ASSERT_TRUE(client->WaitForShards(Scaled(20s)));
  rl::Batch batch;
  int batches = 0;  // batches of 256 the shards served together
  // uniform, n-step: both shards contribute in proportion to their sizes
  for (int round = 0; round < 3; ++round, ++batches) {
    Status s = client->Sample(256, &batch);
    ASSERT_TRUE(s.ok()) << s.message();
  }
  ASSERT_EQ(batch.size(), 256);
  std::map<uint32_t, int> per_shard;
  for (int j = 0; j < 256; ++j) {
    per_shard[ReplayClient::KeyShard(batch.keys[size_t(j)])]++;
    ASSERT_TRUE(std::isfinite(batch.rewards(0, j)));
    float d = batch.discounts(0, j);
    EXPECT_TRUE(d == 0 || std::abs(d - 0.9f) < 1e-5 || std::abs(d - 0.81f) < 1e-5 || std::abs(d - 0.729f) < 1e-5)
        << "discount " << d << " reward " << batch.rewards(0, j);
    EXPECT_EQ(batch.weights(0, j), 1.0f);
    EXPECT_NE((batch.obs.col(j) - batch.next_obs.col(j)).norm(), -1.0f);
  }
  ASSERT_EQ(per_shard.size(), 2u);
  EXPECT_NEAR(per_shard[0], 128, 20);  // equal actors, equal shards

  // prioritised: raise a handful of keys, they dominate the next batches
  client->options().strategy = msg::SAMPLE_PRIORITIZED;
  client->options().n_step = 1;
  ASSERT_TRUE(client->Sample(256, &batch).ok());
  ++batches;
  // four keys from each shard (each shard samples its share from its own priorities)
  std::vector<uint64_t> hot;
  for (uint32_t k = 0; k < 2; ++k)
    for (size_t j = 0, n = 0; j < batch.keys.size() && n < 4; ++j)
      if (ReplayClient::KeyShard(batch.keys[j]) == k) hot.push_back(batch.keys[j]), ++n;
  ASSERT_EQ(hot.size(), 8u);
  std::vector<float> high(8, 1e9f);  // 1e9^0.6 each: far above the ~15k unit masses per shard
  client->UpdatePriorities(hot, high);
  std::set<uint64_t> hot_set(hot.begin(), hot.end());
  int hits = 0;
  ASSERT_TRUE(WaitUntil(
      [&] {
        if (!client->Sample(256, &batch).ok()) return false;
        ++batches;
        hits = 0;
        for (uint64_t k : batch.keys) hits += hot_set.count(k);
        return hits > 200;
      },
      10s))
      << "priority updates did not take effect (" << hits << " hot samples)";
  for (int j = 0; j < 256; ++j)
    if (!hot_set.count(batch.keys[size_t(j)])) {
      EXPECT_FLOAT_EQ(batch.weights(0, j), 1.0f);
    }

  // hindsight: goals relabelled from the segment, rewards recomputed for them
  client->options().strategy = msg::SAMPLE_UNIFORM;
  client->options().her_strategy = msg::HER_FUTURE;
  client->options().her_ratio = 1.0f;
  client->options().goal_mask = {1.0f, 1.0f};
  client->options().target_offset = 0;
  client->options().goal_epsilon = 0.5f;
  Status s = client->Sample(256, &batch);
  ASSERT_TRUE(s.ok()) << s.message();
  ++batches;
  const int S = int(batch.obs.rows()) - 2;
  int reached = 0;
  for (int j = 0; j < 256; ++j) {
    float dist = std::max(std::abs(batch.next_obs(0, j) - batch.obs(S, j)),
                          std::abs(batch.next_obs(1, j) - batch.obs(S + 1, j)));
    bool hit = dist <= 0.5f;
    reached += hit;
    EXPECT_EQ(batch.rewards(0, j), hit ? 0.0f : -1.0f) << "sample " << j;
    if (hit) {
      EXPECT_EQ(batch.discounts(0, j), 0.0f);
    }
  }
  EXPECT_GT(reached, 0);

  // exactly once, and the stored bytes hash to what the actors sent
  StopAll(c.shards, 10s);
  int64_t served = 0;
  for (int i = 0; i < 2; ++i) {
    auto actor = ReadJson(c.dir / ("actor-" + std::to_string(i) + ".json"));
    auto shard = ReadJson(c.dir / ("replay-" + std::to_string(i) + ".json"));
    ASSERT_FALSE(actor.is_null());
    ASSERT_FALSE(shard.is_null());
    ASSERT_EQ(shard["actors"].size(), 1u);
    const auto& ledger = shard["actors"][0];
    EXPECT_EQ(ledger["transitions"], actor["transitions_published"]);
    EXPECT_EQ(ledger["payload_checksum"], actor["payload_checksum"]);
    EXPECT_EQ(ledger["stored_checksum"], actor["payload_checksum"]);
    EXPECT_EQ(ledger["stored_transitions"], actor["transitions_published"]);
    EXPECT_EQ(shard["duplicates"], 0);
    EXPECT_EQ(shard["gaps"], 0);
    EXPECT_GT(shard["samples_served"].get<int64_t>(), 0);
    served += shard["samples_served"].get<int64_t>();
  }
  // every row of every batch came from a shard (a shard may have served a request whose
  // other half timed out, so at least)
  EXPECT_GE(served, 256 * batches);
}

TEST(ReplayService, RateLimiterBlocksWithinOneTimeoutAndReleasesWithinAnother) {
  // a configuration that could deadlock is refused before anything starts
  auto refused = RunCommand(Bin("coins-replay") +
                            " --quiet-config --set replay.samples_per_insert=2 --set replay.error_buffer=10");
  EXPECT_EQ(refused.code, 2) << refused.output;
  EXPECT_NE(refused.output.find("would deadlock"), std::string::npos) << refused.output;

  ReplayCluster c{TempDir("replay-rate"), TestDomain(32)};
  c.shards_n = 1;
  c.actors_n = 1;
  c.StartShards({"--set", "replay.min_size=3000"});
  c.Join();
  // one timeout: 4 rounds of 500 ms, in each the shard waits 3/4 of it for its limiter
  ReplayClientOptions o;
  o.timeout = 2s;
  auto client = c.Client(o);
  ASSERT_TRUE(client->WaitForShards(Scaled(20s)));
  rl::Batch batch;
  auto t0 = Clock::now();
  Status s = client->Sample(64, &batch);
  auto blocked = Clock::now() - t0;
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("rate limiter"), std::string::npos) << s.message();
  // four waits of 375 ms make 1.5 s; a loaded machine once measured 0.4 ms short of that exact
  // sum, so the bound leaves a little room
  EXPECT_GE(blocked, 1400ms);
  EXPECT_LT(blocked, 3s);

  // data arrives: a waiting request is released within the second timeout
  c.StartActors(0);
  client->options().timeout = 30s;
  auto t1 = Clock::now();
  s = client->Sample(64, &batch);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_LT(Clock::now() - t1, 25s);
  EXPECT_GE(client->shard_sizes()[0], 3000u);
  EXPECT_GT(c.Stats(0).rate_limited() + 1, 0u);
}

// SIGSTOP to a child and waits until the kernel shows it stopped (on a loaded machine the signal
// can land after the next request was already answered)
void StopAndWait(const ChildProcess& child) {
  child.Signal(SIGSTOP);
  const std::string stat = "/proc/" + std::to_string(child.pid()) + "/stat";
  ASSERT_TRUE(WaitUntil(
      [&] {
        const std::string text = ReadText(stat);
        const size_t paren = text.rfind(')');
        return paren != std::string::npos && paren + 2 < text.size() && text[paren + 2] == 'T';
      },
      5s))
      << "the shard did not stop";
}

// a shard that stops answering (here SIGSTOP: alive, matched, silent) is sampled around: the
// client takes its share from the other shard at full rate, takes it back once it answers again,
// and fails, naming it, only when it stays silent for longer than shard_wait. A shard that
// missed the client's very first call (its size never heard) is taken back too.
TEST(ReplayService, ASilentShardIsSampledAroundTakenBackAndFailsTheClientOnlyAfterShardWait) {
  ReplayCluster c{TempDir("replay-silent"), TestDomain()};
  c.StartShards();
  c.StartActors(2000);
  c.Join();
  ASSERT_TRUE(WaitUntil([&] { return c.Stats(0).size() >= 1000 && c.Stats(1).size() >= 1000; }, 60s));
  ReplayClientOptions o;
  o.timeout = 2s;
  o.shard_wait = 4s;
  auto client = c.Client(o);
  ASSERT_TRUE(client->WaitForShards(Scaled(20s)));
  rl::Batch batch;
  auto sampled_shards = [&] {
    std::set<uint32_t> s;
    for (uint64_t key : batch.keys) s.insert(ReplayClient::KeyShard(key));
    return s;
  };
  // shard 0 misses the first call (on a loaded machine its first reply can simply be late): the
  // call is served by shard 1, and shard 0 is sampled again once it answers, its size unknown
  // until then
  StopAndWait(c.shards[0]);
  Status first = client->Sample(64, &batch);
  ASSERT_TRUE(first.ok()) << first.message();
  EXPECT_EQ(sampled_shards(), std::set<uint32_t>{1});
  EXPECT_EQ(client->shard_sizes()[0], 0u);
  c.shards[0].Signal(SIGCONT);
  ASSERT_TRUE(WaitUntil([&] { return client->Sample(64, &batch).ok() && sampled_shards().size() == 2; }, 10s))
      << "shard 0 was never sampled after it came back (sizes " << client->shard_sizes()[0] << ", "
      << client->shard_sizes()[1] << ")";

  // the first batch waits one round (500 ms) for shard 0, the next ones do not wait for it
  StopAndWait(c.shards[0]);
  auto t0 = Clock::now();
  Status s = client->Sample(64, &batch);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(sampled_shards(), std::set<uint32_t>{1});
  EXPECT_LT(Clock::now() - t0, 1500ms);
  t0 = Clock::now();
  for (int i = 0; i < 20; ++i) ASSERT_TRUE(client->Sample(64, &batch).ok());
  EXPECT_LT(Clock::now() - t0, 2s);
  EXPECT_EQ(sampled_shards(), std::set<uint32_t>{1});

  c.shards[0].Signal(SIGCONT);
  EXPECT_TRUE(WaitUntil([&] { return client->Sample(64, &batch).ok() && sampled_shards().count(0); }, 10s));

  StopAndWait(c.shards[0]);
  const auto stopped = Clock::now();
  ASSERT_TRUE(WaitUntil([&] { return !(s = client->Sample(64, &batch)).ok(); }, 20s));
  EXPECT_GE(Clock::now() - stopped, 4s);
  EXPECT_NE(s.message().find("shard 0 has not answered for"), std::string::npos) << s.message();
  c.shards[0].Signal(SIGCONT);
}

// malformed batches (wrong sizes, NaN, unknown schema) and requests are rejected and counted,
// and the shard keeps storing and serving
TEST(ReplayService, MalformedBatchesAndRequestsAreRejectedAndCounted) {
  ReplayCluster c{TempDir("replay-malformed"), TestDomain(33)};
  auto writer = StartOneShardWithWriter(c);
  ASSERT_TRUE(writer.ok()) << writer.status().message();
  auto make = [](uint64_t seq) {
    const BatchHeader h{.actor_id = 9,
                        .incarnation = 5,
                        .seq = seq,
                        .layout_hash = LayoutHash("m", 3, 1, 0),
                        .state_dim = 3,
                        .action_dim = 1};
    return SegmentBatch(h, 16, [&](uint32_t r) { return float(seq * 100 + r); });
  };
  auto wrong_size = make(0);
  wrong_size->flags().pop_back();
  auto nan = make(0);
  nan->reward()[3] = std::nanf("");
  auto schema = make(0);
  schema->schema_version(99);
  for (auto* b : {wrong_size.get(), nan.get(), schema.get()}) ASSERT_TRUE(writer->Write(*b));
  uint64_t sent = 0;
  for (uint64_t seq = 0; seq < 3; ++seq) {
    auto b = make(seq);
    sent += b->payload_hash();
    ASSERT_TRUE(writer->Write(*b));
  }
  ASSERT_TRUE(writer->WaitAcked(10s));

  // malformed requests are answered BAD_REQUEST, then a good one is served
  auto requests =
      c.node->MakeWriter<msg::SampleRequestPubSubType>(dds::kSampleRequestTopic, dds::SamplingWriterQos(16));
  auto replies = c.node->MakeReader<msg::SampleReplyPubSubType>(dds::kSampleReplyTopic, dds::SamplingReaderQos(16));
  ASSERT_TRUE(requests.ok() && replies.ok());
  ASSERT_TRUE(WaitUntil([&] { return requests->matched() > 0; }, 20s));
  std::map<uint64_t, msg::SampleReply> got;
  auto ask = [&](uint64_t id, uint32_t schema_version, uint32_t batch) {
    msg::SampleRequest q;
    q.schema_version(schema_version);
    q.correlation_id(id);
    q.shard_id(-1);
    q.batch_size(batch);
    q.n_step(1);
    q.gamma(0.5f);
    q.skill_level(-1);
    q.timeout_ms(1000);
    ASSERT_TRUE(requests->Write(q));
  };
  ask(1, 77, 8);
  ask(2, msg::SAMPLING_SCHEMA, 0);
  ask(3, msg::SAMPLING_SCHEMA, 8);
  ASSERT_TRUE(WaitUntil(
      [&] {
        replies->TakeAll([&](const msg::SampleReply& r, const auto&) { got[r.correlation_id()] = r; });
        return got.size() == 3;
      },
      20s));
  EXPECT_EQ(got[1].status(), msg::SAMPLE_BAD_REQUEST);
  EXPECT_NE(got[1].error().find("schema_version 77"), std::string::npos) << got[1].error();
  EXPECT_EQ(got[2].status(), msg::SAMPLE_BAD_REQUEST);
  EXPECT_NE(got[2].error().find("batch_size 0"), std::string::npos) << got[2].error();
  ASSERT_EQ(got[3].status(), msg::SAMPLE_OK) << got[3].error();
  for (uint32_t i = 0; i < 8; ++i) {
    // sampled values are what was sent: next state counts one past the state, reward 1
    float s0 = got[3].state()[i * 3];
    EXPECT_EQ(got[3].reward()[i], 1.0f);
    ASSERT_GE(got[3].next_end()[i], 1u);
    EXPECT_EQ(got[3].next_value()[i ? got[3].next_end()[i - 1] : 0], s0 + 1);
  }

  StopAll(c.shards, 10s);
  ASSERT_TRUE(c.shards[0].succeeded()) << c.shards[0].Describe();
  auto shard = ReadJson(c.dir / "replay-0.json");
  ASSERT_FALSE(shard.is_null());
  EXPECT_EQ(shard["rejected"], 3);
  EXPECT_EQ(shard["inserted_batches"], 3);
  EXPECT_EQ(shard["bad_requests"], 2);
  EXPECT_EQ(shard["actors"][0]["stored_checksum"], sent);
}

// one batch numbered far ahead of its actor's stream (a bug, or a forged copy) on the wire
// between genuine ones: the shard holds it, counts the jump, and stores every genuine batch
TEST(ReplayService, OneBatchFarAheadDoesNotPoisonTheActorsLaterBatches) {
  ReplayCluster c{TempDir("replay-forged"), TestDomain()};
  auto writer = StartOneShardWithWriter(c);
  ASSERT_TRUE(writer.ok()) << writer.status().message();
  auto make = [](uint64_t seq) {
    const BatchHeader h{.actor_id = 3,
                        .incarnation = 77,
                        .seq = seq,
                        .layout_hash = LayoutHash("f", 2, 1, 0),
                        .state_dim = 2,
                        .action_dim = 1};
    return SegmentBatch(h, 8, [&](uint32_t r) { return float(seq % 1000 + r); });
  };
  uint64_t sent = 0;
  const uint64_t n = 400;
  // a full writer history times a write out (the shard acknowledges slowly on a loaded machine):
  // the same batch is written again, as an actor does
  auto write = [&](const TransitionBatch& b) { return WaitUntil([&] { return writer->Write(b); }, 20s); };
  for (uint64_t seq = 0; seq < n; ++seq) {
    if (seq == 100) {
      ASSERT_TRUE(write(*make(4'000'000'000ull)));  // well formed, its hash intact
    }
    auto b = make(seq);
    sent += b->payload_hash();
    ASSERT_TRUE(write(*b));
  }
  ASSERT_TRUE(writer->WaitAcked(20s));
  StopAll(c.shards, 20s);
  ASSERT_TRUE(c.shards[0].succeeded()) << c.shards[0].Describe();
  auto shard = ReadJson(c.dir / "replay-0.json");
  ASSERT_FALSE(shard.is_null());
  ASSERT_EQ(shard["actors"].size(), 1u);
  const auto& a = shard["actors"][0];
  EXPECT_EQ(a["batches"], n);
  EXPECT_EQ(a["transitions"], n * 7);
  EXPECT_EQ(a["next_seq"], n);
  EXPECT_EQ(a["stored_checksum"], sent);
  EXPECT_EQ(a["seq_jumps"], 1);
  EXPECT_EQ(shard["seq_jumps"], 1);
  EXPECT_EQ(shard["duplicates"], 0);
  EXPECT_EQ(shard["gaps"], 0);
  EXPECT_EQ(shard["rejected"], 1);  // the batch far ahead, dropped once the stream went on
  std::ifstream log(c.dir / "replay-0.log");
  std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("sequence number jumps to 4000000000 (expected 100)"), std::string::npos) << text;
  // the log names the writer that sent it
  std::ostringstream writer_guid;
  writer_guid << writer->raw()->guid();
  EXPECT_NE(text.find("(writer " + writer_guid.str() + ")"), std::string::npos) << text;
}

}  // namespace
}  // namespace coins
