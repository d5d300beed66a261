#include "common/transition_batch.h"

#include <cmath>
#include <cstring>

namespace coins {

namespace {
constexpr uint64_t kPrime = 0x100000001b3ULL;
}

uint64_t HashBytes(const void* data, size_t n, uint64_t h) {
  // four independent FNV-1a lanes over 32-byte blocks (the multiplies overlap), folded at the end
  const auto* p = static_cast<const uint8_t*>(data);
  uint64_t lane[4] = {h, h ^ 0x9e3779b97f4a7c15ULL, h ^ 0xc2b2ae3d27d4eb4fULL, h ^ 0x165667b19e3779f9ULL};
  size_t blocks = n / 32;
  for (size_t i = 0; i < blocks; ++i) {
    uint64_t w[4];
    std::memcpy(w, p + 32 * i, 32);
    for (int k = 0; k < 4; ++k) lane[k] = (lane[k] ^ w[k]) * kPrime;
  }
  // fold only when a block was mixed in (otherwise the lanes' shared seed would cancel)
  if (blocks) {
    h = lane[0];
    for (int k = 1; k < 4; ++k) h = (h ^ lane[k]) * kPrime;
  }
  for (size_t i = blocks * 32; i < n; ++i) h = (h ^ p[i]) * kPrime;
  return (h ^ n) * kPrime;
}

uint32_t LayoutHash(std::string_view env_name, uint32_t state_dim, uint32_t action_dim, uint32_t goal_dim) {
  uint64_t h = HashBytes(env_name.data(), env_name.size());
  uint32_t dims[3] = {state_dim, action_dim, goal_dim};
  h = HashBytes(dims, sizeof(dims), h);
  uint32_t folded = static_cast<uint32_t>(h ^ (h >> 32));
  return folded == 0 ? 1 : folded;  // 0 means "any layout" to ValidateBatch
}

uint32_t MaxRows(uint32_t state_dim, uint32_t action_dim, uint32_t goal_dim) {
  uint32_t per_row = state_dim + action_dim + goal_dim;
  if (per_row == 0) return 0;
  uint32_t rows = COINS_BATCH_MAX_VALUES / per_row;
  return rows < COINS_BATCH_MAX_ROWS ? rows : COINS_BATCH_MAX_ROWS;
}

uint64_t PayloadHash(const TransitionBatch& b) {
  uint32_t n = b.n_rows();
  // one call per block, so a store holding the blocks apart can recompute the same hash
  uint64_t h = HashBytes(BatchState(b, 0), size_t(n) * b.state_dim() * sizeof(float));
  h = HashBytes(BatchAction(b, 0), size_t(n) * b.action_dim() * sizeof(float), h);
  h = HashBytes(BatchGoal(b, 0), size_t(n) * b.goal_dim() * sizeof(float), h);
  h = HashBytes(b.reward().data(), n * sizeof(float), h);
  h = HashBytes(b.flags().data(), n * sizeof(uint16_t), h);
  h = HashBytes(b.skill_level().data(), n * sizeof(uint8_t), h);
  h = HashBytes(b.interactions().data(), n * sizeof(uint32_t), h);
  return h;
}

bool AllFinite(const float* v, size_t n) {
  // a float is NaN or infinite when its exponent bits are all ones; OR-reduce that test
  uint32_t bad = 0;
  for (size_t i = 0; i < n; ++i) {
    uint32_t bits;
    std::memcpy(&bits, v + i, 4);
    bad |= uint32_t((bits & 0x7f800000u) == 0x7f800000u);
  }
  return bad == 0;
}

uint32_t CountTransitions(const TransitionBatch& b) {
  uint32_t count = 0;
  for (uint32_t r = 0; r < b.n_rows(); ++r) count += (b.flags()[r] & msg::ROW_SEGMENT_START) == 0;
  return count;
}

Status ValidateBatch(const TransitionBatch& b, uint32_t expected_layout) {
  if (b.schema_version() != msg::TRANSITION_BATCH_SCHEMA)
    return Errorf("batch from actor {} seq {}: schema version {} (this build reads {})", b.actor_id(),
                  b.seq(), b.schema_version(), msg::TRANSITION_BATCH_SCHEMA);
  uint64_t per_row = uint64_t(b.state_dim()) + b.action_dim() + b.goal_dim();
  if (b.n_rows() == 0 || b.n_rows() > COINS_BATCH_MAX_ROWS || b.state_dim() == 0 ||
      per_row * b.n_rows() > COINS_BATCH_MAX_VALUES)
    return Errorf("batch from actor {} seq {}: bad size (n_rows {}, state_dim {}, action_dim {}, goal_dim {})",
                  b.actor_id(), b.seq(), b.n_rows(), b.state_dim(), b.action_dim(), b.goal_dim());
  if (expected_layout != 0 && b.layout_hash() != expected_layout)
    return Errorf("batch from actor {} seq {}: layout {:08x} differs from this shard's {:08x}", b.actor_id(),
                  b.seq(), b.layout_hash(), expected_layout);
  if ((b.flags()[0] & msg::ROW_SEGMENT_START) == 0)
    return Errorf("batch from actor {} seq {}: row 0 must start a segment", b.actor_id(), b.seq());
  if (!AllFinite(b.values().data(), per_row * b.n_rows()) || !AllFinite(b.reward().data(), b.n_rows()))
    return Errorf("batch from actor {} seq {}: non-finite values", b.actor_id(), b.seq());
  if (PayloadHash(b) != b.payload_hash())
    return Errorf("batch from actor {} seq {}: payload hash mismatch", b.actor_id(), b.seq());
  return Status::Ok();
}

void BatchBuilder::Begin(TransitionBatch* batch, const BatchHeader& header, uint32_t max_rows) {
  b_ = batch;
  h_ = header;
  uint32_t limit = MaxRows(header.state_dim, header.action_dim, header.goal_dim);
  max_rows_ = max_rows == 0 || max_rows > limit ? limit : max_rows;
  rows_ = 0;
}

float* BatchBuilder::NextStateRow() {
  assert(rows_ < max_rows_);
  // state rows are laid out for max_rows_ while filling; Finish() compacts action/goal blocks
  return b_->values().data() + size_t(rows_) * h_.state_dim;
}

void BatchBuilder::CommitRow(std::span<const float> action, std::span<const float> goal, float reward,
                             uint16_t flags, uint8_t skill_level, uint32_t interactions) {
  assert(action.size() == h_.action_dim && goal.size() == h_.goal_dim);
  float* base = b_->values().data();
  // while filling, the action block starts after max_rows_ state rows, the goal block after that
  float* a = base + size_t(max_rows_) * h_.state_dim + size_t(rows_) * h_.action_dim;
  std::memcpy(a, action.data(), action.size_bytes());
  if (h_.goal_dim) {
    float* g = base + size_t(max_rows_) * (h_.state_dim + h_.action_dim) + size_t(rows_) * h_.goal_dim;
    std::memcpy(g, goal.data(), goal.size_bytes());
  }
  b_->reward()[rows_] = reward;
  b_->flags()[rows_] = flags;
  b_->skill_level()[rows_] = skill_level;
  b_->interactions()[rows_] = interactions;
  ++rows_;
}

bool BatchBuilder::AddRow(std::span<const float> state, std::span<const float> action,
                          std::span<const float> goal, float reward, uint16_t flags, uint8_t skill_level,
                          uint32_t interactions) {
  if (full()) return false;
  assert(state.size() == h_.state_dim);
  std::memcpy(NextStateRow(), state.data(), state.size_bytes());
  CommitRow(action, goal, reward, flags, skill_level, interactions);
  return true;
}

uint64_t BatchBuilder::Finish() {
  float* base = b_->values().data();
  // compact: move the action and goal blocks up behind rows_ state rows
  if (rows_ < max_rows_) {
    std::memmove(base + size_t(rows_) * h_.state_dim, base + size_t(max_rows_) * h_.state_dim,
                 size_t(rows_) * h_.action_dim * sizeof(float));
    if (h_.goal_dim)
      std::memmove(base + size_t(rows_) * (h_.state_dim + h_.action_dim),
                   base + size_t(max_rows_) * (h_.state_dim + h_.action_dim),
                   size_t(rows_) * h_.goal_dim * sizeof(float));
  }
  b_->schema_version(msg::TRANSITION_BATCH_SCHEMA);
  b_->actor_id(h_.actor_id);
  b_->incarnation(h_.incarnation);
  b_->seq(h_.seq);
  b_->env_id(h_.env_id);
  b_->layout_hash(h_.layout_hash);
  b_->n_rows(rows_);
  b_->state_dim(h_.state_dim);
  b_->action_dim(h_.action_dim);
  b_->goal_dim(h_.goal_dim);
  b_->episode_base(h_.episode_base);
  uint64_t h = PayloadHash(*b_);
  b_->payload_hash(h);
  return h;
}

}  // namespace coins
