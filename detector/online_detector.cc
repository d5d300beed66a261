#include "detector/online_detector.h"

#include <algorithm>

namespace coins::detector {

Result<OnlineDetector> OnlineDetector::Create(const DetectorSpec& spec, std::span<const uint8_t> blob, uint64_t seed,
                                              int history) {
  OnlineDetector d;
  d.spec_ = spec;
  auto det = PairDetector::Create(spec.layout, spec.options);
  if (!det.ok()) return det.status();
  d.det_ = std::move(*det);
  if (!d.det_.trained()) return Errorf("detector {}->{} models nothing", spec.layout.source, spec.layout.target);
  COINS_RETURN_IF_ERROR(d.det_.LoadWeights(blob));
  const PairLayout& L = spec.layout;
  const size_t compact = spec.gather.size(), adim = size_t(L.action.dim);
  d.rng_.seed(seed);
  d.history_ = std::max(history, 1);
  d.ring_state_.resize(size_t(d.history_) * compact);
  d.ring_next_.resize(size_t(d.history_) * compact);
  d.ring_action_.resize(size_t(d.history_) * adim);
  d.state_.resize(compact);
  d.next_state_.resize(compact);
  d.pas_in_.resize(L.passive_input_dim(), 1);
  d.act_in_.resize(L.active_input_dim(), 1);
  d.target_.resize(L.output_dim(), 1);
  d.scratch_pas_.resize(L.passive_input_dim(), 1);
  d.scratch_target_.resize(L.output_dim(), 1);
  return d;
}

float OnlineDetector::ActiveLL(const PairTransition& src, const PairTransition& tgt, int instance) {
  EncodeSample(spec_.layout, src, tgt, instance, scratch_pas_.data(), act_in_.data(), scratch_target_.data());
  det_.active().LogLikelihood(act_in_, scratch_target_, &ll_);
  return ll_[0];
}

bool OnlineDetector::TestInstance(int instance, const PairTransition& now) {
  const DetectorOptions& o = spec_.options;
  const PairLayout& L = spec_.layout;
  const bool close = EncodeSample(L, now, now, instance, pas_in_.data(), act_in_.data(), target_.data());
  if (o.proximity_gate && L.has_proximity() && !close) return false;
  det_.passive().LogLikelihood(pas_in_, target_, &ll_);
  last_pas_ = ll_[0];
  if (!(last_pas_ < o.eps_pas)) return false;
  det_.active().LogLikelihood(act_in_, target_, &ll_);
  last_act_ = ll_[0];
  if (!(last_act_ > o.eps_act)) return false;
  if (o.counterfactual_draws <= 0 || stored_ == 0) return true;
  // the source of other transitions must explain the target's change worse
  const size_t compact = spec_.gather.size(), adim = size_t(L.action.dim);
  const int sdim = L.source_input_dim();
  own_source_ = act_in_.col(0).head(sdim);
  float sum = 0.0f;
  for (int k = 0; k < o.counterfactual_draws; ++k) {
    int pick = std::uniform_int_distribution<int>(0, stored_ - 1)(rng_);
    PairTransition other;
    for (int tries = 0; tries < 16; ++tries) {
      other = {{ring_state_.data() + size_t(pick) * compact, compact},
               {ring_action_.data() + size_t(pick) * adim, adim},
               {ring_next_.data() + size_t(pick) * compact, compact}};
      EncodeSample(L, other, now, instance, scratch_pas_.data(), act_in_.data(), scratch_target_.data());
      if (act_in_.col(0).head(sdim) != own_source_) break;
      pick = std::uniform_int_distribution<int>(0, stored_ - 1)(rng_);
    }
    sum += ActiveLL(other, now, instance);
  }
  return last_act_ - sum / float(o.counterfactual_draws) > o.eps_cf;
}

void OnlineDetector::Remember(const PairTransition& now) {
  const size_t compact = spec_.gather.size(), adim = now.action.size();
  std::copy(now.state.begin(), now.state.end(), ring_state_.begin() + size_t(next_) * compact);
  std::copy(now.next_state.begin(), now.next_state.end(), ring_next_.begin() + size_t(next_) * compact);
  std::copy(now.action.begin(), now.action.end(), ring_action_.begin() + size_t(next_) * adim);
  next_ = (next_ + 1) % history_;
  stored_ = std::min(stored_ + 1, history_);
}

bool OnlineDetector::Test(const float* state, const float* action, const float* next_state) {
  for (size_t i = 0; i < spec_.gather.size(); ++i) {
    state_[i] = state[spec_.gather[i]];
    next_state_[i] = next_state[spec_.gather[i]];
  }
  const size_t adim = size_t(spec_.layout.action.dim);
  const PairTransition now{{state_.data(), state_.size()}, {action, adim}, {next_state_.data(), next_state_.size()}};
  last_act_ = last_pas_ = 0.0f;
  bool h = false;
  for (int i = 0; i < spec_.layout.instances && !h; ++i) h = TestInstance(i, now);
  Remember(now);
  return h;
}

}  // namespace coins::detector
