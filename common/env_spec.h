// Environment descriptions: the factors of a factored state, the action space and the
// interaction pairs a simulator labels. Plain data that every role needs (the detector, the
// learner and the actors) without running a simulator; actors/envs/env.h builds on it.
//
// A state is a flat float vector: the factors laid out one after another, each factor
// `instances x features` floats (instance-major). A discrete action is one float holding the
// integer index. FactorSpec::low/high are the normalisation bounds the learners use.
#pragma once

#include <string>
#include <vector>

namespace coins::envs {

struct FactorSpec {
  std::string name;             // "Paddle", "Ball", "Block", "Gripper", ...
  int features = 0;             // features per instance
  int instances = 1;            // > 1 for multi-instance classes (Block, Obstacle)
  bool multi_instance = false;  // a class of instances (Block, Obstacle), even with 1 instance
  std::vector<float> low;       // per-feature normalisation bounds, size features
  std::vector<float> high;
  std::vector<std::string> feature_names;  // e.g. {"y", "x", "vy", "vx", "attr"}
  int size() const { return features * instances; }
};

struct ActionSpec {
  bool discrete = true;
  int n = 0;               // number of discrete actions (discrete only)
  int dim = 1;             // floats per action: 1 for discrete, d for continuous
  std::vector<float> low;  // continuous bounds, size dim
  std::vector<float> high;
};

// One ground-truth interaction the simulator can label, "Source->Target".
struct InteractionPair {
  std::string source;
  std::string target;
  std::string label() const { return source + "->" + target; }
};

struct EnvSpec {
  std::string name;
  std::vector<FactorSpec> factors;
  ActionSpec action;
  std::vector<InteractionPair> interactions;  // bit i of StepResult::interactions
  int max_episode_steps = 0;                  // 0: no time limit
  // what evaluations report about a task: what a terminal step means ("the block reached the
  // goal"; empty: not reported) and which step rewards are penalties (reward <= penalty_reward,
  // "the block in a negative region or out of bounds"; empty penalty_means: none)
  std::string done_means;
  std::string penalty_means;
  float penalty_reward = 0.0f;

  int state_dim() const;
  // index of the factor with this name, or -1
  int factor_index(const std::string& name) const;
  // offset of factor i's first float in the state vector
  int factor_offset(int i) const;
  // what state feature `index` is: "Ball.vy", "Block[3].attr"; "outside the state" past its end
  std::string feature_name(int index) const;
};

}  // namespace coins::envs
