#include "replay/selectors/prioritized.h"

#include <algorithm>
#include <cmath>

namespace coins {

namespace {

// a slot of prio back to its global row: rows held are a contiguous range of fewer than slots
// rows; false when the slot holds no row
bool RowOfSlot(const ChunkStore& store, const Priorities& prio, int64_t slot, uint64_t* row) {
  const uint64_t first = store.first_row();
  const int64_t slots = prio.priority_tree().size();
  *row = first + uint64_t((slot - prio.Slot(first) + slots) % slots);
  return *row < store.end_row();
}

}  // namespace

Selected DrawProportional(const ChunkStore& store, const Priorities& prio, const SumTree& tree, std::mt19937_64* rng,
                          Pick* pick) {
  const double total = tree.Total();
  if (total <= 0) return Selected::kEmpty;
  const int64_t slot = tree.Find(std::uniform_real_distribution<double>(0.0, 1.0)(*rng) * total);
  uint64_t row;
  if (!RowOfSlot(store, prio, slot, &row)) return Selected::kMiss;
  PickHeldRow(store, row, tree.Get(slot) / total, pick);
  return Selected::kRow;
}

Selected PrioritizedLevelSelector::Select(std::mt19937_64* rng, Pick* pick) const {
  if (mass_ <= 0) return Selected::kEmpty;
  double prob = 0;
  const int64_t slot = prio_.DrawLevelSlot(mask_, rng, &prob);
  uint64_t row;
  if (slot < 0 || !RowOfSlot(store_, prio_, slot, &row)) return Selected::kMiss;
  PickHeldRow(store_, row, prob, pick);
  return Selected::kRow;
}

void ImportanceWeights(std::span<const double> probs, double n, double beta, std::span<float> weights) {
  double max_w = 0;
  for (size_t i = 0; i < probs.size(); ++i) {
    const double w = std::pow(std::max(n * probs[i], 1e-12), -beta);
    weights[i] = float(w);
    max_w = std::max(max_w, w);
  }
  for (float& w : weights) w = float(w / max_w);
}

}  // namespace coins
