// System tests of snapshots and resume: `coins snapshot` against running shards, kill -9 of a
// shard during inserts and a restart from its snapshot while the actor keeps running, and
// truncated / bit-flipped snapshot files on disk.
#include <fstream>
#include <iostream>

#include "tests/replay/replay_cluster.h"

namespace coins {
namespace {

using namespace coins::testing;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

nlohmann::json Inspect(ReplayCluster& c, const fs::path& snap) {
  auto r = c.Cli("replay inspect --json " + snap.string());
  auto j = nlohmann::json::parse(r.output, nullptr, false);
  EXPECT_FALSE(j.is_discarded()) << r.output;
  return j;
}

std::vector<fs::path> Snapshots(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".snap") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

TEST(ReplayResume, KillNineDuringInsertsThenResumeFromTheLastSnapshot) {
  ReplayCluster c{TempDir("replay-kill"), TestDomain(41)};
  c.shards_n = 1;
  c.actors_n = 1;
  fs::path snaps = c.dir / "snapshots";
  // room for most of what the actor sends during the test (an unpaced actor on a fast machine
  // can still fill it: the checks below hold either way, the checksums only without eviction)
  std::vector<std::string> flags = {"--set", "replay.snapshot_dir=" + snaps.string(),
                                    "--set", "replay.capacity=3000000",
                                    "--set", "replay.capacity_mb=400"};
  c.StartShards(flags);
  c.StartActors(0);
  c.Join();
  ASSERT_TRUE(WaitUntil([&] { return c.Stats(0).size() > 20000; }, 30s)) << "no data reached the shard";

  // a snapshot on command while the actor keeps inserting
  auto r = c.Cli(fmt::format("snapshot --domain {} --shards 1 --timeout 30", c.domain));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("replay-0: snapshot written"), std::string::npos) << r.output;
  auto files = Snapshots(snaps);
  ASSERT_EQ(files.size(), 1u);
  auto snap = Inspect(c, files.back());
  ASSERT_TRUE(snap["valid"].get<bool>()) << snap.dump();
  const auto& ledger = snap["ledger"][0];
  const uint64_t snap_transitions = ledger["transitions"], snap_checksum = ledger["checksum"];
  const uint64_t snap_held = snap["meta"]["transitions"];  // the ledger's count less what was evicted
  EXPECT_GT(snap_held, 0u);
  EXPECT_LE(snap_held, snap_transitions);

  // kill -9 while inserts go on, then restart on the same directory
  uint64_t before_kill = c.Stats(0).inserted_transitions();
  EXPECT_GT(before_kill, snap_transitions);
  c.shards[0].Signal(SIGKILL);
  ASSERT_TRUE(c.shards[0].WaitFor(Scaled(5s)));
  // restart past the participant lease (dds.lease_s, 4 s), as a supervisor would
  std::this_thread::sleep_for(4500ms);
  c.StartShard(0, flags);
  // the actor resumes by itself (its writer recovers when the stream stalls, see
  // actors/batch_sink.h): the restarted shard stores new batches beyond what it restored
  ASSERT_TRUE(WaitUntil(
      [&] {
        auto s = c.Stats(0);
        return s.restored_transitions() == snap_held && s.inserted_transitions() > snap_transitions + 5000;
      },
      30s))
      << "the actor did not resume publishing: restored " << c.Stats(0).restored_transitions() << " inserted "
      << c.Stats(0).inserted_transitions();
  EXPECT_FALSE(c.actors[0].Poll()) << "the actor died: " << c.actors[0].Describe();

