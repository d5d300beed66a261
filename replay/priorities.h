// Priorities: per-row sampling mass of a shard for prioritised and weighted sampling.
//
// Rows are addressed by their global row number (ChunkStore::first_row() .. end_row()); a row
// lives in slot row % slots, which is unique among the rows held because the store keeps at
// most row_capacity rows. Two sum trees: priorities (stored as p^alpha, new rows get the
// largest priority seen so far) and weights (default 1; allocated on first use). Rows that
// are not transitions (ROW_SEGMENT_START) have mass 0 in both. Not thread-safe.
#pragma once

#include <cstdint>
#include <memory>

#include "common/sum_tree.h"

namespace coins {

class Priorities {
 public:
  Priorities(int64_t slots, double alpha);

  // a chunk of n rows starting at global row `row_base` arrived / left
  void OnInsert(uint64_t row_base, const uint16_t* flags, uint32_t n);
  void OnEvict(uint64_t row_base, uint32_t n);
  // new priority (>= 0, before the exponent) / weight (>= 0) of a row held now
  void SetPriority(uint64_t row, double p);
  void SetWeight(uint64_t row, double w);
  // raw masses as stored (priority^alpha, weight), for snapshots
  float RawPriority(uint64_t row) const { return float(prio_.Get(Slot(row))); }
  float RawWeight(uint64_t row) const { return weight_ ? float(weight_->Get(Slot(row))) : 1.0f; }
  void SetRaw(uint64_t row, float priority, float weight);

  const SumTree& priority_tree() const { return prio_; }
  bool has_weights() const { return weight_ != nullptr; }
  const SumTree* weights() const { return weight_.get(); }
  int64_t Slot(uint64_t row) const { return int64_t(row % uint64_t(slots_)); }
  double alpha() const { return alpha_; }
  double max_priority() const { return max_priority_; }

 private:
  void EnsureWeights();
  int64_t slots_;
  double alpha_;
  double max_priority_ = 1.0;  // before the exponent
  SumTree prio_;
  std::unique_ptr<SumTree> weight_;
  std::unique_ptr<uint8_t[]> is_transition_;  // per slot: 1 for transition rows held
};

}  // namespace coins
