// Observations and network inference of one hierarchy level, for actors and evaluation.
//
// GatherFeatures/BuildObservation turn a full state (or the obs_index features a replay sample
// carries) into the level's observation (common/policy/level_spec.h). PolicyNet is the acting
// network of a level: for dqn the online Q-network (QNet: an Mlp or a pair network; dueling and distributional heads as
// learner/rl/dqn.h builds them, so their weight blobs are interchangeable), for ddpg the
// deterministic actor (an Mlp with tanh outputs, as learner/rl/ddpg.h), for sac the squashed
// Gaussian actor (an Mlp with 2 x action_dim outputs, as learner/rl/sac.h). After the first call Act
// allocates nothing. A PolicyNet is used by one thread at a time.
#pragma once

#include <cstdint>
#include <random>
#include <span>
#include <string>

#include <Eigen/Dense>

#include "common/nn/qnet.h"
#include "common/policy/level_spec.h"

namespace coins::policy {

// features[i] = state[spec.obs_index[i]]
void GatherFeatures(const LevelSpec& spec, const float* state, float* features);
// obs (spec.obs_dim()) from gathered features and the level's goal (masked values, env units;
// unused for the task)
void BuildObservation(const LevelSpec& spec, const float* features, const float* goal, float* obs);
// the same for B columns at once: features (obs_index.size() x B), goals (goal.dim() x B)
void BuildObservations(const LevelSpec& spec, const Eigen::Ref<const Eigen::MatrixXf>& features,
                       const Eigen::Ref<const Eigen::MatrixXf>& goals, Eigen::MatrixXf* obs);

// the shape of a level's acting network (learner/rl builds the same for its online network)
nn::QNetOptions ActingNetworkOptions(const LevelSpec& spec);

class PolicyNet {
 public:
  PolicyNet() = default;
  // an untrained network of the spec's shape (the spec must be valid)
  static Result<PolicyNet> Create(const LevelSpec& spec, uint64_t seed = 0);

  const LevelSpec& spec() const { return spec_; }
  nn::ParamSet& params() { return net_.params(); }
  const nn::ParamSet& params() const { return net_.params(); }
  // loads a weights blob (common/nn/serialize.h) whose blocks match this network
  Status Load(std::span<const uint8_t> blob, const std::string& source);

  // one observation -> action. Discrete: action[0] = the index (epsilon-greedy with `explore`);
  // continuous: action_dim values in [-1, 1]; ddpg adds Gaussian noise of std `explore`
  // (clipped), sac samples its policy when `explore` > 0 and acts with tanh(mean) otherwise.
  void Act(const float* obs, float explore, std::mt19937_64* rng, float* action);
  // action values of the last discrete Act (num_actions)
  const Eigen::VectorXf& last_q() const { return q_; }

 private:
  void QValues(const float* obs);
  void ActSquashedGaussian(const float* obs, bool sample, std::mt19937_64* rng, float* action);

  LevelSpec spec_;
  nn::QNet net_;
  Eigen::VectorXf support_;
  Eigen::MatrixXf head_, q_block_;
  Eigen::VectorXf q_;
};

}  // namespace coins::policy
