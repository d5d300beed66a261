// UniformSelector: every row held is picked with probability 1 / rows (the sampler redraws
// rows that are not transitions, which keeps the draw uniform over transitions).
#pragma once

#include "replay/selectors/selector.h"

namespace coins {

class UniformSelector {
 public:
  static constexpr bool kExact = false;
  explicit UniformSelector(const ChunkStore& store);
  Selected Select(std::mt19937_64* rng, Pick* pick) const;

 private:
  const ChunkStore& store_;
  uint64_t first_, rows_;
};

}  // namespace coins
