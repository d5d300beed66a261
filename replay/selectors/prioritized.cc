#include "replay/selectors/prioritized.h"

#include <algorithm>
#include <cmath>

namespace coins {

Selected DrawProportional(const ChunkStore& store, const Priorities& prio, const SumTree& tree, std::mt19937_64* rng,
                          Pick* pick) {
  const double total = tree.Total();
  if (total <= 0) return Selected::kEmpty;
  const int64_t slot = tree.Find(std::uniform_real_distribution<double>(0.0, 1.0)(*rng) * total);
  // slot back to its global row: rows held are a contiguous range of fewer than slots rows
  const uint64_t first = store.first_row();
  const int64_t slots = tree.size();
  const uint64_t row = first + uint64_t((slot - prio.Slot(first) + slots) % slots);
  if (row >= store.end_row()) return Selected::kMiss;
  PickHeldRow(store, row, tree.Get(slot) / total, pick);
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
