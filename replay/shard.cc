#include "replay/shard.h"

namespace coins {

Shard::Shard(uint32_t shard_id, const ReplayOptions& options)
    : id_(shard_id),
      store_(options.capacity, options.capacity_mb * 1024 * 1024),
      prio_(store_.row_capacity(), options.priority_exponent) {
  // evicted rows leave the priority index with their chunk
  // (the chunk leaving is the oldest, index 0)
  store_.SetEvictHook([this](const ChunkInfo& c) {
    prio_.OnEvict(c.row_base, c.n_rows);
    levels_.OnEvict(store_, 0);
  });
}

Status Shard::Check(const TransitionBatch& batch) const {
  return ValidateBatch(batch, store_.layout_hash(), /*check_hash=*/false);
}

Shard::Outcome Shard::Receive(const TransitionBatch& batch, std::string* why) {
  // the payload hash is checked on the stored copy below, so the batch is read once
  Status s = Check(batch);
  if (s.ok() && !store_.configured())
    s = store_.Configure(batch.layout_hash(), batch.state_dim(), batch.action_dim(), batch.goal_dim());
  if (!s.ok()) {
    c_.rejected++;
    if (why) *why = s.message();
    return Outcome::kRejected;
  }
  // a batch continues its env's stream when no sequence number went missing before it
  uint64_t gaps = ledger_.gaps();
  if (!ledger_.Admit(batch.actor_id(), batch.incarnation(), batch.seq())) return Outcome::kDuplicate;
  bool continues = ledger_.gaps() == gaps;
  uint64_t stored_hash = store_.Insert(batch, continues);
  if (stored_hash != batch.payload_hash()) {
    store_.DropLast();
    c_.rejected++;
    if (why) *why = fmt::format("batch from actor {} seq {}: payload hash mismatch", batch.actor_id(), batch.seq());
    return Outcome::kRejected;
  }
  const ChunkInfo& c = store_.chunk(store_.chunks() - 1);
  prio_.OnInsert(c.row_base, store_.flags(store_.chunks() - 1), c.n_rows);
  levels_.OnInsert(store_, store_.chunks() - 1);
  uint32_t transitions = c.transitions;
  ledger_.Record(batch.actor_id(), transitions, stored_hash);
  c_.inserted_transitions += transitions;
  c_.inserted_batches++;
  return Outcome::kStored;
}

std::map<uint32_t, std::pair<uint64_t, uint64_t>> Shard::StoredByActor() const {
  std::map<uint32_t, std::pair<uint64_t, uint64_t>> out;
  for (size_t i = 0; i < store_.chunks(); ++i) {
    auto& e = out[store_.chunk(i).actor_id];
    e.first += store_.chunk(i).transitions;
    e.second += store_.StoredHash(i);
  }
  return out;
}

}  // namespace coins
