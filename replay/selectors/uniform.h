// UniformSelector: every row held is picked with probability 1 / rows (the sampler redraws
// rows that are not transitions, which keeps the draw uniform over transitions). Select is
// inline: it is the cheapest draw, and the sampler's loop should not pay a call for it.
#pragma once

#include "replay/selectors/selector.h"

namespace coins {

class UniformSelector {
 public:
  static constexpr bool kExact = false;
  explicit UniformSelector(const ChunkStore& store)
      : store_(store), first_(store.first_row()), rows_(store.end_row() - first_), prob_(1.0 / double(rows_)) {}
  Selected Select(std::mt19937_64* rng, Pick* pick) const {
    if (rows_ == 0) return Selected::kEmpty;
    const uint64_t row = first_ + std::uniform_int_distribution<uint64_t>(0, rows_ - 1)(*rng);
    PickHeldRow(store_, row, prob_, pick);
    return Selected::kRow;
  }

 private:
  const ChunkStore& store_;
  uint64_t first_, rows_;
  double prob_;
};

}  // namespace coins
