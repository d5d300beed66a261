// ChunkStore: a replay shard's storage. Each received TransitionBatch is kept as it arrived, a
// delta-encoded chunk (see idl/transition.idl), in one preallocated byte arena used as a ring;
// Breakout rows take tens of bytes instead of two kilobytes. The oldest chunks are evicted
// first (FIFO) when the arena or the transition capacity is full. A chunk never wraps around
// the arena's end: the ring wraps early and the tail stays unused until the next lap.
//
// The layout is fixed by the first batch (Configure); Insert() expects a batch that passed
// ValidateBatch with that layout. Chunks are numbered from the oldest (0) to the newest; each
// also has a global id (ids and global row numbers only grow), so that sampling keys stay
// valid while the ring moves. Rows are bounded too (row_capacity, 2 x capacity by default),
// which bounds the slots a per-row index needs.
//
// Continuity: a chunk that continues the previous chunk of the same actor, incarnation and env
// (its row 0 repeats that chunk's last state) is linked from it (ChunkInfo.next), so episodes
// and skill segments can be followed across chunks. The caller says whether a batch continues
// (no sequence gap before it). Not thread-safe.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <unordered_map>
#include <vector>

#include "common/status.h"
#include "common/transition_batch.h"

namespace coins {

struct ChunkInfo {
  int64_t offset = 0;  // in the arena
  int64_t bytes = 0;
  uint32_t n_rows = 0;
  uint32_t transitions = 0;
  uint32_t n_deltas = 0;
  uint32_t actor_id = 0;
  uint32_t env_id = 0;
  uint64_t seq = 0;
  uint64_t incarnation = 0;
  uint64_t episode_base = 0;
  uint64_t id = 0;           // global chunk id
  uint64_t row_base = 0;     // global row number of row 0
  uint64_t next = kNoChunk;  // id of the chunk continuing this one
  bool continues = false;    // this chunk continues an earlier one
  static constexpr uint64_t kNoChunk = ~uint64_t(0);
};

class ChunkStore {
 public:
  // capacity_transitions bounds the transitions held, capacity_bytes the arena
  ChunkStore(int64_t capacity_transitions, int64_t capacity_bytes);

  // fixes the layout on the first call and allocates the arena; later calls check it
  Status Configure(uint32_t layout_hash, uint32_t state_dim, uint32_t action_dim, uint32_t goal_dim);
  bool configured() const { return layout_ != 0; }
  uint32_t layout_hash() const { return layout_; }

  // copies the batch in; returns the hash of the stored copy (equal to the batch's payload
  // hash when the copy is intact). `continues`: the batch follows the last one of its
  // actor/env without a gap.
  uint64_t Insert(const TransitionBatch& batch, bool continues = false);
  // restores a chunk saved by a snapshot: `info` as chunk() gave it (offset, id, row_base and
  // next are assigned anew), `bytes` its info.bytes bytes. Fails on a size that does not match.
  Status InsertRaw(const ChunkInfo& info, const uint8_t* bytes);
  // an empty store's next global chunk id and row number (restores keep sampling keys valid)
  void SetNextIds(uint64_t id, uint64_t row) {
    if (count_ == 0) next_id_ = id, next_row_ = row;
  }
  // called with each chunk just before it is evicted (dropped from the ring)
  void SetEvictHook(std::function<void(const ChunkInfo&)> hook) { evict_hook_ = std::move(hook); }
  // removes the chunk of the last Insert (a batch whose stored copy failed its hash)
  void DropLast();

  int64_t capacity() const { return capacity_transitions_; }
  // chunk descriptors the ring can hold (0 before Configure); chunk ids held are contiguous and
  // fewer than this, so id mod chunk_slots() names a chunk uniquely
  size_t chunk_slots() const { return ring_.size(); }
  int64_t capacity_bytes() const { return arena_bytes_; }
  int64_t row_capacity() const { return row_capacity_; }
  uint32_t state_dim() const { return state_dim_; }
  uint32_t action_dim() const { return action_dim_; }
  uint32_t goal_dim() const { return goal_dim_; }
  // global ids: chunks held are [first_id(), end_id()), rows held are [first_row(), end_row())
  uint64_t first_id() const { return count_ ? chunk(0).id : next_id_; }
  uint64_t end_id() const { return next_id_; }
  uint64_t first_row() const { return count_ ? chunk(0).row_base : next_row_; }
  uint64_t end_row() const { return next_row_; }
  // index (0 = oldest) of the chunk with global id `id`, or -1 when it is not held
  int64_t IndexOf(uint64_t id) const { return (id >= first_id() && id < next_id_) ? int64_t(id - first_id()) : -1; }
  // index of the chunk holding global row `row` (first_row() <= row < end_row()), O(log chunks)
  size_t ChunkOfRow(uint64_t row) const;
  int64_t transitions() const { return transitions_; }
  int64_t rows() const { return rows_; }
  int64_t bytes_used() const { return bytes_; }
  size_t chunks() const { return count_; }
  const ChunkInfo& chunk(size_t i) const { return ring_[(first_ + i) % ring_.size()]; }

