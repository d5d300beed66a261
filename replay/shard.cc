#include "replay/shard.h"

#include <algorithm>
#include <cassert>

#include "common/machine.h"

namespace coins {

int64_t ShardMemoryBytes(const ReplayOptions& o) {
  const double arena = double(o.capacity_mb) * 1024 * 1024;
  const double rows = std::min(2.0 * double(o.capacity), arena / 15) + 2.0 * COINS_BATCH_MAX_ROWS;
  // two sum trees of doubles over a power-of-two leaf count (up to 4 nodes a row each) and a
  // byte a row, per-level block masses (8 levels x 4 nodes / 256 slots, under a byte a row);
  // chunk descriptors for at most min(2 capacity, arena / 64) chunks
  const double per_row = 2 * 4 * sizeof(double) + 2;
  const double chunks = std::min(2.0 * double(o.capacity), arena / 64) + 2;
  const double total = arena + rows * per_row + chunks * double(sizeof(ChunkInfo));
  return total >= 9e18 ? int64_t(9e18) : int64_t(total);
}

Status CheckShardMemory(const ReplayOptions& o, int64_t shards) {
  const int64_t machine = PhysicalMemoryBytes();
  if (machine <= 0) return Status::Ok();  // cannot tell: the allocation itself reports
  const double need = double(ShardMemoryBytes(o)) * double(shards);
  if (need <= 0.9 * double(machine)) return Status::Ok();
  return Errorf(
      "replay.capacity_mb {} and replay.capacity {}: {} would need about {}, more than 90% of this "
      "machine's {} of memory; lower them",
      o.capacity_mb, o.capacity, shards == 1 ? std::string("a shard") : fmt::format("{} shards", shards),
      HumanBytes(need), HumanBytes(double(machine)));
}

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

Shard::Outcome Shard::Receive(const TransitionBatch& batch, std::string* why, uint32_t* also_stored) {
  if (also_stored) *also_stored = 0;
  // the payload hash is checked on the stored copy (Store), so the batch is read once
  Status s = Check(batch);
  if (s.ok() && !store_.configured())
    s = store_.Configure(batch.layout_hash(), batch.state_dim(), batch.action_dim(), batch.goal_dim());
  if (!s.ok()) {
    c_.rejected++;
    if (why) *why = s.message();
    return Outcome::kRejected;
  }
  const uint32_t actor = batch.actor_id();
  // the number expected next (0 for an incarnation not seen before)
  auto known = ledger_.actors().find(actor);
  const uint64_t expected =
      known != ledger_.actors().end() && known->second.incarnation == batch.incarnation() ? known->second.next_seq : 0;
  bool dropped_held = false;
  const auto admission = ledger_.Admit(actor, batch.incarnation(), batch.seq(), &dropped_held);
  if (dropped_held) {
    // the stream went on without confirming the held jump: it was not genuine
    auto it = held_.find(actor);
    if (why && it != held_.end())
      *why = fmt::format("actor {}: dropped the batch held at seq {}: the stream went on at seq {}", actor,
                         it->second->seq(), batch.seq());
    if (it != held_.end()) held_.erase(it);
    c_.rejected++;
  }
  switch (admission) {
    case IngestLedger::Admission::kDuplicate: return Outcome::kDuplicate;
    case IngestLedger::Admission::kHold: {
      // a held batch is checked now (a number damaged in transit must not be held)
      if (PayloadHash(batch) != batch.payload_hash()) {
        ledger_.DropHeld(actor);
        c_.rejected++;
        if (why) *why = fmt::format("batch from actor {} seq {}: payload hash mismatch", actor, batch.seq());
        return Outcome::kRejected;
      }
      auto& slot = held_[actor];
      if (!slot) slot = std::make_unique<TransitionBatch>();
      *slot = batch;
      if (why)
        *why = fmt::format(
            "actor {} incarnation {:x}: sequence number jumps to {} (expected {}); held until seq {} "
            "confirms it",
            actor, batch.incarnation(), batch.seq(), expected, batch.seq() + 1);
      return Outcome::kHeld;
    }
    case IngestLedger::Admission::kConfirm: {
      auto it = held_.find(actor);
      assert(it != held_.end() && "the ledger holds a jump only while the shard keeps its batch");
      std::unique_ptr<TransitionBatch> held = std::move(it->second);
      held_.erase(it);
      std::string held_why;
      const bool held_ok = Store(*held, /*continues=*/false, &held_why) == Outcome::kStored;
      if (held_ok && also_stored) *also_stored = store_.chunk(store_.chunks() - 1).transitions;
      Outcome o = Store(batch, /*continues=*/held_ok, why);
      if (why && o == Outcome::kStored)
        *why = held_ok ? fmt::format("actor {}: the jump to seq {} is confirmed by seq {} ({} numbers skipped)", actor,
                                     held->seq(), batch.seq(), held->seq() - expected)
                       : held_why;
      return o;
    }
    case IngestLedger::Admission::kNext: break;
  }
  return Store(batch, /*continues=*/true, why);
}

Shard::Outcome Shard::Store(const TransitionBatch& batch, bool continues, std::string* why) {
  uint64_t stored_hash = store_.Insert(batch, continues);
  if (stored_hash != batch.payload_hash()) {
    store_.DropLast();
    c_.rejected++;
    if (why) *why = fmt::format("batch from actor {} seq {}: payload hash mismatch", batch.actor_id(), batch.seq());
    return Outcome::kRejected;
  }
  const ChunkInfo& c = store_.chunk(store_.chunks() - 1);
  prio_.OnInsert(c.row_base, store_.flags(store_.chunks() - 1), store_.skill_levels(store_.chunks() - 1), c.n_rows);
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