  c.actors[0].Signal(SIGTERM);
  ASSERT_TRUE(c.actors[0].WaitFor(Scaled(30s)));
  EXPECT_TRUE(c.actors[0].succeeded()) << c.actors[0].Describe();
  StopAll(c.shards, 20s);
  ASSERT_TRUE(c.shards[0].succeeded()) << c.shards[0].Describe();
  auto shard = ReadJson(c.dir / "replay-0.json");
  auto actor = ReadJson(c.dir / "actor-0.json");
  ASSERT_FALSE(shard.is_null());
  ASSERT_FALSE(actor.is_null());
  EXPECT_EQ(shard["restored_transitions"], snap_held);
  const auto& a = shard["actors"][0];
  // every stored byte hashes to the ledger: the snapshot's part (snap_checksum) plus what came
  // after (when the actor was fast enough to fill the shard, eviction makes this moot)
  if (a["stored_transitions"] == a["transitions"]) {
    EXPECT_EQ(a["stored_checksum"], a["payload_checksum"]);
  }
  EXPECT_GT(a["transitions"].get<uint64_t>(), snap_transitions);
  EXPECT_NE(a["payload_checksum"].get<uint64_t>(), snap_checksum);
  // what the shard lost between its snapshot and its restart shows up as gaps, never twice; the
  // batches the actor resent after its recovery that the shard held already are duplicates
  EXPECT_LE(shard["duplicates"].get<uint64_t>(), 256u);  // dds.transition_history
  EXPECT_GT(shard["gaps"].get<uint64_t>(), 0u);
  EXPECT_EQ(a["next_seq"], actor["batches"]);
  EXPECT_LT(a["transitions"].get<uint64_t>(), actor["transitions_published"].get<uint64_t>());
  const uint64_t final_transitions = a["stored_transitions"], final_checksum = a["stored_checksum"];

  // the clean stop wrote a final snapshot: a shard started on it alone (no actor) holds exactly
  // what the stopped shard held
  fs::remove(c.dir / "replay-0.json");
  auto listening = [&] {
    std::ifstream log(c.dir / "replay-0.log");
    std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
    return text.rfind("listening on partition") != std::string::npos &&
           text.rfind("listening on partition") > text.rfind("resumed ");
  };
  auto restart_alone = [&] {
    c.StartShard(0, flags);
    EXPECT_TRUE(WaitUntil(listening, 30s)) << "the shard did not come up";
    StopAll(c.shards, 20s);
    auto j = ReadJson(c.dir / "replay-0.json");
    fs::remove(c.dir / "replay-0.json");
    return j;
  };
  auto last = restart_alone();
  ASSERT_FALSE(last.is_null());
  EXPECT_EQ(last["restored_transitions"], final_transitions);
  EXPECT_EQ(last["actors"][0]["stored_checksum"], final_checksum);

  // the snapshot taken on command holds every transition up to it (less what was evicted): a
  // shard started on it alone recomputes the per-actor checksum of its stored bytes and, without
  // eviction, finds the snapshot's ledger
  for (const auto& f : Snapshots(snaps))
    if (f != files.back()) fs::remove(f);
  auto again = restart_alone();
  ASSERT_FALSE(again.is_null());
  EXPECT_EQ(again["restored_transitions"], snap_held);
  EXPECT_EQ(again["actors"][0]["stored_transitions"], snap_held);
  EXPECT_EQ(again["actors"][0]["payload_checksum"], snap_checksum);
  if (snap_held == snap_transitions) {
    EXPECT_EQ(again["actors"][0]["stored_checksum"], snap_checksum);
  }
}

TEST(ReplayResume, TruncatedAndBitFlippedSnapshotsAreReportedAndThePreviousOneUsed) {
  ReplayCluster c{TempDir("replay-corrupt"), TestDomain(42)};
  c.shards_n = 1;
  c.actors_n = 1;
  fs::path snaps = c.dir / "snapshots";
  // only the snapshots taken on command, none at each stop
  std::vector<std::string> flags = {"--set", "replay.snapshot_dir=" + snaps.string(), "--set",
                                    "replay.snapshot_on_stop=false"};
  c.StartShards(flags);
  c.StartActors(30000);
  c.Join();
  ASSERT_TRUE(WaitUntil([&] { return c.Stats(0).size() > 5000; }, 30s));
  ASSERT_EQ(c.Cli(fmt::format("snapshot --domain {} --shards 1", c.domain)).code, 0);
  ASSERT_TRUE(c.actors[0].WaitFor(Scaled(60s)));
  ASSERT_EQ(c.Cli(fmt::format("snapshot --domain {} --shards 1", c.domain)).code, 0);
  StopAll(c.shards, 10s);
  auto files = Snapshots(snaps);
  ASSERT_EQ(files.size(), 2u);
  auto older = Inspect(c, files[0]);
  const uint64_t older_transitions = older["meta"]["transitions"];

  // truncate the newest: inspect says so (exit 1), the shard resumes from the older one
  fs::resize_file(files[1], fs::file_size(files[1]) - 1000);
  auto r = c.Cli("replay inspect " + files[1].string());
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.output.find("truncated"), std::string::npos) << r.output;
  auto run_once = [&] {
    c.StartShard(0, flags);
    std::this_thread::sleep_for(1500ms);
    StopAll(c.shards, 10s);
    return ReadJson(c.dir / "replay-0.json");
  };
  auto shard = run_once();
  EXPECT_EQ(shard["corrupt_snapshots"], 1);
  EXPECT_EQ(shard["restored_transitions"], older_transitions);
  EXPECT_EQ(shard["actors"][0]["stored_checksum"], older["ledger"][0]["checksum"]);

