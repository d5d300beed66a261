// IngestLedger: a shard's per-actor accounting of received batches.
//
// Sequence numbers run 0, 1, 2, ... per actor incarnation (a restarted actor has a new
// incarnation, and its numbering starts again at 0). Over reliable DDS an actor's batches
// arrive in order, so with next = the number expected next:
//   seq == next            the next batch: admitted (stored)
//   seq <  next            a duplicate: dropped and counted
//   seq >  next, a jump    implausible on its own: only a shard that restarted (or a bug, or a
//                          forged copy) sees numbers skipped. The batch is held, not admitted,
//                          and counted as a jump. The batch numbered seq + 1 of the same
//                          incarnation confirms it: both are admitted and the skipped numbers
//                          count as gaps. A batch that continues the old numbering instead
//                          (seq == next) proves the held one wrong: it is dropped (rejected).
// A new incarnation is a jump unless its numbering starts at 0. So one bad batch never turns the
// genuine batches after it into duplicates.
#pragma once

#include <cstdint>
#include <map>

namespace coins {

struct ActorLedger {
  uint64_t incarnation = 0;
  uint64_t next_seq = 0;
  uint64_t batches = 0;
  uint64_t transitions = 0;
  uint64_t checksum = 0;  // sum of stored-copy hashes (mod 2^64)
  uint64_t incarnations = 0;
  uint64_t seq_jumps = 0;  // jumps seen (held batches), confirmed or not
  // the held jump, if any
  bool holding = false;
  uint64_t held_incarnation = 0;
  uint64_t held_seq = 0;
};

class IngestLedger {
 public:
  enum class Admission {
    kNext,       // store the batch
    kDuplicate,  // drop it (counted)
    kHold,       // hold it until the next number confirms it (a jump, counted)
    kConfirm,    // store the held batch, then this one
  };
  // what to do with a batch; a held batch that this one proves wrong is reported in
  // *dropped_held (the caller discards it and counts it rejected)
  Admission Admit(uint32_t actor_id, uint64_t incarnation, uint64_t seq, bool* dropped_held = nullptr);
  // forgets the jump just held (its batch failed a check)
  void DropHeld(uint32_t actor_id) { actors_[actor_id].holding = false; }
  // records a stored batch
  void Record(uint32_t actor_id, uint32_t transitions, uint64_t stored_hash);

  const std::map<uint32_t, ActorLedger>& actors() const { return actors_; }
  uint64_t duplicates() const { return duplicates_; }
  uint64_t gaps() const { return gaps_; }
  uint64_t seq_jumps() const { return seq_jumps_; }
  // restores the state a snapshot saved (no held batch survives a restart)
  void Restore(uint32_t actor_id, const ActorLedger& a) {
    actors_[actor_id] = a;
    actors_[actor_id].holding = false;
  }
  void RestoreTotals(uint64_t duplicates, uint64_t gaps, uint64_t seq_jumps = 0) {
    duplicates_ = duplicates;
    gaps_ = gaps;
    seq_jumps_ = seq_jumps;
  }

 private:
  std::map<uint32_t, ActorLedger> actors_;
  uint64_t duplicates_ = 0;
  uint64_t gaps_ = 0;
  uint64_t seq_jumps_ = 0;
};

}  // namespace coins
