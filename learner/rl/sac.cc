#include "learner/rl/sac.h"

#include <cassert>

namespace coins::rl {
namespace {

void FillNormal(Eigen::MatrixXf* m, int rows, int cols, std::mt19937_64* rng) {
  std::normal_distribution<float> n(0.0f, 1.0f);
  m->resize(rows, cols);
  for (Eigen::Index i = 0; i < m->size(); ++i) m->data()[i] = n(*rng);
}

}  // namespace

Status SacOptions::Validate() const {
  if (obs_dim <= 0 || action_dim <= 0)
    return Errorf("sac: obs_dim {} and action_dim {} must be > 0", obs_dim, action_dim);
  for (int h : hidden)
    if (h <= 0) return Errorf("sac: hidden size {} must be > 0", h);
  if (!(actor_lr > 0.0f && critic_lr > 0.0f && alpha_lr > 0.0f)) return Errorf("sac: learning rates must be > 0");
  if (!(tau > 0.0f && tau <= 1.0f)) return Errorf("sac: tau {} not in (0, 1]", tau);
  if (!(init_alpha > 0.0f)) return Errorf("sac: init_alpha {} must be > 0", init_alpha);
  if (batch_size <= 0) return Errorf("sac: batch_size {} must be > 0", batch_size);
  if (hidden.empty()) return Errorf("sac: at least one hidden layer");
  if (split.enabled())
    if (Status st = nn::QNetOptions{obs_dim, hidden, 1, activation, activation, split}.Validate(); !st.ok())
      return st.WithContext("sac");
  return Status::Ok();
}

nn::QNetOptions Sac::Network(int in, int out) const {
  return {in, options_.hidden, out, options_.activation, nn::Activation::kIdentity, options_.split};
}

Sac::Sac(SacOptions options) : options_(std::move(options)), rng_(options_.seed ^ 0x5ac) {
  assert(options_.Validate().ok());
  const int od = options_.obs_dim, ad = options_.action_dim;
  actor_ = nn::QNet(Network(od, 2 * ad), options_.seed);
  q1_ = nn::QNet(Network(od + ad, 1), options_.seed + 1);
  q2_ = nn::QNet(Network(od + ad, 1), options_.seed + 2);
  q1_target_ = q1_;
  q2_target_ = q2_;
  const float clip = options_.grad_clip;
  actor_adam_ = nn::Adam({.lr = options_.actor_lr, .clip_norm = clip}, actor_.params().size());
  q1_adam_ = nn::Adam({.lr = options_.critic_lr, .clip_norm = clip}, q1_.params().size());
  q2_adam_ = nn::Adam({.lr = options_.critic_lr, .clip_norm = clip}, q2_.params().size());
  log_alpha_.Add("log_alpha", 1, 1);
  log_alpha_.values[0] = std::log(options_.init_alpha);
  alpha_adam_ = nn::Adam({.lr = options_.alpha_lr}, 1);
  target_entropy_ = std::isnan(options_.target_entropy) ? -float(ad) : options_.target_entropy;
}

void Sac::Concat(const Eigen::MatrixXf& obs, const Eigen::MatrixXf& act) { nn::StackRows(obs, act, &sa_); }

void Sac::Act(std::span<const float> obs, bool deterministic, std::mt19937_64* rng, std::span<float> action) {
  const int ad = options_.action_dim;
  assert(int(obs.size()) == options_.obs_dim && int(action.size()) == ad);
  Eigen::MatrixXf raw = actor_.Forward(Eigen::Map<const Eigen::MatrixXf>(obs.data(), obs.size(), 1));
  Eigen::MatrixXf noise = Eigen::MatrixXf::Zero(ad, 1), a, logp;
  if (!deterministic) FillNormal(&noise, ad, 1, rng);
  head_.Sample(raw, noise, &a, &logp);
  for (int i = 0; i < ad; ++i) action[size_t(i)] = a(i, 0);
}

SacStats Sac::Update(const Batch& batch, Eigen::MatrixXf* priorities) {
  const int bs = batch.size(), ad = options_.action_dim;
  const float inv_b = 1.0f / float(bs);
  const float alpha = this->alpha();
  SacStats stats;

  // soft target: r + discount * (min Q_target(s', a') - alpha log pi(a'|s'))
  raw_ = actor_.Forward(batch.next_obs);
  FillNormal(&noise_, ad, bs, &rng_);
  head_.Sample(raw_, noise_, &act_, &logp_);
  Concat(batch.next_obs, act_);
  q1v_ = q1_target_.Forward(sa_);
  q2v_ = q2_target_.Forward(sa_);
  y_ = batch.rewards.array() + batch.discounts.array() * (q1v_.cwiseMin(q2v_).array() - alpha * logp_.array());

  // critics: weighted squared TD error
  Concat(batch.obs, batch.actions);
  for (auto [q, adam] : {std::pair{&q1_, &q1_adam_}, std::pair{&q2_, &q2_adam_}}) {
    d_ = q->Forward(sa_) - y_;
    if (q == &q1_) prio_ = d_.cwiseAbs();
    stats.critic_loss += 0.5f * (d_.array().square() * batch.weights.array()).sum() * inv_b;
    d_.array() *= batch.weights.array() * inv_b;
    q->Backward(d_);
    adam->Step(&q->params());
  }

  // actor, through the reparameterised sample
  FillNormal(&actor_noise_, ad, bs, &rng_);
  stats.actor_loss = ActorLossAndGrad(batch.obs, actor_noise_, &stats.entropy);
  actor_adam_.Step(&actor_.params());

  // temperature: d/dlog_alpha of -log_alpha (log pi + target_entropy)
  if (options_.auto_alpha) {
    log_alpha_.grads[0] = -(logp_.array() + target_entropy_).mean();
    alpha_adam_.Step(&log_alpha_);
  }
  stats.alpha = this->alpha();

  nn::SoftUpdate(q1_.params(), options_.tau, &q1_target_.params());
  nn::SoftUpdate(q2_.params(), options_.tau, &q2_target_.params());
  if (priorities) *priorities = prio_;
  ++updates_;
  return stats;
}

AlgorithmState Sac::ExportState() const {
  AlgorithmState st;
  st.sets = {actor_.params(), q1_.params(), q2_.params(), q1_target_.params(), q2_target_.params(), log_alpha_};
  AppendAdam(actor_adam_, "actor_adam", &st);
  AppendAdam(q1_adam_, "q1_adam", &st);
  AppendAdam(q2_adam_, "q2_adam", &st);
  AppendAdam(alpha_adam_, "alpha_adam", &st);
  st.counters.push_back(updates_);
  return st;
}

Status Sac::ImportState(const AlgorithmState& st) {
  size_t next = 0, counter = 0;
  for (nn::QNet* net : {&actor_, &q1_, &q2_, &q1_target_, &q2_target_})
    COINS_RETURN_IF_ERROR(RestoreParams(st, &next, &net->params()).WithContext("sac"));
  COINS_RETURN_IF_ERROR(RestoreParams(st, &next, &log_alpha_).WithContext("sac temperature"));
  for (nn::Adam* adam : {&actor_adam_, &q1_adam_, &q2_adam_, &alpha_adam_})
    COINS_RETURN_IF_ERROR(RestoreAdam(st, &next, &counter, adam).WithContext("sac"));
  if (counter >= st.counters.size()) return Errorf("sac: state has no update count");
  updates_ = st.counters[counter];
  return Status::Ok();
}

float Sac::ActorLossAndGrad(const Eigen::MatrixXf& obs, const Eigen::MatrixXf& noise, float* entropy) {
  const int bs = int(obs.cols()), ad = options_.action_dim;
  const float inv_b = 1.0f / float(bs);
  const float alpha = this->alpha();
  raw_ = actor_.Forward(obs);
  head_.Sample(raw_, noise, &act_, &logp_);
  Concat(obs, act_);
  q1v_ = q1_.Forward(sa_);
  q2v_ = q2_.Forward(sa_);
  // the smaller critic per sample carries the gradient
  Eigen::MatrixXf pick1 = (q1v_.array() <= q2v_.array()).cast<float>().matrix();
  Eigen::MatrixXf pick2 = Eigen::MatrixXf::Ones(1, bs) - pick1;
  const float loss = (alpha * logp_.array() - q1v_.cwiseMin(q2v_).array()).mean();
  da_ = q1_.Backward(-inv_b * pick1, /*input_grad=*/true).bottomRows(ad);
  da_ += q2_.Backward(-inv_b * pick2, /*input_grad=*/true).bottomRows(ad);
  dlogp_ = Eigen::MatrixXf::Constant(1, bs, alpha * inv_b);
  head_.Backward(raw_, noise, da_, dlogp_, &draw_);
  actor_.Backward(draw_);
  if (entropy) *entropy = -logp_.mean();
  return loss;
}

Result<SacStats> Sac::Train(BatchSource* source) {
  COINS_RETURN_IF_ERROR(source->Sample(options_.batch_size, &batch_).WithContext("sac"));
  SacStats stats = Update(batch_, &prio_);
  if (!batch_.keys.empty()) source->UpdatePriorities(batch_.keys, {prio_.data(), size_t(prio_.size())});
  return stats;
}

}  // namespace coins::rl
