#include "common/policy/policy_net.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "common/nn/heads.h"
#include "common/nn/serialize.h"

namespace coins::policy {

void GatherFeatures(const LevelSpec& spec, const float* state, float* features) {
  for (size_t i = 0; i < spec.obs_index.size(); ++i) features[i] = state[spec.obs_index[i]];
}

void BuildObservation(const LevelSpec& s, const float* features, const float* goal, float* obs) {
  const size_t n = s.obs_index.size();
  for (size_t i = 0; i < n; ++i) {
    const float mid = 0.5f * (s.obs_high[i] + s.obs_low[i]), half = 0.5f * (s.obs_high[i] - s.obs_low[i]);
    obs[i] = (features[i] - mid) / half;
  }
  for (size_t k = 0; k < s.relative.size(); ++k) {
    const auto [a, b] = s.relative[k];
    obs[n + k] = (features[a] - features[b]) / s.relative_scale[k];
  }
  float* g = obs + n + s.relative.size();
  for (int i = 0; i < s.goal.dim(); ++i) {
    const float lo = s.goal.scale_low[size_t(i)], hi = s.goal.scale_high[size_t(i)];
    g[i] = (goal[i] - 0.5f * (hi + lo)) / (0.5f * (hi - lo));
  }
}

void BuildObservations(const LevelSpec& s, const Eigen::Ref<const Eigen::MatrixXf>& features,
                       const Eigen::Ref<const Eigen::MatrixXf>& goals, Eigen::MatrixXf* obs) {
  const Eigen::Index B = features.cols();
  obs->resize(s.obs_dim(), B);
  for (Eigen::Index b = 0; b < B; ++b)
    BuildObservation(s, features.col(b).data(), s.goal.dim() ? goals.col(b).data() : nullptr, obs->col(b).data());
}

nn::QNetOptions ActingNetworkOptions(const LevelSpec& spec) {
  nn::QNetOptions o;
  o.obs_dim = spec.obs_dim();
  o.hidden = spec.hidden;
  o.outputs = spec.network_outputs();
  o.hidden_act = spec.activation;
  o.output_act = spec.algorithm == "ddpg" ? nn::Activation::kTanh : nn::Activation::kIdentity;
  o.split = spec.pair;
  return o;
}

Result<PolicyNet> PolicyNet::Create(const LevelSpec& spec, uint64_t seed) {
  COINS_RETURN_IF_ERROR(spec.Validate());
  PolicyNet p;
  p.spec_ = spec;
  p.net_ = nn::QNet(ActingNetworkOptions(spec), seed);
  if (spec.algorithm == "dqn" && spec.atoms > 1)
    p.support_ = Eigen::VectorXf::LinSpaced(spec.atoms, spec.v_min, spec.v_max);
  return p;
}

Status PolicyNet::Load(std::span<const uint8_t> blob, const std::string& source) {
  return nn::FromBlob(blob, &net_.params(), source);
}

void PolicyNet::QValues(const float* obs) {
  const Eigen::MatrixXf& raw = net_.Forward(Eigen::Map<const Eigen::MatrixXf>(obs, spec_.obs_dim(), 1));
  const int A = spec_.num_actions, K = spec_.atoms > 1 ? spec_.atoms : 1;
  if (spec_.dueling) {
    nn::DuelingForward(raw, A, K, &head_);
  } else {
    head_ = raw;
  }
  q_.resize(A);
  if (K == 1) {
    q_ = head_.col(0);
    return;
  }
  nn::BlockSoftmax(head_, K, &q_block_);
  for (int a = 0; a < A; ++a) q_[a] = q_block_.col(0).segment(a * K, K).dot(support_);
}

void PolicyNet::Act(const float* obs, float explore, std::mt19937_64* rng, float* action) {
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  if (spec_.discrete_actions()) {
    QValues(obs);
    if (explore > 0.0f && unit(*rng) < explore) {
      action[0] = float(std::uniform_int_distribution<int>(0, spec_.num_actions - 1)(*rng));
      return;
    }
    Eigen::Index best = 0;
    q_.maxCoeff(&best);
    action[0] = float(best);
    return;
  }
  if (spec_.algorithm == "sac") return ActSquashedGaussian(obs, explore > 0.0f, rng, action);
  const Eigen::MatrixXf& mu = net_.Forward(Eigen::Map<const Eigen::MatrixXf>(obs, spec_.obs_dim(), 1));
  std::normal_distribution<float> noise(0.0f, explore > 0.0f ? explore : 1.0f);
  for (int i = 0; i < spec_.action_dim; ++i) {
    float a = mu(i, 0);
    if (explore > 0.0f) a += noise(*rng);
    action[i] = std::clamp(a, -1.0f, 1.0f);
  }
}

// the squashed Gaussian of nn::SquashedGaussian, one action at a time without allocating
void PolicyNet::ActSquashedGaussian(const float* obs, bool sample, std::mt19937_64* rng, float* action) {
  const int d = spec_.action_dim;
  const Eigen::MatrixXf& raw = net_.Forward(Eigen::Map<const Eigen::MatrixXf>(obs, spec_.obs_dim(), 1));
  const nn::SquashedGaussian head;
  std::normal_distribution<float> unit(0.0f, 1.0f);
  for (int i = 0; i < d; ++i) {
    float u = raw(i, 0);
    if (sample) {
      const float log_std =
          head.log_std_min + 0.5f * (head.log_std_max - head.log_std_min) * (std::tanh(raw(d + i, 0)) + 1.0f);
      u += std::exp(log_std) * unit(*rng);
    }
    action[i] = std::clamp(std::tanh(u), -1.0f, 1.0f);
  }
}

}  // namespace coins::policy
