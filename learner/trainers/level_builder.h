// Building the LevelSpec of each hierarchy level from what the chain found (LinkSpec: target,
// mask, goal set, interaction rate) and the learner's options for the level's group.
//
// A skill for link source -> target observes the source factor (none for the primitive
// action), the target factor and their relative positions (features both name x, y or z), plus
// its goal; its goal space is the target's masked features (discrete goals, or continuous
// bounds with the group's epsilon). Its actions are primitive (level 1), or goals of the level
// below: that level's discrete goals, or its continuous goals as offsets (child_offsets, dqn)
// or as continuous actions (ddpg, sac). A link whose interactions are rare events (fewer than one
// per ten transitions in the scoring data: a bounce, a push) needs one for success and, unless its
// group's interaction_ends_goal is "never" (pushing), ends goals at any detected interaction; a link whose source acts
// on the target most of the time (the primitive action moving the paddle: about one step in two) ends goals on reaching
// them. The task observes every factor but Action, Done and Reward, relative positions of the top link (or, with
// task_relative "all", of every pair of single factors and, in its pair network, of every single factor to each
// instance), and acts with the top skill's goals.
#pragma once

#include "common/env_spec.h"
#include "common/policy/level_spec.h"
#include "idl/control.h"
#include "learner/learner_options.h"

namespace coins {

// level L (1-based) for links[L - 1]; child is level L - 1's spec (null for level 1)
Result<policy::LevelSpec> BuildSkillSpec(const envs::EnvSpec& env, const msg::LinkSpec& link, int level,
                                         const policy::LevelSpec* child, const LevelTrainOptions& options);
// the task on top of `top` (the top skill's spec)
Result<policy::LevelSpec> BuildTaskSpec(const envs::EnvSpec& env, const policy::LevelSpec& top,
                                        const LevelTrainOptions& options);

// the task without a chain (orchestrator.chain none: the vanilla baseline): level 1 over primitive
// actions, observing every factor but Action, Done and Reward and the relative positions of every
// pair of single-instance factors (Paddle-Ball in Breakout, the baselines' added features); with
// task_relative "all" its pair network's points see every single factor minus the instance too
Result<policy::LevelSpec> BuildPrimitiveTaskSpec(const envs::EnvSpec& env, const LevelTrainOptions& options);

// rare interactions: the link's skill ends goals at any detected interaction
inline constexpr double kSparseInteractionRate = 0.1;
inline bool SparseLink(const msg::LinkSpec& link) { return link.interaction_rate() < kSparseInteractionRate; }

}  // namespace coins
