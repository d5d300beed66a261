#include "replay/snapshot.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <fstream>
#include <thread>

#include "common/checkpoint.h"
#include "common/machine.h"
#include "replay/replay_service.h"
#include "replay/test_stream.h"

namespace coins {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;
using testing::TestStream;

fs::path TempDir(const std::string& name) {
  auto dir = fs::temp_directory_path() / ("coins-snap-" + name + "-" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

ReplayOptions Options(const fs::path& dir) {
  ReplayOptions o;
  o.capacity = 200000;
  o.capacity_mb = 32;
  o.snapshot_dir = dir.string();
  return o;
}

std::unique_ptr<ReplayService> Open(const ReplayOptions& o, ResumeReport* report) {
  auto s = ReplayService::Open(0, o, report);
  EXPECT_TRUE(s.ok()) << s.status().message();
  return s.ok() ? std::move(*s) : nullptr;
}

void Fill(ReplayService& s, TestStream& stream, int batches) {
  for (int i = 0; i < batches; ++i) ASSERT_EQ(s.Insert(*stream.Next(64), 1s), ReplayService::InsertResult::kStored);
}

// xors the byte at `at` of the file with mask
void FlipBits(const fs::path& path, uint64_t at, uint8_t mask) {
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  f.seekg(std::streamoff(at));
  char c;
  f.get(c);
  f.seekp(std::streamoff(at));
  f.put(char(uint8_t(c) ^ mask));
}

TEST(Snapshot, RoundTripKeepsDataLedgerPrioritiesAndCounters) {
  auto dir = TempDir("roundtrip");
  ResumeReport report;
  auto a = Open(Options(dir), &report);
  EXPECT_TRUE(report.snapshot.empty());
  TestStream stream(3, 7);
  Fill(*a, stream, 50);
  a->Update(msg::UPDATE_PRIORITY, std::vector<uint64_t>{5}, std::vector<float>{9.0f});
  auto w = a->Snapshot(17);
  ASSERT_TRUE(w.ok()) << w.status().message();
  auto before = a->Stats(true);
  EXPECT_EQ(w->transitions, uint64_t(before.size));
  EXPECT_GT(before.size, 3000);

  ResumeReport r2;
  auto b = Open(Options(dir), &r2);
  EXPECT_EQ(r2.snapshot, w->path);
  EXPECT_TRUE(r2.corrupt.empty());
  EXPECT_TRUE(r2.config_changes.empty());
  auto after = b->Stats(true);
  EXPECT_EQ(after.size, before.size);
  EXPECT_EQ(after.shard.inserted_transitions, before.shard.inserted_transitions);
  ASSERT_EQ(after.actors.size(), 1u);
  EXPECT_EQ(after.actors.at(3).checksum, before.actors.at(3).checksum);
  EXPECT_EQ(after.actors.at(3).next_seq, 50u);
  // every stored chunk hashes back to the ledger's checksum
  EXPECT_EQ(after.stored.at(3).second, before.actors.at(3).checksum);
  EXPECT_EQ(after.stored.at(3).first, uint64_t(before.size));
  // sampling keys (global row numbers) survive the restart
  EXPECT_EQ(b->Stats(false).size, before.size);
  {
    msg::SampleRequest q;
    q.schema_version(msg::SAMPLING_SCHEMA);
    q.batch_size(64);
    q.n_step(1);
    q.gamma(0.5f);
    q.skill_level(-1);
    q.timeout_ms(100);
    msg::SampleReply ra, rb;
    a->Sample(q, &ra, 1s);
    ASSERT_EQ(ra.status(), msg::SAMPLE_OK) << ra.error();
    // the rows the first service names are the same transitions in the restored one
    b->Update(msg::UPDATE_PRIORITY, std::vector<uint64_t>(ra.key().begin(), ra.key().begin() + 1),
              std::vector<float>{1e9f});
    q.strategy(msg::SAMPLE_PRIORITIZED);
    b->Sample(q, &rb, 1s);
    ASSERT_EQ(rb.status(), msg::SAMPLE_OK) << rb.error();
    int same = 0;
    for (uint32_t i = 0; i < rb.n(); ++i) same += rb.key()[i] == ra.key()[0] && rb.state()[i * 4] == ra.state()[0];
    EXPECT_GT(same, 50);
    // and so do the per-level masses of prioritised draws restricted to levels
    q.level_mask(1u << ra.skill_level()[0]);
    b->Sample(q, &rb, 1s);
    ASSERT_EQ(rb.status(), msg::SAMPLE_OK) << rb.error();
    same = 0;
    for (uint32_t i = 0; i < rb.n(); ++i) same += rb.key()[i] == ra.key()[0];
    EXPECT_GT(same, 50);
  }
  // the same stream continues: no duplicates, no gaps
  Fill(*b, stream, 2);
  EXPECT_EQ(b->Stats(false).gaps, 0u);
  EXPECT_EQ(b->Stats(false).duplicates, 0u);
  auto img = ReadSnapshot(w->path);
  ASSERT_TRUE(img.ok());
  EXPECT_EQ(img->meta["command_id"], 17);
  EXPECT_NEAR(img->priorities[2 * 5], std::pow(9.0, 0.6), 1e-4);
}

TEST(Snapshot, TruncatedAndBitFlippedSnapshotsAreDetectedAndThePreviousOneUsed) {
  auto dir = TempDir("corrupt");
  ResumeReport report;
  auto a = Open(Options(dir), &report);
  TestStream stream(1, 1);
  Fill(*a, stream, 20);
  auto first = a->Snapshot(1);
  ASSERT_TRUE(first.ok());
  Fill(*a, stream, 20);
  auto second = a->Snapshot(2);
  ASSERT_TRUE(second.ok());
  fs::path good = first->path, newest = second->path;
  fs::copy_file(newest, dir / "copy", fs::copy_options::overwrite_existing);
  const auto size = fs::file_size(newest);

  // truncated: the newest is skipped with a message, the previous one is used
  fs::resize_file(newest, size / 2);
  ResumeReport r;
  auto b = Open(Options(dir), &r);
  ASSERT_EQ(r.corrupt.size(), 1u);
  EXPECT_NE(r.corrupt[0].find("truncated"), std::string::npos) << r.corrupt[0];
  EXPECT_EQ(r.snapshot, good.string());
  EXPECT_EQ(r.transitions, first->transitions);

  // one flipped bit in the chunk data, then in the ledger
  // one flipped bit anywhere is caught: a sweep over the whole file
  for (uint64_t at = 3; at < size; at += 211) {
    fs::copy_file(dir / "copy", newest, fs::copy_options::overwrite_existing);
    FlipBits(newest, at, 0x80);
    ASSERT_FALSE(ReadSnapshot(newest).ok()) << "flipped byte " << at << " of " << size;
  }
  for (uint64_t at : {uint64_t(100), uint64_t(size - 200)}) {
    fs::copy_file(dir / "copy", newest, fs::copy_options::overwrite_existing);
    FlipBits(newest, at, 0x10);
    auto img = ReadSnapshot(newest);
    ASSERT_FALSE(img.ok()) << "flipped byte " << at << " of " << size;
    EXPECT_NE(img.status().message().find("fails its checksum"), std::string::npos) << img.status().message();
    ResumeReport r3;
    auto c = Open(Options(dir), &r3);
    EXPECT_EQ(r3.snapshot, good.string());
  }
}

TEST(Snapshot, StrayFilesWithHugeNumbersAreSkippedAndTheValidOneUsed) {
  auto dir = TempDir("stray");
  ResumeReport report;
  auto a = Open(Options(dir), &report);
  TestStream stream(3, 7);
  Fill(*a, stream, 20);
  auto w = a->Snapshot(1);
  ASSERT_TRUE(w.ok()) << w.status().message();
  // a number past 64 bits (std::stoull threw std::out_of_range and the shard aborted), one that
  // fits but is near the top, and names that only look like snapshots
  for (const char* name : {"shard-0-99999999999999999999999.snap", "shard-0-18446744073709551615.snap", "shard-0-.snap",
                           "shard-0-12x.snap", "shard-0--5.snap"})
    std::ofstream(dir / name) << "not a snapshot";
  auto listed = ListSnapshots(dir, 0);
  ASSERT_EQ(listed.size(), 2u);
  EXPECT_EQ(listed[0].filename(), "shard-0-18446744073709551615.snap");
  EXPECT_EQ(listed[1].string(), w->path);
  // the next name follows the real ones
  EXPECT_EQ(NextSnapshotPath(dir, 0).filename(), "shard-0-00000001.snap");
  ResumeReport r;
  auto b = Open(Options(dir), &r);
  ASSERT_NE(b, nullptr);
  EXPECT_EQ(r.snapshot, w->path);
  EXPECT_EQ(r.corrupt.size(), 1u);  // the one that fits was tried and reported
  EXPECT_EQ(r.transitions, w->transitions);
  fs::remove_all(dir);
}

TEST(Snapshot, FinalSnapshotsNeverPushOutTheEpochsAResumeNeeds) {
  auto dir = TempDir("prune");
  ResumeReport report;
  auto o = Options(dir);
  o.snapshot_keep = 2;
  auto a = Open(o, &report);
  TestStream stream(3, 7);
  Fill(*a, stream, 4);
  // epochs 1..3, then four stop/resume cycles that each write a final snapshot (command 0)
  std::vector<std::string> paths;
  std::vector<uint64_t> commands = {CheckpointCommandId(1), CheckpointCommandId(2), CheckpointCommandId(3), 0, 0, 0, 0};
  for (uint64_t command : commands) {
    Fill(*a, stream, 1);
    auto w = a->Snapshot(command);
    ASSERT_TRUE(w.ok()) << w.status().message();
    paths.push_back(w->path);
    auto c = ReadSnapshotCommand(w->path);
    ASSERT_TRUE(c.ok()) << c.status().message();
    EXPECT_EQ(*c, command);
  }
  // kept: the newest two, and the snapshots of the newest two epochs; epoch 1 and two finals went
  std::vector<fs::path> want = {paths[6], paths[5], paths[2], paths[1]};
  EXPECT_EQ(ListSnapshots(dir, 0), want);
  // a resume of epoch 2 finds its snapshot, passing the newer ones over on their META
  ResumeReport r;
  auto b = ReplayService::Open(0, o, &r, CheckpointCommandId(2));
  ASSERT_TRUE(b.ok()) << b.status().message();
  EXPECT_EQ(r.snapshot, paths[1]);
  EXPECT_EQ(r.other_command.size(), 3u);
  EXPECT_TRUE(r.corrupt.empty());
  // a corrupt META is an error naming the file and the section; a corrupt DATA is not seen by
  // the META reader but fails the full read
  FlipBits(paths[6], fs::file_size(paths[6]) - 30, 0x10);
  auto bad = ReadSnapshotCommand(paths[6]);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find(paths[6]), std::string::npos) << bad.status().message();
  FlipBits(paths[5], 16 + 24 + 3, 0x01);
  auto data_bad = ReadSnapshotCommand(paths[5]);
  ASSERT_TRUE(data_bad.ok()) << data_bad.status().message();
  EXPECT_FALSE(ReadSnapshot(paths[5]).ok());
  fs::remove_all(dir);
}

TEST(Snapshot, AShardTooLargeForTheMachineIsRefusedBeforeItAllocates) {
  ReplayOptions o;
  o.capacity_mb = int64_t(1) << 20;  // 1 TiB of arena
  Status s = o.Validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("replay.capacity_mb 1048576"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("of memory"), std::string::npos) << s.message();
  o.capacity_mb = 64;
  EXPECT_TRUE(o.Validate().ok());
  EXPECT_FALSE(CheckShardMemory(o, 1 << 20).ok());  // a million such shards on one machine
  // the transition capacity counts too (its indexes)
  o.capacity = int64_t(1) << 34;
  o.capacity_mb = 16384;
  if (PhysicalMemoryBytes() < (int64_t(1) << 40)) {
    EXPECT_FALSE(o.Validate().ok());
  }
}

TEST(Snapshot, ConfigThatDiffersIsReportedAndTheNewOneWinsOnlyWhenAsked) {
  auto dir = TempDir("config");
  ResumeReport report;
  auto a = Open(Options(dir), &report);
  TestStream stream(1, 1);
  Fill(*a, stream, 5);
  ASSERT_TRUE(a->Snapshot(1).ok());
  ReplayOptions changed = Options(dir);
  changed.min_size = 50;
  ResumeReport r;
  auto b = Open(changed, &r);
  ASSERT_EQ(r.config_changes.size(), 1u);
  EXPECT_EQ(r.config_changes[0], "replay.min_size: 1 -> 50");
  EXPECT_EQ(b->options().min_size, 1);
  changed.prefer_new_config = true;
  ResumeReport r2;
  auto c = Open(changed, &r2);
  EXPECT_TRUE(r2.new_config_won);
  EXPECT_EQ(c->options().min_size, 50);
}

// inserts and samples go on while a snapshot is written (also a data-race check under TSan)
TEST(Snapshot, WrittenWhileInsertsAndSamplesGoOn) {
  auto dir = TempDir("concurrent");
  ResumeReport report;
  ReplayOptions o = Options(dir);
  o.capacity = 20000;  // eviction happens during the snapshot
  auto s = Open(o, &report);
  TestStream stream(1, 1);
  Fill(*s, stream, 400);
  std::atomic<bool> stop{false};
  std::atomic<int> inserted{0}, sampled{0};
  // paced like a busy actor fleet (64 transitions a millisecond): eviction goes on during every
  // snapshot, yet it cannot overtake the snapshot's copy and leave it empty, as an unpaced
  // in-process loop holding the lock back to back could
  std::thread inserter([&] {
    TestStream other(2, 1);
    while (!stop) {
      s->Insert(*other.Next(64), 1s);
      inserted++;
      std::this_thread::sleep_for(1ms);
    }
  });
  std::thread sampler([&] {
    msg::SampleRequest q;
    q.schema_version(msg::SAMPLING_SCHEMA);
    q.batch_size(32);
    q.n_step(1);
    q.gamma(0.9f);
    q.skill_level(-1);
    q.timeout_ms(100);
    msg::SampleReply r;
    while (!stop) {
      s->Sample(q, &r, 1s);
      if (r.status() == msg::SAMPLE_OK) sampled++;
    }
  });
  // snapshots back to back until both sides made progress beside them (bounded)
  std::vector<SnapshotWriteResult> written;
  auto end = std::chrono::steady_clock::now() + 20s;
  while (written.size() < 3 || ((inserted < 50 || sampled < 50) && std::chrono::steady_clock::now() < end)) {
    auto w = s->Snapshot(uint64_t(written.size() + 1));
    ASSERT_TRUE(w.ok()) << w.status().message();
    written.push_back(*w);
  }
  stop = true;
  inserter.join();
  sampler.join();
  EXPECT_GE(inserted.load(), 50);
  EXPECT_GE(sampled.load(), 50);
  for (const auto& w : written) {
    if (!fs::exists(w.path)) continue;  // pruned (keep 3)
    auto img = ReadSnapshot(w.path);
    ASSERT_TRUE(img.ok()) << img.status().message();
    EXPECT_EQ(img->meta["transitions"], w.transitions);
    // chunks evicted while the snapshot is written leave it (a fast inserter on a loaded machine)
    EXPECT_GT(w.transitions, 1000u);
  }
}

}  // namespace
}  // namespace coins
