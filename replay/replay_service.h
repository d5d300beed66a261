// ReplayService: one shard as a thread-safe service, without DDS. The ingest thread calls
// Insert, the sampling thread Sample and UpdatePriorities, the snapshot thread Snapshot, and
// the status thread Stats, all at once. One mutex guards the Shard; the rate limiter has its
// own and the two are never held together (the limiter reads the size from an atomic).
//
// Start-up: Open() resumes from the newest valid snapshot in options.snapshot_dir (corrupt or
// truncated ones are reported and skipped, older ones tried); a config that differs from the
// snapshot's is reported, and the snapshot's wins unless options.prefer_new_config. With
// resume_command (a checkpoint epoch's command id, common/checkpoint.h), only a snapshot written
// for that command counts; without one the shard starts empty.
#pragma once

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <vector>

#include "replay/rate_limiter.h"
#include "replay/sampler.h"
#include "replay/shard.h"
#include "replay/snapshot.h"

namespace coins {

struct ResumeReport {
  std::string snapshot;                     // the snapshot resumed from ("" = none)
  std::vector<std::string> corrupt;         // one line per snapshot skipped
  std::vector<std::string> other_command;   // snapshots skipped: not of the command asked for
  std::vector<std::string> config_changes;  // "key: snapshot -> new"
  bool new_config_won = false;
  uint64_t transitions = 0;
  double seconds = 0;
};

struct ServiceCounters {
  uint64_t samples_served = 0, bad_requests = 0, rate_limited = 0, insert_waits = 0;
  uint64_t snapshots_written = 0, snapshot_failures = 0, last_snapshot_command = 0;
  double last_snapshot_s = 0;
};

class ReplayService {
 public:
  // options are checked (rate limiter deadlock rules) by ReplayOptions::Validate first
  static Result<std::unique_ptr<ReplayService>> Open(uint32_t shard_id, ReplayOptions options, ResumeReport* report,
                                                     uint64_t resume_command = 0);

  enum class InsertResult { kStored, kDuplicate, kRejected, kHeld, kTimedOut };
  // validates, waits for the rate limiter (up to timeout), stores. `why` receives the reason
  // of a rejection or a note worth logging (Shard::Receive), else stays empty.
  InsertResult Insert(const TransitionBatch& batch, std::chrono::milliseconds timeout, std::string* why = nullptr);
  // answers a request into reply (header fields too); waits for the rate limiter up to
  // the request's timeout_ms (capped by max_wait)
  void Sample(const msg::SampleRequest& req, msg::SampleReply* reply, std::chrono::milliseconds max_wait);
  // priority (kind UPDATE_PRIORITY) or weight updates; keys no longer held are ignored
  void Update(uint8_t kind, std::span<const uint64_t> keys, std::span<const float> values);
  // writes a snapshot now (the caller's thread; traffic goes on); a shard that holds nothing
  // yet writes no file (empty path in the result)
  Result<SnapshotWriteResult> Snapshot(uint64_t command_id);
  // a stop is under way: inserts no longer wait for the rate limiter (what was taken from DDS is
  // stored, and actors can flush); samples are served as before
  void ReleaseInserts() { limiter_.ReleaseInserts(); }
  // the end: releases every blocked call; samples are refused from then on
  void Close() { limiter_.Close(); }

  // a consistent copy of what Stats needs
  struct View {
    uint32_t shard_id;
    int64_t size, capacity;
    ShardCounters shard;
    uint64_t duplicates, gaps, seq_jumps;
    size_t held;  // batches held now (sequence jumps not confirmed)
    std::map<uint32_t, ActorLedger> actors;
    std::map<uint32_t, std::pair<uint64_t, uint64_t>> stored;  // only when asked (O(chunks))
    ServiceCounters service;
  };
  View Stats(bool with_stored_checksums) const;
  const ReplayOptions& options() const { return options_; }
  int64_t size() const { return size_.load(); }

 private:
  ReplayService(uint32_t shard_id, const ReplayOptions& options);

  ReplayOptions options_;
  mutable std::mutex mu_;
  Shard shard_;
  RateLimiter limiter_;
  Sampler sampler_;
  std::mt19937_64 rng_;
  std::atomic<int64_t> size_{0};
  ServiceCounters counters_;  // guarded by mu_
  std::mutex snapshot_mu_;    // one snapshot at a time
};

}  // namespace coins
