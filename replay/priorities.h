// Priorities: per-row sampling mass of a shard for prioritised and weighted sampling.
//
// Rows are addressed by their global row number (ChunkStore::first_row() .. end_row()); a row
// lives in slot row % slots, which is unique among the rows held because the store keeps at
// most row_capacity rows. Two sum trees: priorities (stored as p^alpha, new rows get the
// largest priority seen so far) and weights (default 1; allocated on first use). Rows that
// are not transitions (ROW_SEGMENT_START) have mass 0 in both.
//
// Prioritised draws among some skill levels only (a chain's skill is trained on its own level's
// rows, at first one row in a hundred) go through per-level block masses: for each level, a
// small sum tree over blocks of kBlock slots holds the priority mass of that level's
// transitions in each block (kept by adding each change). DrawLevelSlot picks a level, then a
// block, both in proportion to mass, then a slot inside the block by scanning its kBlock leaves:
// P(slot) = mass / (the mask's levels' mass), with no redraws however rare the levels are.
// Not thread-safe.
#pragma once

#include <cstdint>
#include <memory>
#include <random>
#include <vector>

#include "common/sum_tree.h"

namespace coins {

class Priorities {
 public:
  static constexpr int kLevels = 8;       // skill levels 0 .. 7 (COINS_MAX_LEVELS)
  static constexpr int64_t kBlock = 256;  // slots per block of the per-level masses
  Priorities(int64_t slots, double alpha);

  // a chunk of n rows starting at global row `row_base` arrived (flags and skill levels per
  // row) / left
  void OnInsert(uint64_t row_base, const uint16_t* flags, const uint8_t* levels, uint32_t n);
  void OnEvict(uint64_t row_base, uint32_t n);
  // new priority (>= 0, before the exponent) / weight (>= 0) of a row held now
  void SetPriority(uint64_t row, double p);
  void SetWeight(uint64_t row, double w);
  // raw masses as stored (priority^alpha, weight), for snapshots
  float RawPriority(uint64_t row) const { return float(prio_.Get(Slot(row))); }
  float RawWeight(uint64_t row) const { return weight_ ? float(weight_->Get(Slot(row))) : 1.0f; }
  void SetRaw(uint64_t row, float priority, float weight);

  // priority mass of the transitions of the mask's levels (bit L: level L)
  double LevelMass(uint32_t level_mask) const;
  // a slot drawn in proportion to its priority mass among the transitions of the mask's levels,
  // and its probability; -1 when none was drawn (no mass, or a block left with rounding only)
  int64_t DrawLevelSlot(uint32_t level_mask, std::mt19937_64* rng, double* prob) const;

  const SumTree& priority_tree() const { return prio_; }
  bool has_weights() const { return weight_ != nullptr; }
  const SumTree* weights() const { return weight_.get(); }
  int64_t Slot(uint64_t row) const { return int64_t(row % uint64_t(slots_)); }
  double alpha() const { return alpha_; }
  double max_priority() const { return max_priority_; }

 private:
  static constexpr uint8_t kNotTransition = 0xFF;  // level_ of a slot without a held transition
  static constexpr uint8_t kOtherLevel = 0xFE;     // a transition of a level >= kLevels
  bool IsTransition(int64_t slot) const { return level_[size_t(slot)] != kNotTransition; }
  // the slot holds a row of `level` (or a marker) with priority mass `mass` now; the block
  // masses of its old and new levels follow
  void AssignSlot(int64_t slot, uint8_t level, double mass);
  void AddBlockMass(uint8_t level, int64_t slot, double delta);
  void EnsureWeights();
  int64_t slots_;
  double alpha_;
  double max_priority_ = 1.0;  // before the exponent
  SumTree prio_;
  std::unique_ptr<SumTree> weight_;
  std::unique_ptr<uint8_t[]> level_;   // per slot: the held transition's level, or the markers above
  std::vector<SumTree> level_blocks_;  // per level: mass per block (made on the level's first row)
};

}  // namespace coins
