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
  // room for everything the actor sends during the test: no eviction, so checksums add up
  std::vector<std::string> flags = {"--set", "replay.snapshot_dir=" + snaps.string(), "--set",
                                    "replay.capacity=3000000", "--set", "replay.capacity_mb=400"};
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
  EXPECT_EQ(snap["meta"]["transitions"].get<uint64_t>(), snap_transitions);  // no eviction at this size

  // kill -9 while inserts go on, then restart on the same directory
  uint64_t before_kill = c.Stats(0).inserted_transitions();
  EXPECT_GT(before_kill, snap_transitions);
  c.shards[0].Signal(SIGKILL);
  ASSERT_TRUE(c.shards[0].WaitFor(5s));
  // restart past the participant lease (dds.lease_s, 4 s): the actor's writer has dropped the
  // dead reader by then (an earlier restart sometimes left the actor's writer stalled on it)
  std::this_thread::sleep_for(4500ms);
  c.StartShard(0, flags);
  // the actor reconnects: the restarted shard stores new batches beyond what it restored.
  // Known limit outside the replay service: in some runs the actor's writer stays stalled after
  // its reader was killed over shared memory (Fast DDS 2.9); the actor is then restarted once,
  // as a crashed actor would be, and the shard must take its data.
  auto resumed = [&](std::chrono::seconds within) {
    return WaitUntil([&] {
      auto s = c.Stats(0);
      return s.restored_transitions() == snap_transitions && s.inserted_transitions() > snap_transitions + 5000;
    }, within);
  };
  bool reconnected = resumed(20s);
  if (!reconnected) {
    std::cerr << "note: the actor did not resume publishing after the shard restart (stalled writer); "
                 "restarting the actor\n";
    c.actors[0].Signal(SIGKILL);
    ASSERT_TRUE(c.actors[0].WaitFor(5s));
    c.actors.clear();
    c.StartActors(0);
    ASSERT_TRUE(resumed(30s)) << "restored " << c.Stats(0).restored_transitions() << " inserted "
                              << c.Stats(0).inserted_transitions();
  }
  EXPECT_FALSE(c.actors[0].Poll()) << "the actor died: " << c.actors[0].Describe();

  c.actors[0].Signal(SIGTERM);
  ASSERT_TRUE(c.actors[0].WaitFor(30s));
  EXPECT_TRUE(c.actors[0].succeeded()) << c.actors[0].Describe();
  StopAll(c.shards, 10s);
  ASSERT_TRUE(c.shards[0].succeeded()) << c.shards[0].Describe();
  auto shard = ReadJson(c.dir / "replay-0.json");
  auto actor = ReadJson(c.dir / "actor-0.json");
  ASSERT_FALSE(shard.is_null());
  ASSERT_FALSE(actor.is_null());
  EXPECT_EQ(shard["restored_transitions"], snap_transitions);
  const auto& a = shard["actors"][0];
  // every stored byte hashes to the ledger: the snapshot's part (snap_checksum) plus what came
  // after (when the actor was fast enough to fill the shard, eviction makes this moot)
  if (a["stored_transitions"] == a["transitions"]) EXPECT_EQ(a["stored_checksum"], a["payload_checksum"]);
  EXPECT_GT(a["transitions"].get<uint64_t>(), snap_transitions);
  EXPECT_NE(a["payload_checksum"].get<uint64_t>(), snap_checksum);
  // what the shard lost between its snapshot and its restart shows up as gaps, never twice
  EXPECT_EQ(shard["duplicates"], 0);
  if (reconnected) EXPECT_GT(shard["gaps"].get<uint64_t>(), 0u);
  EXPECT_EQ(a["next_seq"], actor["batches"]);
  if (reconnected) EXPECT_LT(a["transitions"].get<uint64_t>(), actor["transitions_published"].get<uint64_t>());

  // the snapshot holds every transition up to it: a shard started on it alone (no actor)
  // recomputes the per-actor checksum of its stored bytes and finds the snapshot's ledger
  fs::remove(c.dir / "replay-0.json");
  c.StartShard(0, flags);
  auto listening = [&] {
    std::ifstream log(c.dir / "replay-0.log");
    std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
    return text.rfind("listening on partition") > text.rfind("resumed ");
  };
  ASSERT_TRUE(WaitUntil(listening, 30s)) << "the third shard start did not come up";
  StopAll(c.shards, 10s);
  auto again = ReadJson(c.dir / "replay-0.json");
  ASSERT_FALSE(again.is_null());
  EXPECT_EQ(again["restored_transitions"], snap_transitions);
  EXPECT_EQ(again["actors"][0]["stored_transitions"], snap_transitions);
  EXPECT_EQ(again["actors"][0]["stored_checksum"], snap_checksum);
  EXPECT_EQ(again["actors"][0]["payload_checksum"], snap_checksum);
}

TEST(ReplayResume, TruncatedAndBitFlippedSnapshotsAreReportedAndThePreviousOneUsed) {
  ReplayCluster c{TempDir("replay-corrupt"), TestDomain(42)};
  c.shards_n = 1;
  c.actors_n = 1;
  fs::path snaps = c.dir / "snapshots";
  std::vector<std::string> flags = {"--set", "replay.snapshot_dir=" + snaps.string()};
  c.StartShards(flags);
  c.StartActors(30000);
  c.Join();
  ASSERT_TRUE(WaitUntil([&] { return c.Stats(0).size() > 5000; }, 30s));
  ASSERT_EQ(c.Cli(fmt::format("snapshot --domain {} --shards 1", c.domain)).code, 0);
  ASSERT_TRUE(c.actors[0].WaitFor(60s));
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

}  // namespace
}  // namespace coins
