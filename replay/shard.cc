#include "replay/shard.h"

namespace coins {

Shard::Shard(uint32_t shard_id, const ReplayOptions& options)
    : id_(shard_id), store_(options.capacity, options.capacity_mb * 1024 * 1024) {}

Shard::Outcome Shard::Receive(const TransitionBatch& batch, std::string* why) {
  // the payload hash is checked on the stored copy below, so the batch is read once
  Status s = ValidateBatch(batch, store_.layout_hash(), /*check_hash=*/false);
  if (s.ok() && !store_.configured())
    s = store_.Configure(batch.layout_hash(), batch.state_dim(), batch.action_dim(), batch.goal_dim());
  if (!s.ok()) {
    rejected_++;
    if (why) *why = s.message();
    return Outcome::kRejected;
  }
  if (!ledger_.Admit(batch.actor_id(), batch.incarnation(), batch.seq())) return Outcome::kDuplicate;
  uint64_t stored_hash = store_.Insert(batch);
  if (stored_hash != batch.payload_hash()) {
    store_.DropLast();
    rejected_++;
    if (why) *why = fmt::format("batch from actor {} seq {}: payload hash mismatch", batch.actor_id(), batch.seq());
    return Outcome::kRejected;
  }
  uint32_t transitions = CountTransitions(batch);
  ledger_.Record(batch.actor_id(), transitions, stored_hash);
  inserted_transitions_ += transitions;
  inserted_batches_++;
  return Outcome::kStored;
}

}  // namespace coins
