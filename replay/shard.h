// Shard: what a replay shard does with each received TransitionBatch, independent of DDS:
// validate it (malformed batches are rejected and counted, never stored), drop duplicates,
// hold a batch whose sequence number jumps until the next one confirms it (ingest_ledger.h),
// store it, keep the per-actor ledger and the per-row priorities. Not thread-safe: the replay
// service guards a Shard with its lock.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include "replay/chunk_store.h"
#include "replay/ingest_ledger.h"
#include "replay/level_index.h"
#include "replay/priorities.h"
#include "replay/replay_options.h"

namespace coins {

struct ShardCounters {
  uint64_t inserted_transitions = 0;
  uint64_t inserted_batches = 0;
  uint64_t rejected = 0;
};

class Shard {
 public:
  Shard(uint32_t shard_id, const ReplayOptions& options);
  Shard(const Shard&) = delete;
  Shard& operator=(const Shard&) = delete;

  enum class Outcome { kStored, kDuplicate, kRejected, kHeld };
  // handles one batch. `why` (if given) receives the reason of a rejection, or a note worth a
  // log line (a held jump, a held batch confirmed or dropped), else stays untouched.
  // `also_stored` (if given) receives the transitions of a held batch stored before this one.
  Outcome Receive(const TransitionBatch& batch, std::string* why = nullptr, uint32_t* also_stored = nullptr);
  // the checks of Receive that need no state change: validation against the layout held
  Status Check(const TransitionBatch& batch) const;

  uint32_t id() const { return id_; }
  const ChunkStore& store() const { return store_; }
  const IngestLedger& ledger() const { return ledger_; }
  const Priorities& priorities() const { return prio_; }
  Priorities& priorities() { return prio_; }
  const LevelIndex& levels() const { return levels_; }
  LevelIndex& levels() { return levels_; }
  uint64_t inserted_transitions() const { return c_.inserted_transitions; }
  uint64_t inserted_batches() const { return c_.inserted_batches; }
  uint64_t rejected() const { return c_.rejected; }
  // batches held now (sequence jumps waiting for confirmation)
  size_t held() const { return held_.size(); }
  const ShardCounters& counters() const { return c_; }

  // per-actor transitions held and the sum of their stored-copy hashes, recomputed from the
  // arena (what a checksum test compares with the ledger)
  std::map<uint32_t, std::pair<uint64_t, uint64_t>> StoredByActor() const;

  // restore path (snapshots): the store, ledger and counters are refilled in place
  ChunkStore& mutable_store() { return store_; }
  IngestLedger& mutable_ledger() { return ledger_; }
  void RestoreCounters(const ShardCounters& c) { c_ = c; }

 private:
  // stores a batch that was admitted; kStored, or kRejected when the stored copy fails its hash
  Outcome Store(const TransitionBatch& batch, bool continues, std::string* why);

  uint32_t id_;
  ChunkStore store_;
  IngestLedger ledger_;
  Priorities prio_;
  LevelIndex levels_;
  ShardCounters c_;
  std::map<uint32_t, std::unique_ptr<TransitionBatch>> held_;  // by actor
};

}  // namespace coins
