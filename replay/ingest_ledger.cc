#include "replay/ingest_ledger.h"

namespace coins {

bool IngestLedger::Admit(uint32_t actor_id, uint64_t incarnation, uint64_t seq) {
  ActorLedger& a = actors_[actor_id];
  if (a.incarnations == 0 || a.incarnation != incarnation) {
    // a new actor process under this id: its numbering starts again
    a.incarnation = incarnation;
    a.next_seq = 0;
    a.incarnations++;
  }
  if (seq < a.next_seq) {
    duplicates_++;
    return false;
  }
  gaps_ += seq - a.next_seq;
  a.next_seq = seq + 1;
  return true;
}

void IngestLedger::Record(uint32_t actor_id, uint32_t transitions, uint64_t stored_hash) {
  ActorLedger& a = actors_[actor_id];
  a.batches++;
  a.transitions += transitions;
  a.checksum += stored_hash;
}

}  // namespace coins
