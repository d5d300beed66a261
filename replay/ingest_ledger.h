// IngestLedger: a shard's per-actor accounting of received batches. Sequence numbers run
// 0, 1, 2, ... per actor incarnation (a restarted actor has a new incarnation), so a batch
// below the expected number is a duplicate (dropped and counted) and one above it reveals a
// gap (counted; the batch is kept).
#pragma once

#include <cstdint>
#include <map>

namespace coins {

struct ActorLedger {
  uint64_t incarnation = 0;
  uint64_t next_seq = 0;
  uint64_t batches = 0;
  uint64_t transitions = 0;
  uint64_t checksum = 0;    // sum of stored-copy hashes (mod 2^64)
  uint64_t incarnations = 0;
};

class IngestLedger {
 public:
  // true when the batch is new and should be stored; false for a duplicate
  bool Admit(uint32_t actor_id, uint64_t incarnation, uint64_t seq);
  // records a stored batch
  void Record(uint32_t actor_id, uint32_t transitions, uint64_t stored_hash);

  const std::map<uint32_t, ActorLedger>& actors() const { return actors_; }
  uint64_t duplicates() const { return duplicates_; }
  uint64_t gaps() const { return gaps_; }
  // restores the state a snapshot saved
  void Restore(uint32_t actor_id, const ActorLedger& a) { actors_[actor_id] = a; }
  void RestoreTotals(uint64_t duplicates, uint64_t gaps) {
    duplicates_ = duplicates;
    gaps_ = gaps;
  }

 private:
  std::map<uint32_t, ActorLedger> actors_;
  uint64_t duplicates_ = 0;
  uint64_t gaps_ = 0;
};

}  // namespace coins
