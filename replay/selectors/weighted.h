// WeightedSelector: rows picked in proportion to their sampling weight (Priorities::SetWeight:
// passive error, proximity, ...; 0 for rows that are not transitions). Until a weight is set,
// every transition weighs 1 and the draw is uniform. The bias is intended: a weighted sample's
// importance weight is 1, so the sampler ignores pick.prob here. kEmpty when all weights are 0.
#pragma once

#include "replay/priorities.h"
#include "replay/selectors/prioritized.h"
#include "replay/selectors/uniform.h"

namespace coins {

class WeightedSelector {
 public:
  static constexpr bool kExact = false;
  WeightedSelector(const ChunkStore& store, const Priorities& prio)
      : store_(store), prio_(prio), weights_(prio.weights()), uniform_(store) {}
  Selected Select(std::mt19937_64* rng, Pick* pick) const {
    return weights_ ? DrawProportional(store_, prio_, *weights_, rng, pick) : uniform_.Select(rng, pick);
  }

 private:
  const ChunkStore& store_;
  const Priorities& prio_;
  const SumTree* weights_;  // null: no weight set yet
  UniformSelector uniform_;
};

}  // namespace coins
