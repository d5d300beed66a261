// ReplayOptions: the "replay" section of the config.
#pragma once

#include <cstdint>
#include <string>

#include "common/config/config.h"
#include "idl/sampling.h"
#include "idl/transition.h"
#include "replay/rate_limiter.h"

namespace coins {

struct ReplayOptions;
// an error naming the keys when `shards` shards of these options would not fit in 90% of this
// machine's physical memory (ShardMemoryBytes each)
Status CheckShardMemory(const ReplayOptions& o, int64_t shards);

struct ReplayOptions {
  // transitions a shard holds at most
  int64_t capacity = 1'000'000;
  // memory of a shard's chunk arena, in MiB (Breakout rows take about 60 bytes); whichever
  // limit is reached first evicts the oldest batches
  int64_t capacity_mb = 512;
  // seconds between ReplayStats / heartbeat publications
  double status_period_s = 1.0;
  // rate limiter (replay/rate_limiter.h): sampling starts at min_size transitions; with
  // samples_per_insert > 0 the sampled/inserted ratio stays within error_buffer of it
  int64_t min_size = 1;
  double samples_per_insert = 0;
  double error_buffer = 0;
  // prioritised sampling exponents
  double priority_exponent = 0.6;
  double importance_exponent = 0.4;
  // hindsight walk bound (rows)
  int64_t max_segment_rows = 1000;
  // snapshots: directory ("" = none), period (0 = only on command), how many to keep
  std::string snapshot_dir;
  double snapshot_period_s = 0;
  int64_t snapshot_keep = 3;
  // on resume, a config that differs from the snapshot's: false = the snapshot's wins
  // (reported), true = this config wins (also reported)
  bool prefer_new_config = false;
  // on a clean stop, how long at most the shard keeps storing batches from transition writers
  // still matched (actors finishing their flush) before it closes the stream; it closes it
  // earlier once they are gone or have sent nothing for half a second
  double stop_drain_s = 10.0;
  // on a clean stop, write a final snapshot (with snapshot_dir set)
  bool snapshot_on_stop = true;

  void Visit(ConfigVisitor& v) {
    v.Int("capacity", capacity, 1024, int64_t(1) << 34, "transitions per shard");
    v.Int("capacity_mb", capacity_mb, 16, int64_t(1) << 20, "chunk arena per shard (MiB)");
    v.Float("status_period_s", status_period_s, 0.05, 3600, "status period (s)");
    v.Int("min_size", min_size, 1, int64_t(1) << 34, "transitions held before sampling starts");
    v.Float("samples_per_insert", samples_per_insert, 0, 1e6, "sampled / inserted transitions (0: no limit)");
    v.Float("error_buffer", error_buffer, 0, 1e15, "allowed deviation from samples_per_insert (transitions)");
    v.Float("priority_exponent", priority_exponent, 0, 10, "prioritised replay alpha");
    v.Float("importance_exponent", importance_exponent, 0, 10, "prioritised replay beta");
    v.Int("max_segment_rows", max_segment_rows, 1, 1 << 20, "hindsight walk bound (rows)");
    v.String("snapshot_dir", snapshot_dir, {}, "snapshot directory (empty: no snapshots)");
    v.Float("snapshot_period_s", snapshot_period_s, 0, 1e7, "seconds between snapshots (0: on command only)");
    v.Int("snapshot_keep", snapshot_keep, 1, 1000, "snapshots kept per shard");
    v.Bool("prefer_new_config", prefer_new_config, "on resume, this config wins over the snapshot's");
    v.Float("stop_drain_s", stop_drain_s, 0, 600, "on stop, seconds to keep storing from writers still matched");
    v.Bool("snapshot_on_stop", snapshot_on_stop, "on a clean stop, write a final snapshot (with snapshot_dir)");
  }
  RateLimiterConfig rate() const { return {min_size, samples_per_insert, error_buffer}; }
  // the rate limiter's rules, and the memory one shard of this config needs against the
  // machine's (CheckShardMemory)
  Status Validate() const {
    COINS_RETURN_IF_ERROR(
        RateLimiter::Check(rate(), capacity, COINS_BATCH_MAX_ROWS, COINS_SAMPLE_MAX_BATCH).WithContext("replay"));
    return CheckShardMemory(*this, 1);
  }
};

// bytes a shard of these options allocates at most: its chunk arena (capacity_mb), the per-row
// priority and weight trees and the chunk descriptors
int64_t ShardMemoryBytes(const ReplayOptions& o);

}  // namespace coins
