// LevelSelector: exactly uniform among the transitions of the skill levels in a mask (bit L:
// level L), through the shard's LevelIndex, so that rare levels (a task's decisions, one row in
// a hundred) cost no redraws. Exact: every pick is such a transition. kEmpty when none is held.
#pragma once

#include "replay/level_index.h"
#include "replay/selectors/selector.h"

namespace coins {

class LevelSelector {
 public:
  static constexpr bool kExact = true;
  LevelSelector(const ChunkStore& store, const LevelIndex& levels, uint32_t level_mask);
  Selected Select(std::mt19937_64* rng, Pick* pick) const;

 private:
  const ChunkStore& store_;
  const LevelIndex& levels_;
  uint32_t mask_;
  uint64_t count_;  // transitions of the mask's levels
};

}  // namespace coins