  // the chunk's n_rows x state_dim states, row-major
  void DecodeStates(size_t i, float* out) const;
  // per-row columns of chunk i
  const float* rewards(size_t i) const;
  const uint16_t* flags(size_t i) const;
  const float* actions(size_t i) const;  // n_rows x action_dim
  const float* goals(size_t i) const;    // n_rows x goal_dim
  const uint8_t* skill_levels(size_t i) const;
  const uint32_t* interactions(size_t i) const;  // simulator ground truth, bit i = env pair i
  // the chunk's provenance block (common/transition_batch.h): command_seq, then the weights
  // version of each level
  const uint64_t* provenance(size_t i) const;
  // the state of row r of chunk i (state_dim floats), decoded from first_state and deltas
  void DecodeRow(size_t i, uint32_t r, float* out) const;
  // the deltas of row r (r >= 1): features changed from row r-1 to row r
  void RowDeltas(size_t i, uint32_t r, const uint16_t** index, const float** value, uint32_t* n) const;
  // the chunk's stored bytes (chunk(i).bytes of them)
  const uint8_t* bytes(size_t i) const { return arena_.get() + chunk(i).offset; }
  // hash of the stored copy (header fields kept in ChunkInfo and the layout, then the
  // columns), as Insert computed it
  uint64_t StoredHash(size_t i) const;
  // arena bytes of a chunk of n_rows rows and n_deltas deltas with these dimensions (what an
  // owner needs to size capacity_bytes for chunks of a known shape)
  static int64_t ChunkBytes(uint32_t state_dim, uint32_t action_dim, uint32_t goal_dim, uint32_t n_rows,
                            uint32_t n_deltas) {
    return LayoutOf(state_dim, action_dim, goal_dim, n_rows, n_deltas).end;
  }

 private:
  struct Offsets {  // where each column of a chunk starts, relative to the chunk
    int64_t first_state, delta_end, delta_index, delta_value, action, goal, reward, flags, skill, interactions,
        provenance, end;
  };
  static Offsets LayoutOf(uint32_t state_dim, uint32_t action_dim, uint32_t goal_dim, uint32_t n_rows,
                          uint32_t n_deltas);
  Offsets Layout(uint32_t n_rows, uint32_t n_deltas) const {
    return LayoutOf(state_dim_, action_dim_, goal_dim_, n_rows, n_deltas);
  }
  // the HeaderHash of a chunk's batch, from what the store keeps
  uint64_t StoredHeaderHash(const ChunkInfo& c) const;
  // evicts until a chunk of `bytes`, `rows` and `transitions` fits; returns its offset
  int64_t MakeRoom(int64_t bytes, uint32_t rows, uint32_t transitions);
  void Append(ChunkInfo info, bool continues);
  void EvictOldest();
  bool OldestOverlaps(int64_t begin, int64_t end) const;

  int64_t capacity_transitions_;
  int64_t arena_bytes_;
  int64_t row_capacity_;
  uint32_t layout_ = 0;
  uint32_t state_dim_ = 0, action_dim_ = 0, goal_dim_ = 0;
  std::unique_ptr<uint8_t[]> arena_;
  std::vector<ChunkInfo> ring_;  // chunk descriptors, a ring of first_ .. first_ + count_
  size_t first_ = 0, count_ = 0;
  int64_t head_ = 0;  // next free byte in the arena
  int64_t transitions_ = 0, rows_ = 0, bytes_ = 0;
  uint64_t next_id_ = 0, next_row_ = 0;
  std::unordered_map<uint64_t, uint64_t> last_of_stream_;  // (actor << 32 | env) -> newest chunk id
  std::function<void(const ChunkInfo&)> evict_hook_;
};

}  // namespace coins
