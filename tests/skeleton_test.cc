// System tests of the walking skeleton: real coins-actor and coins-replay processes exchanging
// Breakout transitions over Fast DDS on loopback.
#include <signal.h>

#include <gtest/gtest.h>

#include "tests/replay/replay_cluster.h"

namespace coins {
namespace {

using namespace coins::testing;

TEST(Skeleton, EveryTransitionSentIsStoredExactlyOnce) {
  ReplayCluster c{TempDir("exactly-once"), TestDomain(1)};
  c.StartShards();
  const int64_t steps = 20000;
  c.StartActors(steps);
  for (auto& a : c.actors) {
    ASSERT_TRUE(a.WaitFor(Scaled(std::chrono::seconds(90)))) << a.name() << " did not finish";
    ASSERT_TRUE(a.succeeded()) << a.name() << " " << a.Describe();
  }
  // actors wait for acknowledgements before exiting; shards drain their reader on SIGTERM
  StopAll(c.shards, std::chrono::seconds(10));
  for (auto& s : c.shards) ASSERT_TRUE(s.succeeded()) << s.name() << " " << s.Describe();

  for (int i = 0; i < 2; ++i) {
    auto actor = ReadJson(c.dir / ("actor-" + std::to_string(i) + ".json"));
    auto shard = ReadJson(c.dir / ("replay-" + std::to_string(i % 2) + ".json"));
    ASSERT_FALSE(actor.is_null());
    ASSERT_FALSE(shard.is_null());
    EXPECT_EQ(actor["steps"], steps);
    EXPECT_EQ(actor["transitions_published"], steps);
    EXPECT_EQ(shard["duplicates"], 0);
    EXPECT_EQ(shard["gaps"], 0);
    EXPECT_EQ(shard["rejected"], 0);
    ASSERT_EQ(shard["actors"].size(), 1u) << "shard " << i % 2 << " got batches from a foreign actor";
    const auto& ledger = shard["actors"][0];
    EXPECT_EQ(ledger["actor_id"], i);
    EXPECT_EQ(ledger["transitions"], actor["transitions_published"]);
    EXPECT_EQ(ledger["batches"], actor["batches"]);
    // the stored copies hash to what the actor sent
    EXPECT_EQ(ledger["payload_checksum"], actor["payload_checksum"]);
    EXPECT_EQ(ledger["next_seq"], actor["batches"]);
  }
}

TEST(Skeleton, KillingOneActorLeavesTheRestExchangingData) {
  ReplayCluster c{TempDir("kill-actor"), TestDomain(2)};
  c.StartShards();
  c.StartActors(0);
  c.Join();

  auto stored_from = [&](uint32_t shard, uint32_t actor) -> uint64_t {
    msg::ReplayStats stats = c.Stats(shard);
    for (const auto& a : stats.actors())
      if (a.actor_id() == actor) return a.transitions();
    return 0;
  };
  ASSERT_TRUE(WaitUntil([&] { return stored_from(0, 0) > 0 && stored_from(1, 1) > 0; }, std::chrono::seconds(30)))
      << "shards never reported data from both actors";

  c.actors[0].Signal(SIGKILL);
  ASSERT_TRUE(c.actors[0].WaitFor(Scaled(std::chrono::seconds(5))));
  // past the participant lease, the survivors must still be alive and moving data
  std::this_thread::sleep_for(std::chrono::seconds(5));
  uint64_t before = stored_from(1, 1);
  uint64_t dead_before = stored_from(0, 0);
  std::this_thread::sleep_for(std::chrono::seconds(2));
  EXPECT_GT(stored_from(1, 1), before + 1000) << "actor-1 -> replay-1 stopped flowing";
  EXPECT_EQ(stored_from(0, 0), dead_before) << "data from the killed actor kept arriving";
  for (auto* p : {&c.actors[1], &c.shards[0], &c.shards[1]})
    EXPECT_FALSE(p->Poll()) << p->name() << " " << p->Describe();
  StatusView v = c.collector->Snapshot();
  for (const char* name : {"replay-0", "replay-1", "actor-1"}) {
    ASSERT_TRUE(v.heartbeats.count(name)) << name;
    EXPECT_LT(std::chrono::duration<double>(StatusView::Clock::now() - v.heartbeats[name].received).count(), 2.0)
        << name << " went silent";
  }

  // a clean stop of the survivor: its shard holds exactly what it published
  c.actors[1].Signal(SIGTERM);
  ASSERT_TRUE(c.actors[1].WaitFor(Scaled(std::chrono::seconds(20))));
  EXPECT_TRUE(c.actors[1].succeeded()) << c.actors[1].Describe();
  StopAll(c.shards, std::chrono::seconds(10));
  auto actor = ReadJson(c.dir / "actor-1.json");
  auto shard = ReadJson(c.dir / "replay-1.json");
  ASSERT_FALSE(actor.is_null());
  ASSERT_FALSE(shard.is_null());
  // a clean stop publishes the partial batches too: every step taken was published and stored
  EXPECT_EQ(actor["transitions_published"], actor["steps"]);
  EXPECT_EQ(shard["actors"][0]["transitions"], actor["transitions_published"]);
  EXPECT_EQ(shard["actors"][0]["payload_checksum"], actor["payload_checksum"]);
  EXPECT_EQ(shard["duplicates"], 0);
  EXPECT_EQ(shard["rejected"], 0);
}

}  // namespace
}  // namespace coins