  // one flipped bit in the older one too: both are skipped, the shard starts empty
  {
    std::fstream f(files[0], std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(5000);
    char ch;
    f.get(ch);
    f.seekp(5000);
    f.put(char(ch ^ 0x04));
  }
  r = c.Cli("replay inspect " + files[0].string());
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.output.find("fails its checksum"), std::string::npos) << r.output;
  shard = run_once();
  EXPECT_EQ(shard["corrupt_snapshots"], 2);
  EXPECT_EQ(shard["restored_transitions"], 0);
  EXPECT_EQ(shard["size"], 0);
}

TEST(ReplayResume, PeriodicSnapshotsAreWrittenAndPruned) {
  ReplayCluster c{TempDir("replay-periodic"), TestDomain(43)};
  c.shards_n = 1;
  c.actors_n = 1;
  fs::path snaps = c.dir / "snapshots";
  c.StartShards({"--set", "replay.snapshot_dir=" + snaps.string(), "--set", "replay.snapshot_period_s=0.4", "--set",
                 "replay.snapshot_keep=2"});
  c.StartActors(0);
  c.Join();
  ASSERT_TRUE(WaitUntil([&] { return c.Stats(0).snapshots_written() >= 4; }, 30s))
      << "snapshots written: " << c.Stats(0).snapshots_written();
  StopAll(c.actors, 10s);
  StopAll(c.shards, 10s);
  auto files = Snapshots(snaps);
  ASSERT_EQ(files.size(), 2u);  // replay.snapshot_keep
  for (const auto& f : files) {
    auto j = Inspect(c, f);
    EXPECT_TRUE(j["valid"].get<bool>()) << j.dump();
    EXPECT_GT(j["meta"]["transitions"].get<uint64_t>(), 0u);
  }
  auto shard = ReadJson(c.dir / "replay-0.json");
  EXPECT_EQ(shard["snapshot_failures"], 0);
}

