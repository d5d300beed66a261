// Hindsight experience replay as plain functions over arrays (no DDS, no storage).
//
// The replay service calls these at sample time: extract the achieved goal of a state with a
// feature mask, test whether a goal is reached (masked L1 or L-inf distance <= epsilon), pick
// the hindsight index inside an episode / skill segment, and compute the skill reward.
// Index ranges are half-open [begin, end) in whatever indexing the caller uses (ring slots
// after unwrapping, absolute step counters, ...).
#pragma once

#include <cstdint>
#include <random>
#include <span>

#include "common/status.h"

namespace coins {

enum class GoalNorm { kL1, kLinf };
enum class HerStrategy {
  kNone,    // keep the original goal
  kFinal,   // the achieved goal at the segment's last step
  kFuture,  // the achieved goal at a uniformly chosen step in [t, end)
  kEpisode  // the achieved goal at a uniformly chosen step in [begin, end)
};

Result<HerStrategy> ParseHerStrategy(const std::string& name);  // "none", "final", "future", ...

// goal[i] = state[i] * mask[i] (all spans the same size): the paper's eta_b-masked target
void MaskedGoal(std::span<const float> state, std::span<const float> mask, std::span<float> goal);
// compact form: writes state[i] for every i with mask[i] != 0, in order; returns the count
int GatherMasked(std::span<const float> state, std::span<const float> mask, std::span<float> goal);
// distance between achieved and goal with each difference scaled by mask (empty: all ones)
float GoalDistance(std::span<const float> achieved, std::span<const float> goal, std::span<const float> mask,
                   GoalNorm norm);
// GoalDistance(...) <= epsilon
bool GoalReached(std::span<const float> achieved, std::span<const float> goal, std::span<const float> mask,
                 float epsilon, GoalNorm norm);
// the skill reward of the paper: reached ? success_reward : step_reward (paddle: 0 / -1)
inline float SkillReward(bool reached, float step_reward = -1.0f, float success_reward = 0.0f) {
  return reached ? success_reward : step_reward;
}

// the index whose achieved goal relabels transition t of the segment [begin, end)
// (begin <= t < end); kNone returns t.
int64_t SelectHindsightIndex(HerStrategy strategy, int64_t t, int64_t begin, int64_t end, std::mt19937_64* rng);

}  // namespace coins
