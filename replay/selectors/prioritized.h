// PrioritizedSelector: prioritised replay's draw. Row i is picked with probability
// P(i) = m_i / sum m, where m_i is the row's mass in the Priorities tree (its priority^alpha,
// 0 for rows that are not transitions); kEmpty when the total mass is 0.
//
// ImportanceWeights turns the draws' probabilities into the corrections (N P(i))^-beta,
// normalised by the batch's largest, so that the weights only ever scale updates down.
#pragma once

#include <span>

#include "common/sum_tree.h"
#include "replay/priorities.h"
#include "replay/selectors/selector.h"

namespace coins {

// a row drawn in proportion to its mass in `tree`, a tree of prio's slots (Priorities::Slot);
// the weighted selector draws with it too
Selected DrawProportional(const ChunkStore& store, const Priorities& prio, const SumTree& tree, std::mt19937_64* rng,
                          Pick* pick);

class PrioritizedSelector {
 public:
  static constexpr bool kExact = false;
  PrioritizedSelector(const ChunkStore& store, const Priorities& prio) : store_(store), prio_(prio) {}
  Selected Select(std::mt19937_64* rng, Pick* pick) const {
    return DrawProportional(store_, prio_, prio_.priority_tree(), rng, pick);
  }

 private:
  const ChunkStore& store_;
  const Priorities& prio_;
};

// PrioritizedLevelSelector: the prioritised draw among the transitions of some skill levels
// only (bit L of the mask: level L), through Priorities' per-level masses: P(i) = m_i / (the
// levels' mass), however rare the levels are among the shard's rows. Exact; kEmpty when the
// levels have no mass.
class PrioritizedLevelSelector {
 public:
  static constexpr bool kExact = true;
  PrioritizedLevelSelector(const ChunkStore& store, const Priorities& prio, uint32_t level_mask)
      : store_(store), prio_(prio), mask_(level_mask), mass_(prio.LevelMass(level_mask)) {}
  Selected Select(std::mt19937_64* rng, Pick* pick) const;

 private:
  const ChunkStore& store_;
  const Priorities& prio_;
  uint32_t mask_;
  double mass_;
};

// weights[i] = (n probs[i])^-beta / max_j (n probs[j])^-beta (spans of the same size; n * p is
// floored at 1e-12)
void ImportanceWeights(std::span<const double> probs, double n, double beta, std::span<float> weights);

}  // namespace coins