TEST(ReplayResume, ACleanStopWritesAFinalSnapshotThatARestartRestores) {
  ReplayCluster c{TempDir("replay-final"), TestDomain()};
  c.shards_n = 1;
  c.actors_n = 1;
  fs::path snaps = c.dir / "snapshots";
  // no periodic snapshot and none on command: only the one a clean stop writes
  std::vector<std::string> flags = {"--set", "replay.snapshot_dir=" + snaps.string()};
  c.StartShards(flags);
  c.StartActors(100000);
  ASSERT_TRUE(c.actors[0].WaitFor(Scaled(120s)));
  ASSERT_TRUE(c.actors[0].succeeded()) << c.actors[0].Describe();
  StopAll(c.shards, 20s);
  ASSERT_TRUE(c.shards[0].succeeded()) << c.shards[0].Describe();
  auto actor = ReadJson(c.dir / "actor-0.json");
  auto first = ReadJson(c.dir / "replay-0.json");
  ASSERT_FALSE(actor.is_null());
  ASSERT_FALSE(first.is_null());
  ASSERT_EQ(first["actors"][0]["transitions"], 100000);
  ASSERT_EQ(Snapshots(snaps).size(), 1u) << "no final snapshot";

  // a restart restores all 100,000, and their stored bytes hash to what the actor sent
  fs::remove(c.dir / "replay-0.json");
  c.StartShard(0, flags);
  std::this_thread::sleep_for(1500ms);
  StopAll(c.shards, 20s);
  auto second = ReadJson(c.dir / "replay-0.json");
  ASSERT_FALSE(second.is_null());
  EXPECT_EQ(second["restored_transitions"], 100000);
  EXPECT_EQ(second["actors"][0]["stored_transitions"], 100000);
  EXPECT_EQ(second["actors"][0]["stored_checksum"], actor["payload_checksum"]);
  EXPECT_EQ(second["actors"][0]["next_seq"], actor["batches"]);
}

// kill -9 of the shard while the actor publishes, and an immediate restart (or one past the
// participant lease), 20 times: each time the actor resumes publishing by itself. Two Fast DDS
// 2.9 faults made it stop after a few kills: a restarted shard that took the killed one's
// shared-memory port went unheard (common/dds/participant_ids.h), and replacing a stalled writer
// could hang in its destructor (common/dds/node.cc)
TEST(ReplayResume, TheActorResumesByItselfAfterEveryShardKill) {
  ReplayCluster c{TempDir("replay-kills"), TestDomain()};
  c.shards_n = 1;
  c.actors_n = 1;
  c.StartShards();
  c.StartActors(0);
  c.Join();
  ASSERT_TRUE(WaitUntil([&] { return c.Stats(0).inserted_transitions() > 5000; }, 30s));
  const int kills = 20;
  int recovered = 0;
  std::string failures;
  for (int k = 0; k < kills; ++k) {
    c.shards[0].Signal(SIGKILL);
    ASSERT_TRUE(c.shards[0].WaitFor(Scaled(5s)));
    if (k % 4 == 3) std::this_thread::sleep_for(4500ms);  // past the lease now and then
    c.StartShard(0);
    // the new shard's own count: it starts from nothing
    auto t0 = std::chrono::steady_clock::now();
    bool ok = WaitUntil(
        [&] {
          auto v = c.collector->Snapshot();
          auto it = v.shards.find(0);
          return it != v.shards.end() && it->second.received > t0 + 300ms &&
                 it->second.sample.inserted_transitions() > 2000;
        },
        25s);
    recovered += ok;
    if (!ok) failures += fmt::format(" kill {}", k + 1);
    ASSERT_FALSE(c.actors[0].Poll()) << "the actor died: " << c.actors[0].Describe();
  }
  EXPECT_EQ(recovered, kills) << "not resumed after" << failures;

  // a clean stop after the last restart: the shard holds the actor's stream up to its end
  c.actors[0].Signal(SIGTERM);
  ASSERT_TRUE(c.actors[0].WaitFor(Scaled(30s)));
  EXPECT_TRUE(c.actors[0].succeeded()) << c.actors[0].Describe();
  StopAll(c.shards, 20s);
  auto shard = ReadJson(c.dir / "replay-0.json");
  auto actor = ReadJson(c.dir / "actor-0.json");
  ASSERT_FALSE(shard.is_null());
  ASSERT_FALSE(actor.is_null());
  EXPECT_EQ(shard["actors"][0]["next_seq"], actor["batches"]);
  if (shard["actors"][0]["stored_transitions"] == shard["actors"][0]["transitions"]) {
    EXPECT_EQ(shard["actors"][0]["stored_checksum"], shard["actors"][0]["payload_checksum"]);
  }
}

}  // namespace
}  // namespace coins
