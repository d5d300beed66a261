#include "replay/chunk_store.h"

#include <algorithm>
#include <cstring>
#include <new>

namespace coins {

namespace {
int64_t Align8(int64_t x) { return (x + 7) & ~int64_t(7); }

}  // namespace

ChunkStore::ChunkStore(int64_t capacity_transitions, int64_t capacity_bytes)
    : capacity_transitions_(capacity_transitions),
      arena_bytes_(capacity_bytes),
      // every row costs at least 15 bytes (delta end, reward, flags, skill, interactions)
      row_capacity_(std::min(2 * capacity_transitions, capacity_bytes / 15) + 2 * int64_t(COINS_BATCH_MAX_ROWS)) {}

ChunkStore::Offsets ChunkStore::LayoutOf(uint32_t state_dim, uint32_t action_dim, uint32_t goal_dim, uint32_t n,
                                         uint32_t d) {
  Offsets o;
  o.first_state = 0;
  o.delta_end = Align8(o.first_state + int64_t(state_dim) * 4);
  o.delta_index = Align8(o.delta_end + int64_t(n) * 4);
  o.delta_value = Align8(o.delta_index + int64_t(d) * 2);
  o.action = Align8(o.delta_value + int64_t(d) * 4);
  o.goal = Align8(o.action + int64_t(n) * action_dim * 4);
  o.reward = Align8(o.goal + int64_t(n) * goal_dim * 4);
  o.flags = Align8(o.reward + int64_t(n) * 4);
  o.skill = Align8(o.flags + int64_t(n) * 2);
  o.interactions = Align8(o.skill + int64_t(n));
  o.provenance = Align8(o.interactions + int64_t(n) * 4);
  o.end = o.provenance + int64_t(kProvenanceWords) * 8;
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
  // new[] without initialisation: pages are only touched as chunks are written
  arena_.reset(new (std::nothrow) uint8_t[size_t(arena_bytes_)]);
  if (!arena_) return Errorf("replay arena: cannot allocate {} bytes; lower replay.capacity_mb", arena_bytes_);
  // every chunk holds at least one row, and more than 1 + arena/64 chunks cannot fit
  size_t max_chunks = size_t(std::min<int64_t>(capacity_transitions_ * 2 + 2, arena_bytes_ / 64 + 2));
  try {
    ring_.assign(max_chunks, ChunkInfo{});
  } catch (const std::bad_alloc&) {
    arena_.reset();
    return Errorf("replay store: cannot allocate {} chunk descriptors; lower replay.capacity", max_chunks);
  }
  layout_ = layout_hash;
  return Status::Ok();
}

bool ChunkStore::OldestOverlaps(int64_t begin, int64_t end) const {
  const ChunkInfo& c = chunk(0);
  return c.offset < end && begin < c.offset + c.bytes;
}

void ChunkStore::EvictOldest() {
  const ChunkInfo& c = chunk(0);
  if (evict_hook_) evict_hook_(c);
  transitions_ -= c.transitions;
  rows_ -= c.n_rows;
  bytes_ -= c.bytes;
  first_ = (first_ + 1) % ring_.size();
  --count_;
}

int64_t ChunkStore::MakeRoom(int64_t bytes, uint32_t rows, uint32_t transitions) {
  // room by transitions, rows and descriptors
  while (count_ > 0 && (transitions_ + transitions > capacity_transitions_ || rows_ + rows > row_capacity_ ||
                        count_ + 1 > ring_.size()))
    EvictOldest();
  // room in the arena: wrap early when the chunk does not fit before the end; the chunks
  // left behind the head are then the oldest ones
  if (head_ + bytes > arena_bytes_) {
    int64_t old_head = head_;
    while (count_ > 0 && chunk(0).offset >= old_head) EvictOldest();
    head_ = 0;
  }
  while (count_ > 0 && OldestOverlaps(head_, head_ + bytes)) EvictOldest();
  return head_;
}

void ChunkStore::Append(ChunkInfo c, bool continues) {
  c.id = next_id_++;
  c.row_base = next_row_;
  next_row_ += c.n_rows;
  c.next = ChunkInfo::kNoChunk;
  c.continues = false;
  // link the chunk to the newest one of its stream when it continues it
  uint64_t stream = (uint64_t(c.actor_id) << 32) | c.env_id;
  auto it = last_of_stream_.find(stream);
  if (continues && it != last_of_stream_.end()) {
    int64_t prev = IndexOf(it->second);
    if (prev >= 0) {
      ChunkInfo& p = ring_[(first_ + size_t(prev)) % ring_.size()];
      if (p.incarnation == c.incarnation) {
        p.next = c.id;
        c.continues = true;
      }
    }
  }
  last_of_stream_[stream] = c.id;
  ring_[(first_ + count_) % ring_.size()] = c;
  ++count_;
  head_ += c.bytes;
  transitions_ += c.transitions;
  rows_ += c.n_rows;
  bytes_ += c.bytes;
}

uint64_t ChunkStore::Insert(const TransitionBatch& b, bool continues) {
  const uint32_t n = b.n_rows();
  const uint32_t d = static_cast<uint32_t>(b.delta_index().size());
  const Offsets o = Layout(n, d);
  const uint32_t transitions = CountTransitions(b);
  MakeRoom(o.end, n, transitions);

  ChunkInfo c{head_, o.end, n, transitions, d, b.actor_id(), b.env_id(), b.seq()};
  c.incarnation = b.incarnation();
  c.episode_base = b.episode_base();

  // copy the columns and hash the stored copy in the order of PayloadHash, header first
  uint8_t* base = arena_.get() + head_;
  uint64_t h = StoredHeaderHash(c);
  auto put = [&](int64_t at, const auto& v) {
    using T = typename std::decay_t<decltype(v)>::value_type;
    if (!v.empty()) std::memcpy(base + at, v.data(), v.size() * sizeof(T));  // an empty column may have no data
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
  uint64_t block[kProvenanceWords];
  ProvenanceBlock(b, block);
  std::memcpy(base + o.provenance, block, sizeof(block));
  h = HashBytes(base + o.provenance, sizeof(block), h);
  Append(c, continues);
  return h;
}

Status ChunkStore::InsertRaw(const ChunkInfo& info, const uint8_t* bytes) {
  if (!configured()) return Errorf("replay store: chunk restored before the layout was set");
  if (info.n_rows == 0 || info.n_rows > COINS_BATCH_MAX_ROWS || info.n_deltas > COINS_BATCH_MAX_DELTAS ||
      info.transitions >= info.n_rows + 1 || Layout(info.n_rows, info.n_deltas).end != info.bytes)
    return Errorf("replay store: chunk of actor {} seq {} has inconsistent sizes ({} rows, {} deltas, {} bytes)",
                  info.actor_id, info.seq, info.n_rows, info.n_deltas, info.bytes);
  MakeRoom(info.bytes, info.n_rows, info.transitions);
  std::memcpy(arena_.get() + head_, bytes, size_t(info.bytes));
  ChunkInfo c = info;
  c.offset = head_;
  Append(c, info.continues);
  return Status::Ok();
}

size_t ChunkStore::ChunkOfRow(uint64_t row) const {
  // chunks are sorted by row_base around the ring: binary search over ring positions
  size_t lo = 0, hi = count_;
  while (hi - lo > 1) {
    size_t mid = (lo + hi) / 2;
    if (chunk(mid).row_base <= row)
      lo = mid;
    else
      hi = mid;
  }
  return lo;
}

uint64_t ChunkStore::StoredHeaderHash(const ChunkInfo& c) const {
  BatchHeader h{c.actor_id, c.incarnation, c.seq,     c.env_id,      layout_,
                state_dim_, action_dim_,   goal_dim_, c.episode_base};
  return HeaderHash(msg::TRANSITION_BATCH_SCHEMA, h, c.n_rows);
}

uint64_t ChunkStore::StoredHash(size_t i) const {
  const ChunkInfo& c = chunk(i);
  const Offsets o = Layout(c.n_rows, c.n_deltas);
  const uint8_t* base = arena_.get() + c.offset;
  const uint32_t n = c.n_rows, d = c.n_deltas;
  uint64_t h = StoredHeaderHash(c);
  h = HashBytes(base + o.first_state, size_t(state_dim_) * 4, h);
  h = HashBytes(base + o.delta_end, size_t(n) * 4, h);
  h = HashBytes(base + o.delta_index, size_t(d) * 2, h);
  h = HashBytes(base + o.delta_value, size_t(d) * 4, h);
  h = HashBytes(base + o.action, size_t(n) * action_dim_ * 4, h);
  h = HashBytes(base + o.goal, size_t(n) * goal_dim_ * 4, h);
  h = HashBytes(base + o.reward, size_t(n) * 4, h);
  h = HashBytes(base + o.flags, size_t(n) * 2, h);
  h = HashBytes(base + o.skill, size_t(n), h);
  h = HashBytes(base + o.interactions, size_t(n) * 4, h);
  h = HashBytes(base + o.provenance, kProvenanceWords * 8, h);
  return h;
}

void ChunkStore::DropLast() {
  if (count_ == 0) return;
  const ChunkInfo c = chunk(count_ - 1);
  transitions_ -= c.transitions;
  rows_ -= c.n_rows;
  bytes_ -= c.bytes;
  head_ = c.offset;
  next_row_ -= c.n_rows;
  --next_id_;
  --count_;
  // unlink it: its stream continues from nothing (rare: a corrupt batch)
  last_of_stream_.erase((uint64_t(c.actor_id) << 32) | c.env_id);
  for (size_t i = count_; i-- > 0;) {
    ChunkInfo& p = ring_[(first_ + i) % ring_.size()];
    if (p.next == c.id) {
      p.next = ChunkInfo::kNoChunk;
      break;
    }
  }
}

void ChunkStore::DecodeStates(size_t i, float* out) const {
  const ChunkInfo& c = chunk(i);
  const Offsets o = Layout(c.n_rows, c.n_deltas);
  const uint8_t* base = arena_.get() + c.offset;
  DecodeDeltaRows(reinterpret_cast<const float*>(base + o.first_state), state_dim_, c.n_rows,
                  reinterpret_cast<const uint32_t*>(base + o.delta_end),
                  reinterpret_cast<const uint16_t*>(base + o.delta_index),
                  reinterpret_cast<const float*>(base + o.delta_value), out);
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

namespace coins {

const float* ChunkStore::goals(size_t i) const {
  const ChunkInfo& c = chunk(i);
  return reinterpret_cast<const float*>(arena_.get() + c.offset + Layout(c.n_rows, c.n_deltas).goal);
}

const uint8_t* ChunkStore::skill_levels(size_t i) const {
  const ChunkInfo& c = chunk(i);
  return arena_.get() + c.offset + Layout(c.n_rows, c.n_deltas).skill;
}

const uint32_t* ChunkStore::interactions(size_t i) const {
  const ChunkInfo& c = chunk(i);
  return reinterpret_cast<const uint32_t*>(arena_.get() + c.offset + Layout(c.n_rows, c.n_deltas).interactions);
}

const uint64_t* ChunkStore::provenance(size_t i) const {
  const ChunkInfo& c = chunk(i);
  return reinterpret_cast<const uint64_t*>(arena_.get() + c.offset + Layout(c.n_rows, c.n_deltas).provenance);
}

void ChunkStore::DecodeRow(size_t i, uint32_t r, float* out) const {
  const ChunkInfo& c = chunk(i);
  const Offsets o = Layout(c.n_rows, c.n_deltas);
  const uint8_t* base = arena_.get() + c.offset;
  const auto* end = reinterpret_cast<const uint32_t*>(base + o.delta_end);
  const auto* index = reinterpret_cast<const uint16_t*>(base + o.delta_index);
  const auto* value = reinterpret_cast<const float*>(base + o.delta_value);
  std::memcpy(out, base + o.first_state, size_t(state_dim_) * 4);
  // deltas apply in row order, so the last write of a feature wins
  ApplyDeltas(index, value, end[r], out);
}

void ChunkStore::RowDeltas(size_t i, uint32_t r, const uint16_t** index, const float** value, uint32_t* n) const {
  const ChunkInfo& c = chunk(i);
  const Offsets o = Layout(c.n_rows, c.n_deltas);
  const uint8_t* base = arena_.get() + c.offset;
  const auto* end = reinterpret_cast<const uint32_t*>(base + o.delta_end);
  uint32_t begin = end[r - 1];
  *index = reinterpret_cast<const uint16_t*>(base + o.delta_index) + begin;
  *value = reinterpret_cast<const float*>(base + o.delta_value) + begin;
  *n = end[r] - begin;
}

}  // namespace coins
