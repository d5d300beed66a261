#include "replay/selectors/level.h"

namespace coins {

LevelSelector::LevelSelector(const ChunkStore& store, const LevelIndex& levels, uint32_t level_mask)
    : store_(store), levels_(levels), mask_(level_mask), count_(levels.Count(level_mask)) {}

Selected LevelSelector::Select(std::mt19937_64* rng, Pick* pick) const {
  size_t chunk = 0;
  uint32_t row = 0;
  if (!levels_.Draw(store_, mask_, rng, &chunk, &row)) return Selected::kEmpty;
  *pick = {uint32_t(chunk), row, 1.0 / double(count_)};
  return Selected::kRow;
}

}  // namespace coins
