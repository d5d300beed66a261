// What a level's action means: a primitive action for the env (level 1), or a goal for the
// level below (levels >= 2), and how goals are drawn at random for the skill being trained.
#pragma once

#include <random>

#include "common/policy/level_spec.h"

namespace coins::policy {

// the env action of a level whose actions are primitive: discrete index as a float, or a in
// [-1, 1]^d scaled to action_low/high
void ToPrimitiveAction(const LevelSpec& level, const float* action, float* env_action);

// the child's goal (masked values, env units) chosen by `parent`'s action in `state`:
// a discrete child goal by index; or child value + a * child_ratio * (high - low), with a the
// continuous action or child_offsets[index], clipped to the child's bounds. Returns whether a
// feature was clipped (a goal outside the child's goal space, e.g. past the workspace's edge).
bool ToChildGoal(const LevelSpec& parent, const GoalSpace& child, const float* action, const float* state,
                 float* child_goal);

// a uniformly random goal of the space: one of the discrete goals; continuous, uniform within the
// bounds, or with sample_ratio > 0 (a skill's own is goal.sample_ratio) uniform within
// sample_ratio * (high - low) of the target's value in `state` (the full state; unread
// otherwise), clipped to the bounds
void RandomGoal(const GoalSpace& goal, float sample_ratio, const float* state, std::mt19937_64* rng, float* out);

// a uniformly random action of the level (before any weights exist)
void RandomAction(const LevelSpec& level, std::mt19937_64* rng, float* action);

}  // namespace coins::policy
