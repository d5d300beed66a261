#include "learner/rl/ddpg.h"

#include <cassert>

#include "learner/rl/exploration.h"

namespace coins::rl {

Status DdpgOptions::Validate() const {
  if (obs_dim <= 0 || action_dim <= 0)
    return Errorf("ddpg: obs_dim {} and action_dim {} must be > 0", obs_dim, action_dim);
  for (int h : hidden)
    if (h <= 0) return Errorf("ddpg: hidden size {} must be > 0", h);
  if (!(actor_lr > 0.0f && critic_lr > 0.0f)) return Errorf("ddpg: learning rates must be > 0");
  if (!(tau > 0.0f && tau <= 1.0f)) return Errorf("ddpg: tau {} not in (0, 1]", tau);
  if (exploration_sigma < 0.0f) return Errorf("ddpg: exploration_sigma {} must be >= 0", exploration_sigma);
  if (batch_size <= 0) return Errorf("ddpg: batch_size {} must be > 0", batch_size);
  return Status::Ok();
}

Ddpg::Ddpg(DdpgOptions options) : options_(std::move(options)) {
  assert(options_.Validate().ok());
  const int od = options_.obs_dim, ad = options_.action_dim;
  auto sizes = [&](int in, int out) { return nn::LayerSizes(in, options_.hidden, out); };
  actor_ = nn::Mlp({sizes(od, ad), options_.activation, nn::Activation::kTanh}, options_.seed);
  critic_ = nn::Mlp({sizes(od + ad, 1), options_.activation, nn::Activation::kIdentity}, options_.seed + 1);
  actor_target_ = actor_;
  critic_target_ = critic_;
  actor_adam_ = nn::Adam({.lr = options_.actor_lr, .clip_norm = options_.grad_clip}, actor_.params().size());
  critic_adam_ = nn::Adam({.lr = options_.critic_lr, .clip_norm = options_.grad_clip}, critic_.params().size());
}

void Ddpg::Concat(const Eigen::MatrixXf& obs, const Eigen::MatrixXf& act) { nn::StackRows(obs, act, &sa_); }

void Ddpg::Act(std::span<const float> obs, bool explore, std::mt19937_64* rng, std::span<float> action) {
  assert(int(obs.size()) == options_.obs_dim && int(action.size()) == options_.action_dim);
  const Eigen::MatrixXf& mu = actor_.Forward(Eigen::Map<const Eigen::MatrixXf>(obs.data(), obs.size(), 1));
  for (size_t i = 0; i < action.size(); ++i) action[i] = mu(Eigen::Index(i), 0);
  if (explore) AddGaussianNoise(action, options_.exploration_sigma, -1.0f, 1.0f, rng);
}

DdpgStats Ddpg::Update(const Batch& batch, Eigen::MatrixXf* priorities) {
  const int bs = batch.size();
  const float inv_b = 1.0f / float(bs);
  DdpgStats stats;

  // target: r + discount * Q_target(s', mu_target(s'))
  act_ = actor_target_.Forward(batch.next_obs);
  Concat(batch.next_obs, act_);
  y_ = batch.rewards.array() + batch.discounts.array() * critic_target_.Forward(sa_).array();

  // critic
  Concat(batch.obs, batch.actions);
  d_ = critic_.Forward(sa_) - y_;
  prio_ = d_.cwiseAbs();
  stats.critic_loss = 0.5f * (d_.array().square() * batch.weights.array()).sum() * inv_b;
  d_.array() *= batch.weights.array() * inv_b;
  critic_.Backward(d_);
  critic_adam_.Step(&critic_.params());

  // actor: ascend Q(s, mu(s)) through the critic's input gradient
  stats.actor_loss = ActorLossAndGrad(batch.obs);
  actor_adam_.Step(&actor_.params());

  nn::SoftUpdate(actor_.params(), options_.tau, &actor_target_.params());
  nn::SoftUpdate(critic_.params(), options_.tau, &critic_target_.params());
  if (priorities) *priorities = prio_;
  ++updates_;
  return stats;
}

AlgorithmState Ddpg::ExportState() const {
  AlgorithmState st;
  st.sets = {actor_.params(), critic_.params(), actor_target_.params(), critic_target_.params()};
  AppendAdam(actor_adam_, "actor_adam", &st);
  AppendAdam(critic_adam_, "critic_adam", &st);
  st.counters.push_back(updates_);
  return st;
}

Status Ddpg::ImportState(const AlgorithmState& st) {
  size_t next = 0, counter = 0;
  for (nn::Mlp* net : {&actor_, &critic_, &actor_target_, &critic_target_})
    COINS_RETURN_IF_ERROR(RestoreParams(st, &next, &net->params()).WithContext("ddpg"));
  COINS_RETURN_IF_ERROR(RestoreAdam(st, &next, &counter, &actor_adam_).WithContext("ddpg"));
  COINS_RETURN_IF_ERROR(RestoreAdam(st, &next, &counter, &critic_adam_).WithContext("ddpg"));
  if (counter >= st.counters.size()) return Errorf("ddpg: state has no update count");
  updates_ = st.counters[counter];
  return Status::Ok();
}

float Ddpg::ActorLossAndGrad(const Eigen::MatrixXf& obs) {
  const int bs = int(obs.cols()), ad = options_.action_dim;
  act_ = actor_.Forward(obs);
  Concat(obs, act_);
  const float loss = -critic_.Forward(sa_).mean();
  da_ = critic_.Backward(Eigen::MatrixXf::Constant(1, bs, -1.0f / float(bs)), /*input_grad=*/true).bottomRows(ad);
  actor_.Backward(da_);
  return loss;
}

Result<DdpgStats> Ddpg::Train(BatchSource* source) {
  COINS_RETURN_IF_ERROR(source->Sample(options_.batch_size, &batch_).WithContext("ddpg"));
  DdpgStats stats = Update(batch_, &prio_);
  if (!batch_.keys.empty()) source->UpdatePriorities(batch_.keys, {prio_.data(), size_t(prio_.size())});
  return stats;
}

}  // namespace coins::rl
