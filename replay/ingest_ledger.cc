#include "replay/ingest_ledger.h"

namespace coins {

IngestLedger::Admission IngestLedger::Admit(uint32_t actor_id, uint64_t incarnation, uint64_t seq, bool* dropped_held) {
  if (dropped_held) *dropped_held = false;
  ActorLedger& a = actors_[actor_id];
  const bool known = a.incarnations > 0 && a.incarnation == incarnation;
  // the batch after a held jump confirms it: the numbering moves there
  if (a.holding && a.held_incarnation == incarnation && seq == a.held_seq + 1) {
    if (!known) {
      a.incarnation = incarnation;
      a.incarnations++;
      a.next_seq = 0;
    }
    gaps_ += a.held_seq - a.next_seq;
    a.next_seq = seq + 1;
    a.holding = false;
    return Admission::kConfirm;
  }
  if (a.holding && a.held_incarnation == incarnation && seq == a.held_seq) {
    duplicates_++;
    return Admission::kDuplicate;
  }
  // the next number of the known stream, or a first batch numbered 0
  if ((known && seq == a.next_seq) || (!known && seq == 0)) {
    if (a.holding && dropped_held) *dropped_held = true;
    a.holding = false;
    if (!known) {
      a.incarnation = incarnation;
      a.incarnations++;
    }
    a.next_seq = seq + 1;
    return Admission::kNext;
  }
  if (known && seq < a.next_seq) {
    duplicates_++;
    return Admission::kDuplicate;
  }
  // a jump: hold it (a batch held before is dropped in its favour)
  if (a.holding && dropped_held) *dropped_held = true;
  a.holding = true;
  a.held_incarnation = incarnation;
  a.held_seq = seq;
  a.seq_jumps++;
  seq_jumps_++;
  return Admission::kHold;
}

void IngestLedger::Record(uint32_t actor_id, uint32_t transitions, uint64_t stored_hash) {
  ActorLedger& a = actors_[actor_id];
  a.batches++;
  a.transitions += transitions;
  a.checksum += stored_hash;
}

}  // namespace coins
