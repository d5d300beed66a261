#include "replay/chunk_store.h"

#include <algorithm>
#include <cstring>

namespace coins {

namespace {
int64_t Align8(int64_t x) { return (x + 7) & ~int64_t(7); }

}  // namespace

ChunkStore::ChunkStore(int64_t capacity_transitions, int64_t capacity_bytes)
    : capacity_transitions_(capacity_transitions), arena_bytes_(capacity_bytes) {}

ChunkStore::Offsets ChunkStore::Layout(uint32_t n, uint32_t d) const {
  Offsets o;
  o.first_state = 0;
  o.delta_end = Align8(o.first_state + int64_t(state_dim_) * 4);
  o.delta_index = Align8(o.delta_end + int64_t(n) * 4);
  o.delta_value = Align8(o.delta_index + int64_t(d) * 2);
  o.action = Align8(o.delta_value + int64_t(d) * 4);
  o.goal = Align8(o.action + int64_t(n) * action_dim_ * 4);
  o.reward = Align8(o.goal + int64_t(n) * goal_dim_ * 4);
  o.flags = Align8(o.reward + int64_t(n) * 4);
  o.skill = Align8(o.flags + int64_t(n) * 2);
  o.interactions = Align8(o.skill + int64_t(n));
  o.end = Align8(o.interactions + int64_t(n) * 4);
  return o;
}

Status ChunkStore::Configure(uint32_t layout_hash, uint32_t state_dim, uint32_t action_dim, uint32_t goal_dim) {
  if (configured()) {
    if (layout_hash != layout_) return Errorf("replay store holds layout {:08x}, not {:08x}", layout_, layout_hash);
    return Status::Ok();
  }
  state_dim_ = state_dim;
  action_dim_ = action_dim;
  goal_dim_ = goal_dim;
  // the arena must hold at least two of the largest possible chunks
  int64_t largest = Layout(COINS_BATCH_MAX_ROWS, COINS_BATCH_MAX_DELTAS).end;
  if (arena_bytes_ < 2 * largest)
    return Errorf("replay arena of {} bytes is below two of the largest batches ({} bytes); raise replay.capacity_mb",
                  arena_bytes_, 2 * largest);
  layout_ = layout_hash;
  // new[] without initialisation: pages are only touched as chunks are written
  arena_.reset(new uint8_t[arena_bytes_]);
  // every chunk holds at least one row, and more than 1 + arena/64 chunks cannot fit
  size_t max_chunks = size_t(std::min<int64_t>(capacity_transitions_ * 2 + 2, arena_bytes_ / 64 + 2));
  ring_.assign(max_chunks, ChunkInfo{});
  return Status::Ok();
}

bool ChunkStore::OldestOverlaps(int64_t begin, int64_t end) const {
  const ChunkInfo& c = chunk(0);
  return c.offset < end && begin < c.offset + c.bytes;
}

void ChunkStore::EvictOldest() {
  const ChunkInfo& c = chunk(0);
  transitions_ -= c.transitions;
  rows_ -= c.n_rows;
  bytes_ -= c.bytes;
  first_ = (first_ + 1) % ring_.size();
  --count_;
}

uint64_t ChunkStore::Insert(const TransitionBatch& b) {
  const uint32_t n = b.n_rows();
  const uint32_t d = static_cast<uint32_t>(b.delta_index().size());
  const Offsets o = Layout(n, d);
  const uint32_t transitions = CountTransitions(b);

  // room by transitions and by descriptors
  while (count_ > 0 && (transitions_ + transitions > capacity_transitions_ || count_ + 1 > ring_.size())) EvictOldest();
  // room in the arena: wrap early when the chunk does not fit before the end; the chunks
  // left behind the head are then the oldest ones
  if (head_ + o.end > arena_bytes_) {
    int64_t old_head = head_;
    while (count_ > 0 && chunk(0).offset >= old_head) EvictOldest();
    head_ = 0;
  }
  while (count_ > 0 && OldestOverlaps(head_, head_ + o.end)) EvictOldest();

  // copy the columns and hash the stored copy in the order of PayloadHash
  uint8_t* base = arena_.get() + head_;
  uint64_t h = 0xcbf29ce484222325ULL;
  auto put = [&](int64_t at, const auto& v) {
    using T = typename std::decay_t<decltype(v)>::value_type;
    std::memcpy(base + at, v.data(), v.size() * sizeof(T));
    h = HashBytes(base + at, v.size() * sizeof(T), h);
  };
  put(o.first_state, b.first_state());
  put(o.delta_end, b.delta_end());
  put(o.delta_index, b.delta_index());
  put(o.delta_value, b.delta_value());
  put(o.action, b.action());
  put(o.goal, b.goal());
  put(o.reward, b.reward());
  put(o.flags, b.flags());
  put(o.skill, b.skill_level());
  put(o.interactions, b.interactions());

  ChunkInfo& c = ring_[(first_ + count_) % ring_.size()];
  c = ChunkInfo{head_, o.end, n, transitions, d, b.actor_id(), b.env_id(), b.seq()};
  ++count_;
  head_ += o.end;
  transitions_ += transitions;
  rows_ += n;
  bytes_ += o.end;
  return h;
}

void ChunkStore::DropLast() {
  if (count_ == 0) return;
  const ChunkInfo& c = chunk(count_ - 1);
  transitions_ -= c.transitions;
  rows_ -= c.n_rows;
  bytes_ -= c.bytes;
  head_ = c.offset;
  --count_;
}

void ChunkStore::DecodeStates(size_t i, float* out) const {
  const ChunkInfo& c = chunk(i);
  const Offsets o = Layout(c.n_rows, c.n_deltas);
  const uint8_t* base = arena_.get() + c.offset;
  const auto* end = reinterpret_cast<const uint32_t*>(base + o.delta_end);
  const auto* index = reinterpret_cast<const uint16_t*>(base + o.delta_index);
  const auto* value = reinterpret_cast<const float*>(base + o.delta_value);
  std::memcpy(out, base + o.first_state, size_t(state_dim_) * 4);
  for (uint32_t r = 1; r < c.n_rows; ++r) {
    float* row = out + size_t(r) * state_dim_;
    std::memcpy(row, row - state_dim_, size_t(state_dim_) * 4);
    for (uint32_t k = end[r - 1]; k < end[r]; ++k) row[index[k]] = value[k];
  }
}

const float* ChunkStore::rewards(size_t i) const {
  const ChunkInfo& c = chunk(i);
  return reinterpret_cast<const float*>(arena_.get() + c.offset + Layout(c.n_rows, c.n_deltas).reward);
}

const uint16_t* ChunkStore::flags(size_t i) const {
  const ChunkInfo& c = chunk(i);
  return reinterpret_cast<const uint16_t*>(arena_.get() + c.offset + Layout(c.n_rows, c.n_deltas).flags);
}

const float* ChunkStore::actions(size_t i) const {
  const ChunkInfo& c = chunk(i);
  return reinterpret_cast<const float*>(arena_.get() + c.offset + Layout(c.n_rows, c.n_deltas).action);
}

}  // namespace coins
