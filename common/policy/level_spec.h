// LevelSpec: one level of the skill hierarchy as every role sees it (the learner that trains it,
// the actors that run it, `coins eval`). Level 1 is the first skill (its actions are primitive),
// level L >= 2 a skill whose actions are goals of level L - 1, and the level above the top skill
// is the task (no goal of its own; extrinsic reward). The learner writes a spec into the
// PolicyWeights it publishes (as JSON), so a receiver builds the right network and observation
// before loading the weights.
//
// Observation (features x 1, all normalised to about [-1, 1]):
//   [ state[obs_index[i]] scaled by obs_low/high ... ; relative pairs ; goal ]
// where relative pair k is (state[relative[k].first] - state[relative[k].second]) /
// relative_scale[k] and goal is the level's own goal on its masked features, scaled by the
// target factor's bounds. Learners receive exactly the obs_index features from replay.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "common/env_spec.h"
#include "common/hindsight.h"
#include "common/nn/activation.h"
#include "common/nn/qnet.h"
#include "common/status.h"

namespace coins::policy {

enum class GoalKind { kNone, kDiscrete, kContinuous };
const char* GoalKindName(GoalKind k);

// The goal space of a skill: values of the masked features of one target factor.
struct GoalSpace {
  std::string factor;                        // target factor
  int offset = 0;                            // its first feature in the state
  int features = 0;                          // its features
  std::vector<float> mask;                   // `features` entries, 1 = controlled
  std::vector<int> masked;                   // the indices with mask 1, in order
  std::vector<float> scale_low, scale_high;  // factor bounds of the masked features
  GoalKind kind = GoalKind::kNone;
  std::vector<std::vector<float>> goals;  // discrete: one vector of masked values per goal
  std::vector<float> low, high;           // continuous: bounds of each masked feature
  float epsilon = 0.0f;                   // reached when the distance <= epsilon (env units)
  GoalNorm norm = GoalNorm::kLinf;
  // continuous: random goals (training, evaluation) lie within sample_ratio * (high - low) of
  // the target's value when drawn, as a parent's relative goals do; 0: uniform within the bounds
  float sample_ratio = 0.0f;

  int dim() const { return int(masked.size()); }
  // the masked values of the target in a full state
  void Achieved(const float* state, float* out) const;
  bool Reached(const float* achieved, const float* goal) const;
};

enum class ActionKind {
  kPrimitiveDiscrete,    // num_actions primitive actions
  kPrimitiveContinuous,  // action_dim primitive floats in [-1, 1], scaled to action_low/high
  kChildDiscrete,        // one of the child's discrete goals
  kChildContinuous,      // a in [-1, 1]^d: child goal = child value + a * child_ratio * range
  kChildOffsets,         // one of child_offsets (1-d child goals): value + offset * ratio * range
};
const char* ActionKindName(ActionKind k);

struct LevelSpec {
  std::string name;    // "skill/Paddle", "skill/Ball", "task"
  int level = 0;       // 1..: skills; the task is the top skill's level + 1
  std::string source;  // the link's source factor ("Action" for level 1; "" task)
  GoalSpace goal;      // kind kNone for the task
  // observation
  std::vector<int> obs_index;  // state features, in order
  std::vector<float> obs_low, obs_high;
  std::vector<std::pair<int, int>> relative;  // positions into obs_index: (source, target)
  std::vector<float> relative_scale;
  // actions
  ActionKind action_kind = ActionKind::kPrimitiveDiscrete;
  int num_actions = 0;                         // discrete kinds
  int action_dim = 1;                          // floats the level's action takes (1 for discrete kinds)
  std::vector<float> action_low, action_high;  // kPrimitiveContinuous
  float child_ratio = 0.15f;                   // child goals relative to the child's value (coins-method.md)
  std::vector<float> child_offsets;            // kChildOffsets: the a values, in [-1, 1]
  // temporal structure
  int timeout = 30;                       // env steps before the level's goal times out
  int decision_period = 0;                // env steps per action at most (0: until the child's goal ends)
  bool hold_decision = false;             // with decision_period: each action lasts exactly that many env
                                          // steps (a child that reaches its goal sooner holds it)
  bool terminate_on_interaction = false;  // any detected link interaction ends the goal
  bool require_interaction = false;       // success needs the link interaction
  std::string detector;                   // weights name of the link's detector ("" when none is needed)
  // network
  std::string algorithm = "dqn";         // dqn | ddpg | sac
  std::vector<int> hidden = {128, 128};  // with a pair network: its per-instance point layers
  // a pair network (common/nn/qnet.h) over the instances of pair_factor, which sit at
  // observation rows pair.offset ... (not enabled: an Mlp over the whole observation)
  std::string pair_factor;
  nn::InstanceSplit pair;
  nn::Activation activation = nn::Activation::kRelu;
  bool dueling = true;  // dqn
  int atoms = 51;       // dqn: distributional when > 1
  float v_min = -30.0f, v_max = 0.0f;
  float explore = 0.1f;  // acting: dqn epsilon, ddpg Gaussian noise sigma; sac: > 0 samples the policy

  bool is_task() const { return goal.kind == GoalKind::kNone; }
  bool discrete_actions() const;
  int obs_dim() const { return int(obs_index.size() + relative.size()) + goal.dim(); }
  // outputs of the network's last layer
  int network_outputs() const;
  Status Validate() const;
};

nlohmann::json ToJson(const LevelSpec& spec);
Result<LevelSpec> LevelSpecFromJson(const nlohmann::json& j);
Result<LevelSpec> ParseLevelSpec(const std::string& text);

// a level trained in env `trained` runs unchanged in `target`: every state feature it observes
// (and its goal's target factor) is the same feature there; the error names the first that is not
Status CheckLevelFits(const LevelSpec& spec, const envs::EnvSpec& trained, const envs::EnvSpec& target);

// the goal space of `factor` with `mask`, resolved against spec (offset, bounds); goal values
// and kind are filled by the caller
Result<GoalSpace> MakeGoalSpace(const envs::EnvSpec& spec, const std::string& factor, const std::vector<float>& mask);

}  // namespace coins::policy
