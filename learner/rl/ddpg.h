// Ddpg: deterministic policy gradient with a target actor and critic (Polyak-averaged) over
// continuous actions in [-1, 1]^action_dim; exploration adds Gaussian noise at acting time.
//
// Actor: Mlp obs_dim -> hidden... -> action_dim with tanh output. Critic: Mlp
// [obs; action] -> 1. Critic loss: weighted squared TD error; actor loss: -mean Q(s, mu(s)).
#pragma once

#include <cstdint>
#include <random>
#include <span>
#include <vector>

#include <Eigen/Dense>

#include "common/nn/adam.h"
#include "common/nn/mlp.h"
#include "learner/rl/algorithm_state.h"
#include "learner/rl/batch.h"

namespace coins::rl {

struct DdpgOptions {
  int obs_dim = 0;
  int action_dim = 0;
  std::vector<int> hidden = {128, 128, 128, 128, 128, 128};  // the ball skill's MLP 6x128
  nn::Activation activation = nn::Activation::kRelu;
  float actor_lr = 1e-4f;  // ball skill lr 1e-4
  float critic_lr = 1e-4f;
  float tau = 0.005f;
  float exploration_sigma = 0.1f;  // Gaussian noise std at acting time
  float grad_clip = 0.0f;
  int batch_size = 128;  // ball skill batch 128
  uint64_t seed = 0;
  Status Validate() const;
};

struct DdpgStats {
  float critic_loss = 0.0f;
  float actor_loss = 0.0f;
};

class Ddpg {
 public:
  explicit Ddpg(DdpgOptions options);  // asserts options.Validate()

  // mu(obs), plus N(0, exploration_sigma^2) noise clipped to [-1, 1] when explore
  void Act(std::span<const float> obs, bool explore, std::mt19937_64* rng, std::span<float> action);
  // per-sample |TD error| (1 x B) into priorities when asked
  DdpgStats Update(const Batch& batch, Eigen::MatrixXf* priorities = nullptr);
  Result<DdpgStats> Train(BatchSource* source);
  // the actor loss -mean Q(s, mu(s)) and its gradient in actor().params().grads; no step
  float ActorLossAndGrad(const Eigen::MatrixXf& obs);

  nn::Mlp& actor() { return actor_; }
  const nn::Mlp& actor() const { return actor_; }
  const DdpgOptions& options() const { return options_; }
  int64_t updates() const { return updates_; }
  // the whole training state (actor, critic, targets, both Adams, update count)
  AlgorithmState ExportState() const;
  Status ImportState(const AlgorithmState& state);

 private:
  void Concat(const Eigen::MatrixXf& obs, const Eigen::MatrixXf& act);

  DdpgOptions options_;
  nn::Mlp actor_, critic_, actor_target_, critic_target_;
  nn::Adam actor_adam_, critic_adam_;
  int64_t updates_ = 0;
  Batch batch_;
  Eigen::MatrixXf sa_, act_, y_, d_, da_, prio_;
};

}  // namespace coins::rl
