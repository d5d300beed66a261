// ChunkStore: a replay shard's storage. Each received TransitionBatch is kept as it arrived, a
// delta-encoded chunk (see idl/transition.idl), in one preallocated byte arena used as a ring;
// Breakout rows take tens of bytes instead of two kilobytes. The oldest chunks are evicted
// first (FIFO) when the arena or the transition capacity is full. A chunk never wraps around
// the arena's end: the ring wraps early and the tail stays unused until the next lap.
//
// The layout is fixed by the first batch (Configure); Insert() expects a batch that passed
// ValidateBatch with that layout. Chunks are numbered from the oldest (0) to the newest.
// Not thread-safe.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "common/status.h"
#include "common/transition_batch.h"

namespace coins {

struct ChunkInfo {
  int64_t offset = 0;        // in the arena
  int64_t bytes = 0;
  uint32_t n_rows = 0;
  uint32_t transitions = 0;
  uint32_t n_deltas = 0;
  uint32_t actor_id = 0;
  uint32_t env_id = 0;
  uint64_t seq = 0;
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
  // hash when the copy is intact)
  uint64_t Insert(const TransitionBatch& batch);
  // removes the chunk of the last Insert (a batch whose stored copy failed its hash)
  void DropLast();

  int64_t capacity() const { return capacity_transitions_; }
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

 private:
  struct Offsets {  // where each column of a chunk starts, relative to the chunk
    int64_t first_state, delta_end, delta_index, delta_value, action, goal, reward, flags, skill, interactions, end;
  };
  Offsets Layout(uint32_t n_rows, uint32_t n_deltas) const;
  void EvictOldest();
  bool OldestOverlaps(int64_t begin, int64_t end) const;

  int64_t capacity_transitions_;
  int64_t arena_bytes_;
  uint32_t layout_ = 0;
  uint32_t state_dim_ = 0, action_dim_ = 0, goal_dim_ = 0;
  std::unique_ptr<uint8_t[]> arena_;
  std::vector<ChunkInfo> ring_;  // chunk descriptors, a ring of first_ .. first_ + count_
  size_t first_ = 0, count_ = 0;
  int64_t head_ = 0;             // next free byte in the arena
  int64_t transitions_ = 0, rows_ = 0, bytes_ = 0;
};

}  // namespace coins
