#include "replay/selectors/uniform.h"

namespace coins {

UniformSelector::UniformSelector(const ChunkStore& store)
    : store_(store), first_(store.first_row()), rows_(store.end_row() - store.first_row()) {}

Selected UniformSelector::Select(std::mt19937_64* rng, Pick* pick) const {
  if (rows_ == 0) return Selected::kEmpty;
  const uint64_t row = first_ + std::uniform_int_distribution<uint64_t>(0, rows_ - 1)(*rng);
  return PickRow(store_, row, 1.0 / double(rows_), pick);
}

}  // namespace coins
