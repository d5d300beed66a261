// RingStore: a replay shard's columnar storage of TransitionBatch rows in a preallocated ring.
//
// Rows keep the batch layout (see idl/transition.idl): state, action, goal, reward, flags,
// skill level, interactions, plus the source (actor, env) of every row. A batch is stored
// contiguously: when it does not fit before the end of the ring, the ring wraps early and the
// rows left at the end are dead until overwritten. The oldest rows are evicted first (FIFO).
// The layout (dimensions) is fixed by the first batch inserted; Insert() expects a batch that
// passed ValidateBatch with that layout. Not thread-safe.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "common/status.h"
#include "common/transition_batch.h"

namespace coins {

class RingStore {
 public:
  // capacity in rows, and a cap on the memory the ring may take
  RingStore(int64_t capacity_rows, int64_t capacity_bytes);

  // fixes the layout on the first call; allocates the ring then
  Status Configure(uint32_t layout_hash, uint32_t state_dim, uint32_t action_dim, uint32_t goal_dim);
  bool configured() const { return layout_ != 0; }
  uint32_t layout_hash() const { return layout_; }

  // copies the batch's rows in; returns the hash of the stored copy (equal to the batch's
  // payload hash when the copy is intact)
  uint64_t Insert(const TransitionBatch& batch);

  int64_t capacity() const { return capacity_; }
  int64_t rows() const { return rows_; }                  // live rows
  int64_t transitions() const { return transitions_; }    // live rows that are transitions

  // read access to a stored row (index in [0, capacity))
  const float* state(int64_t i) const { return state_.get() + i * state_dim_; }
  const float* action(int64_t i) const { return action_.get() + i * action_dim_; }
  float reward(int64_t i) const { return reward_[i]; }
  uint16_t flags(int64_t i) const { return flags_[i]; }

 private:
  void Evict(int64_t begin, int64_t end);

  int64_t requested_rows_;
  int64_t capacity_bytes_;
  int64_t capacity_ = 0;
  uint32_t layout_ = 0;
  uint32_t state_dim_ = 0, action_dim_ = 0, goal_dim_ = 0;
  std::unique_ptr<float[]> state_, action_, goal_, reward_;
  std::unique_ptr<uint16_t[]> flags_;
  std::unique_ptr<uint8_t[]> skill_;
  std::unique_ptr<uint32_t[]> interactions_, actor_;
  std::unique_ptr<uint8_t[]> live_;
  int64_t head_ = 0;         // next row to write
  int64_t rows_ = 0;
  int64_t transitions_ = 0;
};

}  // namespace coins
