// Shard: what a replay shard does with each received TransitionBatch, independent of DDS:
// validate it (malformed batches are rejected and counted, never stored), drop duplicates,
// store it, and keep the per-actor ledger. Not thread-safe.
#pragma once

#include <cstdint>
#include <string>

#include "replay/ingest_ledger.h"
#include "replay/replay_options.h"
#include "replay/chunk_store.h"

namespace coins {

class Shard {
 public:
  Shard(uint32_t shard_id, const ReplayOptions& options);

  enum class Outcome { kStored, kDuplicate, kRejected };
  // handles one batch; on kRejected, `why` (if given) receives the reason
  Outcome Receive(const TransitionBatch& batch, std::string* why = nullptr);

  uint32_t id() const { return id_; }
  const ChunkStore& store() const { return store_; }
  const IngestLedger& ledger() const { return ledger_; }
  uint64_t inserted_transitions() const { return inserted_transitions_; }
  uint64_t inserted_batches() const { return inserted_batches_; }
  uint64_t rejected() const { return rejected_; }

 private:
  uint32_t id_;
  ChunkStore store_;
  IngestLedger ledger_;
  uint64_t inserted_transitions_ = 0;
  uint64_t inserted_batches_ = 0;
  uint64_t rejected_ = 0;
};

}  // namespace coins
