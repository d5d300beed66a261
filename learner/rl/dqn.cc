#include "learner/rl/dqn.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "common/nn/heads.h"
#include "learner/rl/exploration.h"

namespace coins::rl {

Status DqnOptions::Validate() const {
  if (obs_dim <= 0) return Errorf("dqn: obs_dim {} must be > 0", obs_dim);
  if (num_actions < 2) return Errorf("dqn: num_actions {} must be >= 2", num_actions);
  for (int h : hidden)
    if (h <= 0) return Errorf("dqn: hidden size {} must be > 0", h);
  if (distributional && atoms < 2) return Errorf("dqn: atoms {} must be >= 2", atoms);
  if (distributional && !(v_max > v_min)) return Errorf("dqn: v_max {} must exceed v_min {}", v_max, v_min);
  const nn::QNetOptions net{obs_dim, hidden, 2, activation, nn::Activation::kIdentity, split};
  COINS_RETURN_IF_ERROR(net.Validate().WithContext("dqn"));
  if (!(lr > 0.0f)) return Errorf("dqn: lr {} must be > 0", lr);
  if (tau < 0.0f || tau > 1.0f) return Errorf("dqn: tau {} not in [0, 1]", tau);
  if (tau == 0.0f && target_update_period <= 0)
    return Errorf("dqn: target_update_period {} must be > 0 when tau is 0", target_update_period);
  if (batch_size <= 0) return Errorf("dqn: batch_size {} must be > 0", batch_size);
  return Status::Ok();
}

Dqn::Dqn(DqnOptions options) : options_(std::move(options)) {
  assert(options_.Validate().ok());
  const int outputs = (options_.dueling ? 1 + options_.num_actions : options_.num_actions) * atoms();
  online_ = nn::QNet(
      {options_.obs_dim, options_.hidden, outputs, options_.activation, nn::Activation::kIdentity, options_.split},
      options_.seed);
  target_ = online_;
  adam_ = nn::Adam({.lr = options_.lr, .clip_norm = options_.grad_clip}, online_.params().size());
  support_ = Eigen::VectorXf::LinSpaced(atoms(), options_.v_min, options_.v_max);
}

void Dqn::Head(const Eigen::MatrixXf& raw, Eigen::MatrixXf* out) const {
  if (options_.dueling)
    nn::DuelingForward(raw, options_.num_actions, atoms(), out);
  else
    *out = raw;
}

void Dqn::ToQ(const Eigen::MatrixXf& head, Eigen::MatrixXf* q) const {
  if (!options_.distributional) {
    *q = head;
    return;
  }
  Eigen::MatrixXf probs;
  nn::BlockSoftmax(head, atoms(), &probs);
  nn::ExpectedValues(probs, support_, q);
}

void Dqn::QValues(const Eigen::Ref<const Eigen::MatrixXf>& obs, Eigen::MatrixXf* q) {
  Eigen::MatrixXf head;
  Head(online_.Forward(obs), &head);
  ToQ(head, q);
}

int Dqn::Act(std::span<const float> obs, float epsilon, std::mt19937_64* rng) {
  assert(int(obs.size()) == options_.obs_dim);
  Eigen::MatrixXf q;
  QValues(Eigen::Map<const Eigen::MatrixXf>(obs.data(), options_.obs_dim, 1), &q);
  return EpsilonGreedy(q.col(0), epsilon, rng);
}

DqnStats Dqn::Update(const Batch& batch, Eigen::MatrixXf* priorities) {
  DqnStats stats = LossAndGrad(batch);
  stats.grad_norm = adam_.Step(&online_.params());
  ++updates_;
  // target network
  if (options_.tau > 0.0f)
    nn::SoftUpdate(online_.params(), options_.tau, &target_.params());
  else if (updates_ % options_.target_update_period == 0)
    nn::HardUpdate(online_.params(), &target_.params());
  if (priorities) *priorities = per_sample_;
  return stats;
}

DqnStats Dqn::LossAndGrad(const Batch& batch) {
  const int batch_size = batch.size(), k = atoms();
  assert(batch.obs.rows() == options_.obs_dim);
  DqnStats stats;

  // next actions: argmax of the online net (double Q) or of the target net
  Eigen::MatrixXf& target_head = target_head_;
  Head(target_.Forward(batch.next_obs), &target_head);
  if (options_.double_q) {
    Head(online_.Forward(batch.next_obs), &head_);
    ToQ(head_, &q_next_);
  } else {
    ToQ(target_head, &q_next_);
  }
  std::vector<int>& next_action = next_action_;
  next_action.assign(size_t(batch_size), 0);
  for (int b = 0; b < batch_size; ++b) {
    Eigen::Index best = 0;
    q_next_.col(b).maxCoeff(&best);
    next_action[size_t(b)] = int(best);
  }

  // online forward on the batch (Backward below refers to this pass)
  Head(online_.Forward(batch.obs), &head_);
  if (options_.distributional) {
    // project the target net's distribution for the next action
    nn::BlockSoftmax(target_head, k, &probs_);
    next_probs_.resize(k, batch_size);
    for (int b = 0; b < batch_size; ++b) next_probs_.col(b) = probs_.col(b).segment(next_action[size_t(b)] * k, k);
    nn::ProjectDistribution(next_probs_, batch.rewards, batch.discounts, options_.v_min, options_.v_max, &target_dist_);
    stats.loss =
        nn::CategoricalCrossEntropy(head_, k, batch.actions, target_dist_, batch.weights, &dhead_, &per_sample_);
    ToQ(head_, &q_target_);
  } else {
    // Huber loss on r + discount * Q_target(next, a*) - Q(obs, a)
    q_target_ = head_;
    dhead_.setZero(head_.rows(), batch_size);
    per_sample_.resize(1, batch_size);
    double loss = 0.0;
    const float delta = options_.huber_delta;
    for (int b = 0; b < batch_size; ++b) {
      const int a = int(batch.actions(0, b));
      const float y = batch.rewards(0, b) + batch.discounts(0, b) * target_head(next_action[size_t(b)], b);
      const float td = head_(a, b) - y;
      const float w = batch.weights(0, b);
      const float abs_td = std::abs(td);
      loss += w * (abs_td <= delta ? 0.5f * td * td : delta * (abs_td - 0.5f * delta));
      dhead_(a, b) = w * std::clamp(td, -delta, delta) / float(batch_size);
      per_sample_(0, b) = abs_td;
    }
    stats.loss = float(loss / batch_size);
  }
  double q_sum = 0.0;
  for (int b = 0; b < batch_size; ++b) q_sum += q_target_(int(batch.actions(0, b)), b);
  stats.mean_q = float(q_sum / batch_size);

  // backward through the dueling head and the MLP, then Adam
  if (options_.dueling) {
    nn::DuelingBackward(dhead_, options_.num_actions, k, &draw_);
    online_.Backward(draw_);
  } else {
    online_.Backward(dhead_);
  }
  return stats;
}

AlgorithmState Dqn::ExportState() const {
  AlgorithmState st;
  st.sets = {online_.params(), target_.params()};
  AppendAdam(adam_, "adam", &st);
  st.counters.push_back(updates_);
  return st;
}

Status Dqn::ImportState(const AlgorithmState& st) {
  size_t next = 0, counter = 0;
  COINS_RETURN_IF_ERROR(RestoreParams(st, &next, &online_.params()).WithContext("dqn"));
  COINS_RETURN_IF_ERROR(RestoreParams(st, &next, &target_.params()).WithContext("dqn"));
  COINS_RETURN_IF_ERROR(RestoreAdam(st, &next, &counter, &adam_).WithContext("dqn"));
  if (counter >= st.counters.size()) return Errorf("dqn: state has no update count");
  updates_ = st.counters[counter];
  return Status::Ok();
}

Result<DqnStats> Dqn::Train(BatchSource* source) {
  COINS_RETURN_IF_ERROR(source->Sample(options_.batch_size, &batch_).WithContext("dqn"));
  DqnStats stats = Update(batch_, &chosen_);
  if (!batch_.keys.empty()) source->UpdatePriorities(batch_.keys, {chosen_.data(), size_t(chosen_.size())});
  return stats;
}

}  // namespace coins::rl
