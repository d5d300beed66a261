// Dqn: the Rainbow parts the paper's paddle skill uses — double Q, dueling, n-step returns
// (built by the BatchSource), distributional C51 — plus priority reporting for prioritised
// replay. Discrete actions; observations are obs_dim vectors (goal-conditioned: with the goal
// appended by the source).
//
// Network: a QNet (an Mlp, or a pair network over one factor's instances) obs_dim -> hidden... ->
// (dueling ? 1 + A : A) * K outputs, K = atoms when
// distributional else 1. Loss: cross-entropy against the projected target distribution
// (distributional) or Huber on the TD error, weighted by Batch::weights. The target network is
// copied every target_update_period updates, or Polyak-averaged with tau when tau > 0.
#pragma once

#include <cstdint>
#include <random>
#include <span>
#include <vector>

#include <Eigen/Dense>

#include "common/nn/adam.h"
#include "common/nn/qnet.h"
#include "learner/rl/algorithm_state.h"
#include "learner/rl/batch.h"

namespace coins::rl {

struct DqnOptions {
  int obs_dim = 0;
  int num_actions = 4;                   // the paddle's 4 primitive actions
  std::vector<int> hidden = {128, 128};  // paddle skill MLP 128-128
  nn::InstanceSplit split;               // enabled: a pair network over these instances (common/nn/qnet.h)
  nn::Activation activation = nn::Activation::kRelu;
  bool double_q = true;
  bool dueling = true;
  bool distributional = true;
  int atoms = 51;
  float v_min = -30.0f;  // paddle: returns in [-30, 0]
  float v_max = 0.0f;
  float lr = 7e-4f;
  float grad_clip = 10.0f;          // global gradient-norm clip (0: off)
  int target_update_period = 1000;  // hard copy every N updates (when tau == 0)
  float tau = 0.0f;                 // > 0: soft update every update instead
  float huber_delta = 1.0f;         // non-distributional loss
  int batch_size = 64;
  uint64_t seed = 0;
  Status Validate() const;
};

struct DqnStats {
  float loss = 0.0f;
  float grad_norm = 0.0f;
  float mean_q = 0.0f;  // mean value of the taken actions
};

class Dqn {
 public:
  explicit Dqn(DqnOptions options);  // asserts options.Validate()

  // action values (num_actions x B) of the online network for obs (obs_dim x B)
  void QValues(const Eigen::Ref<const Eigen::MatrixXf>& obs, Eigen::MatrixXf* q);
  // epsilon-greedy action for one observation
  int Act(std::span<const float> obs, float epsilon, std::mt19937_64* rng);

  // one gradient step on batch; writes per-sample priorities (1 x B) when asked
  DqnStats Update(const Batch& batch, Eigen::MatrixXf* priorities = nullptr);
  // the loss of batch and its gradient in online().params().grads, without stepping (the
  // target distribution / value is treated as a constant). Update = this + Adam + target sync.
  DqnStats LossAndGrad(const Batch& batch);
  // per-sample priorities of the last LossAndGrad: cross-entropy (C51) or |TD error|
  const Eigen::MatrixXf& last_priorities() const { return per_sample_; }
  // samples options.batch_size from source, updates, and reports priorities back
  Result<DqnStats> Train(BatchSource* source);

  nn::QNet& online() { return online_; }
  const nn::QNet& online() const { return online_; }
  int64_t updates() const { return updates_; }
  const DqnOptions& options() const { return options_; }
  // the whole training state (online, target, Adam, update count) for checkpoints
  AlgorithmState ExportState() const;
  Status ImportState(const AlgorithmState& state);

 private:
  int atoms() const { return options_.distributional ? options_.atoms : 1; }
  // raw network output -> per-action logits / values ((A * K) x B)
  void Head(const Eigen::MatrixXf& raw, Eigen::MatrixXf* out) const;
  void ToQ(const Eigen::MatrixXf& head, Eigen::MatrixXf* q) const;

  DqnOptions options_;
  nn::QNet online_, target_;
  nn::Adam adam_;
  Eigen::VectorXf support_;
  int64_t updates_ = 0;
  Batch batch_;
  // workspaces
  Eigen::MatrixXf head_, probs_, q_next_, q_target_, target_dist_, dhead_, draw_, per_sample_;
  Eigen::MatrixXf next_probs_, chosen_, target_head_;
  std::vector<int> next_action_;
};

}  // namespace coins::rl
