// Sac: soft actor-critic with twin critics, target critics and automatic temperature, over
// continuous actions in [-1, 1]^action_dim (callers scale to their bounds).
//
// Actor: obs_dim -> hidden... -> 2 * action_dim, read by nn::SquashedGaussian.
// Critics: two networks [obs; action] -> 1, with Polyak-averaged targets (tau).
// Every network is an nn::QNet: an Mlp, or with a split a pair network over the instances of one
// multi-instance factor (the pushing obstacles); the critics' action joins the source part.
// Temperature: log alpha learned so that the policy entropy tracks target_entropy
// (default -action_dim) when auto_alpha, else fixed at init_alpha.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>
#include <span>
#include <vector>

#include <Eigen/Dense>

#include "common/nn/adam.h"
#include "common/nn/heads.h"
#include "common/nn/mlp.h"
#include "common/nn/qnet.h"
#include "learner/rl/algorithm_state.h"
#include "learner/rl/batch.h"

namespace coins::rl {

struct SacOptions {
  int obs_dim = 0;
  int action_dim = 0;
  std::vector<int> hidden = {256, 256};  // gripper skill size; the block skill uses 256x4-128
  nn::InstanceSplit split;               // a pair network's instances in obs (none: Mlps)
  nn::Activation activation = nn::Activation::kRelu;
  float actor_lr = 2e-4f;  // block skill lr 2e-4
  float critic_lr = 2e-4f;
  float alpha_lr = 2e-4f;
  float tau = 0.005f;
  float init_alpha = 0.2f;  // the block skill's alpha 0.2
  bool auto_alpha = true;
  float target_entropy = NAN;  // NaN: -action_dim
  float grad_clip = 0.0f;      // 0: no clipping
  int batch_size = 256;
  uint64_t seed = 0;
  Status Validate() const;
};

struct SacStats {
  float critic_loss = 0.0f;
  float actor_loss = 0.0f;
  float alpha = 0.0f;
  float entropy = 0.0f;  // -mean log pi of the sampled actions
};

class Sac {
 public:
  explicit Sac(SacOptions options);  // asserts options.Validate()

  // one action in [-1, 1]^action_dim: tanh(mean) when deterministic, else a policy sample
  void Act(std::span<const float> obs, bool deterministic, std::mt19937_64* rng, std::span<float> action);
  // per-sample |TD error| of the first critic (1 x B) into priorities when asked
  SacStats Update(const Batch& batch, Eigen::MatrixXf* priorities = nullptr);
  // the actor loss mean(alpha log pi(a|s) - min_i Q_i(s, a)) at a = tanh(mean + std * noise)
  // (noise: action_dim x B) and its gradient in actor().params().grads; no step is taken.
  // Writes -mean log pi into entropy when not null.
  float ActorLossAndGrad(const Eigen::MatrixXf& obs, const Eigen::MatrixXf& noise, float* entropy = nullptr);
  Result<SacStats> Train(BatchSource* source);

  float alpha() const { return std::exp(log_alpha_.values[0]); }
  nn::QNet& actor() { return actor_; }
  const nn::QNet& actor() const { return actor_; }
  const SacOptions& options() const { return options_; }
  int64_t updates() const { return updates_; }
  // the whole training state (actor, both critics and their targets, the temperature, all
  // four Adams, the update count); the sampling generator restarts from the seed
  AlgorithmState ExportState() const;
  Status ImportState(const AlgorithmState& state);

 private:
  void Concat(const Eigen::MatrixXf& obs, const Eigen::MatrixXf& act);  // -> sa_
  nn::QNetOptions Network(int in, int out) const;                       // in -> hidden... -> out

  SacOptions options_;
  nn::SquashedGaussian head_;
  nn::QNet actor_, q1_, q2_, q1_target_, q2_target_;
  nn::Adam actor_adam_, q1_adam_, q2_adam_, alpha_adam_;
  nn::ParamSet log_alpha_;
  float target_entropy_ = 0.0f;
  int64_t updates_ = 0;
  std::mt19937_64 rng_;
  Batch batch_;
  Eigen::MatrixXf sa_, raw_, noise_, actor_noise_, act_, logp_, y_, q1v_, q2v_, d_, da_, dlogp_, draw_, prio_;
};

}  // namespace coins::rl
