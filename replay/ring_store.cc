#include "replay/ring_store.h"

#include <algorithm>
#include <cstring>

namespace coins {

RingStore::RingStore(int64_t capacity_rows, int64_t capacity_bytes)
    : requested_rows_(capacity_rows), capacity_bytes_(capacity_bytes) {}

Status RingStore::Configure(uint32_t layout_hash, uint32_t state_dim, uint32_t action_dim, uint32_t goal_dim) {
  if (configured()) {
    if (layout_hash != layout_) return Errorf("replay store holds layout {:08x}, not {:08x}", layout_, layout_hash);
    return Status::Ok();
  }
  int64_t row_bytes = int64_t(state_dim + action_dim + goal_dim + 1) * 4 + 2 + 1 + 4 + 4 + 1;
  capacity_ = std::min(requested_rows_, capacity_bytes_ / row_bytes);
  if (capacity_ < int64_t(COINS_BATCH_MAX_ROWS) * 2)
    return Errorf("replay capacity of {} rows ({} bytes each) is below two batches; raise replay.capacity_mb",
                  capacity_, row_bytes);
  layout_ = layout_hash;
  state_dim_ = state_dim;
  action_dim_ = action_dim;
  goal_dim_ = goal_dim;
  // new[] without initialisation: pages are only touched as rows are written
  state_.reset(new float[size_t(capacity_) * state_dim]);
  action_.reset(new float[size_t(capacity_) * std::max(action_dim, 1u)]);
  goal_.reset(new float[size_t(capacity_) * std::max(goal_dim, 1u)]);
  reward_.reset(new float[capacity_]);
  flags_.reset(new uint16_t[capacity_]);
  skill_.reset(new uint8_t[capacity_]);
  interactions_.reset(new uint32_t[capacity_]);
  actor_.reset(new uint32_t[capacity_]);
  live_.reset(new uint8_t[capacity_]());
  return Status::Ok();
}

void RingStore::Evict(int64_t begin, int64_t end) {
  for (int64_t i = begin; i < end; ++i) {
    if (!live_[i]) continue;
    live_[i] = 0;
    --rows_;
    transitions_ -= (flags_[i] & msg::ROW_SEGMENT_START) == 0;
  }
}

uint64_t RingStore::Insert(const TransitionBatch& b) {
  const int64_t n = b.n_rows();
  // keep the batch contiguous: wrap early when it does not fit before the end
  if (head_ + n > capacity_) {
    Evict(head_, capacity_);
    head_ = 0;
  }
  const int64_t at = head_;
  Evict(at, at + n);
  std::memcpy(state_.get() + at * state_dim_, BatchState(b, 0), size_t(n) * state_dim_ * sizeof(float));
  std::memcpy(action_.get() + at * action_dim_, BatchAction(b, 0), size_t(n) * action_dim_ * sizeof(float));
  if (goal_dim_) std::memcpy(goal_.get() + at * goal_dim_, BatchGoal(b, 0), size_t(n) * goal_dim_ * sizeof(float));
  std::memcpy(reward_.get() + at, b.reward().data(), n * sizeof(float));
  std::memcpy(flags_.get() + at, b.flags().data(), n * sizeof(uint16_t));
  std::memcpy(skill_.get() + at, b.skill_level().data(), n);
  std::memcpy(interactions_.get() + at, b.interactions().data(), n * sizeof(uint32_t));
  for (int64_t i = at; i < at + n; ++i) {
    actor_[i] = b.actor_id();
    live_[i] = 1;
    transitions_ += (flags_[i] & msg::ROW_SEGMENT_START) == 0;
  }
  rows_ += n;
  head_ = at + n == capacity_ ? 0 : at + n;

  // hash the stored copy in the batch's own order (values blocks, then the per-row columns)
  uint64_t h = HashBytes(state_.get() + at * state_dim_, size_t(n) * state_dim_ * sizeof(float));
  h = HashBytes(action_.get() + at * action_dim_, size_t(n) * action_dim_ * sizeof(float), h);
  h = HashBytes(goal_.get() + at * goal_dim_, size_t(n) * goal_dim_ * sizeof(float), h);
  h = HashBytes(reward_.get() + at, n * sizeof(float), h);
  h = HashBytes(flags_.get() + at, n * sizeof(uint16_t), h);
  h = HashBytes(skill_.get() + at, n, h);
  h = HashBytes(interactions_.get() + at, n * sizeof(uint32_t), h);
  return h;
}

}  // namespace coins
