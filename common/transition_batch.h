// Building, hashing and checking TransitionBatch samples (idl/transition.idl).
//
// BatchBuilder fills a batch in place (typically a sample loaned from the DDS writer) row by
// row; Finish() stamps the header and the payload hash. ValidateBatch() is what a receiver
// runs before it stores anything: schema version, sizes within bounds, finite values, and the
// payload hash; its error names the first thing wrong.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

#include "common/status.h"
#include "idl/transition.h"

namespace coins {

using msg::TransitionBatch;

// identifies an env name together with the batch dimensions
uint32_t LayoutHash(std::string_view env_name, uint32_t state_dim, uint32_t action_dim, uint32_t goal_dim);

// 64-bit hash: four FNV-1a lanes over 8-byte words, folded; `seed` chains calls
// (a chained call hashes the same as one call only at the block level, so hash the same
// pieces on both sides)
uint64_t HashBytes(const void* data, size_t n, uint64_t seed = 0xcbf29ce484222325ULL);
// hash over the used parts of the batch arrays, chained in layout order: the state, action and
// goal blocks, then reward, flags, skill_level and interactions
uint64_t PayloadHash(const TransitionBatch& b);

// true when none of the n floats is NaN or infinite
bool AllFinite(const float* v, size_t n);

// checks a received batch; expected_layout 0 accepts any layout
Status ValidateBatch(const TransitionBatch& b, uint32_t expected_layout = 0);

// the largest number of rows that fits for these dimensions
uint32_t MaxRows(uint32_t state_dim, uint32_t action_dim, uint32_t goal_dim);

struct BatchHeader {
  uint32_t actor_id = 0;
  uint64_t incarnation = 0;
  uint64_t seq = 0;
  uint32_t env_id = 0;
  uint32_t layout_hash = 0;
  uint32_t state_dim = 0;
  uint32_t action_dim = 0;
  uint32_t goal_dim = 0;
  uint64_t episode_base = 0;
};

class BatchBuilder {
 public:
  // starts filling `batch` (not owned) with at most max_rows rows (clamped to MaxRows)
  void Begin(TransitionBatch* batch, const BatchHeader& header, uint32_t max_rows);
  // appends a row; returns false (and appends nothing) when the batch is full
  bool AddRow(std::span<const float> state, std::span<const float> action, std::span<const float> goal,
              float reward, uint16_t flags, uint8_t skill_level, uint32_t interactions);
  // state area of the next row, to write a state in place; call CommitRow after
  float* NextStateRow();
  void CommitRow(std::span<const float> action, std::span<const float> goal, float reward,
                 uint16_t flags, uint8_t skill_level, uint32_t interactions);
  bool full() const { return rows_ >= max_rows_; }
  uint32_t rows() const { return rows_; }
  uint32_t max_rows() const { return max_rows_; }
  // stamps n_rows and the payload hash; returns the hash
  uint64_t Finish();

 private:
  TransitionBatch* b_ = nullptr;
  BatchHeader h_;
  uint32_t max_rows_ = 0;
  uint32_t rows_ = 0;
};

// accessors into a batch's columnar values
inline const float* BatchState(const TransitionBatch& b, uint32_t row) {
  return b.values().data() + size_t(row) * b.state_dim();
}
inline const float* BatchAction(const TransitionBatch& b, uint32_t row) {
  return b.values().data() + size_t(b.n_rows()) * b.state_dim() + size_t(row) * b.action_dim();
}
inline const float* BatchGoal(const TransitionBatch& b, uint32_t row) {
  return b.values().data() + size_t(b.n_rows()) * (b.state_dim() + b.action_dim()) +
         size_t(row) * b.goal_dim();
}
// transitions in a batch: rows without ROW_SEGMENT_START
uint32_t CountTransitions(const TransitionBatch& b);

}  // namespace coins
