#include "common/hindsight.h"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace coins {

Result<HerStrategy> ParseHerStrategy(const std::string& name) {
  if (name == "none") return HerStrategy::kNone;
  if (name == "final") return HerStrategy::kFinal;
  if (name == "future") return HerStrategy::kFuture;
  if (name == "episode") return HerStrategy::kEpisode;
  return Errorf("unknown hindsight strategy '{}' (known: none, final, future, episode)", name);
}

void MaskedGoal(std::span<const float> state, std::span<const float> mask, std::span<float> goal) {
  assert(state.size() == mask.size() && goal.size() == mask.size());
  for (size_t i = 0; i < state.size(); ++i) goal[i] = state[i] * mask[i];
}

int GatherMasked(std::span<const float> state, std::span<const float> mask, std::span<float> goal) {
  assert(state.size() == mask.size());
  int n = 0;
  for (size_t i = 0; i < state.size(); ++i)
    if (mask[i] != 0.0f) {
      assert(size_t(n) < goal.size());
      goal[size_t(n++)] = state[i];
    }
  return n;
}

float GoalDistance(std::span<const float> achieved, std::span<const float> goal, std::span<const float> mask,
                   GoalNorm norm) {
  assert(achieved.size() == goal.size() && (mask.empty() || mask.size() == goal.size()));
  float d = 0.0f;
  for (size_t i = 0; i < goal.size(); ++i) {
    const float diff = std::abs((achieved[i] - goal[i]) * (mask.empty() ? 1.0f : mask[i]));
    d = norm == GoalNorm::kL1 ? d + diff : std::max(d, diff);
  }
  return d;
}

bool GoalReached(std::span<const float> achieved, std::span<const float> goal, std::span<const float> mask,
                 float epsilon, GoalNorm norm) {
  return GoalDistance(achieved, goal, mask, norm) <= epsilon;
}

int64_t SelectHindsightIndex(HerStrategy strategy, int64_t t, int64_t begin, int64_t end, std::mt19937_64* rng) {
  assert(begin <= t && t < end);
  switch (strategy) {
    case HerStrategy::kNone: return t;
    case HerStrategy::kFinal: return end - 1;
    case HerStrategy::kFuture: return std::uniform_int_distribution<int64_t>(t, end - 1)(*rng);
    case HerStrategy::kEpisode: return std::uniform_int_distribution<int64_t>(begin, end - 1)(*rng);
  }
  return t;
}

}  // namespace coins
