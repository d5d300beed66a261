#include "common/policy/actions.h"

#include <algorithm>
#include <cmath>

namespace coins::policy {

void ToPrimitiveAction(const LevelSpec& level, const float* action, float* env_action) {
  if (level.action_kind == ActionKind::kPrimitiveDiscrete) {
    env_action[0] = action[0];
    return;
  }
  for (int i = 0; i < level.action_dim; ++i) {
    const float lo = level.action_low[size_t(i)], hi = level.action_high[size_t(i)];
    env_action[i] = lo + 0.5f * (std::clamp(action[i], -1.0f, 1.0f) + 1.0f) * (hi - lo);
  }
}

bool ToChildGoal(const LevelSpec& parent, const GoalSpace& child, const float* action, const float* state,
                 float* child_goal) {
  if (parent.action_kind == ActionKind::kChildDiscrete) {
    const size_t k = std::min(child.goals.size() - 1, size_t(std::max(0.0f, action[0])));
    std::copy(child.goals[k].begin(), child.goals[k].end(), child_goal);
    return false;
  }
  bool clipped = false;
  for (int i = 0; i < child.dim(); ++i) {
    const float a =
        parent.action_kind == ActionKind::kChildOffsets
            ? parent.child_offsets[std::min(parent.child_offsets.size() - 1, size_t(std::max(0.0f, action[0])))]
            : action[std::min(i, parent.action_dim - 1)];
    const float lo = child.low[size_t(i)], hi = child.high[size_t(i)];
    const float now = state[child.offset + child.masked[size_t(i)]];
    const float want = now + a * parent.child_ratio * (hi - lo);
    child_goal[i] = std::isfinite(want) ? std::clamp(want, lo, hi) : std::clamp(now, lo, hi);
    clipped |= !(child_goal[i] == want);  // a non-finite goal (stays where it is) counts too
  }
  return clipped;
}

void RandomGoal(const GoalSpace& goal, float sample_ratio, const float* state, std::mt19937_64* rng, float* out) {
  if (goal.kind == GoalKind::kDiscrete) {
    const size_t k = std::uniform_int_distribution<size_t>(0, goal.goals.size() - 1)(*rng);
    std::copy(goal.goals[k].begin(), goal.goals[k].end(), out);
    return;
  }
  for (int i = 0; i < goal.dim(); ++i) {
    float lo = goal.low[size_t(i)], hi = goal.high[size_t(i)];
    if (sample_ratio > 0) {
      const float now = std::clamp(state[goal.offset + goal.masked[size_t(i)]], lo, hi);
      const float reach = sample_ratio * (hi - lo);
      lo = std::max(lo, now - reach);
      hi = std::min(hi, now + reach);
    }
    out[i] = std::uniform_real_distribution<float>(lo, hi)(*rng);
  }
}

void RandomAction(const LevelSpec& level, std::mt19937_64* rng, float* action) {
  if (level.discrete_actions()) {
    action[0] = float(std::uniform_int_distribution<int>(0, level.num_actions - 1)(*rng));
    return;
  }
  for (int i = 0; i < level.action_dim; ++i) action[i] = std::uniform_real_distribution<float>(-1.0f, 1.0f)(*rng);
}

}  // namespace coins::policy
