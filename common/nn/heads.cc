#include "common/nn/heads.h"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace coins::nn {
namespace {
constexpr float kHalfLog2Pi = 0.91893853320467274178f;
constexpr float kSquashEps = 1e-6f;
}  // namespace

void GaussianMeanStd(const Eigen::Ref<const Eigen::MatrixXf>& raw, float min_std, Eigen::MatrixXf* mean,
                     Eigen::MatrixXf* std) {
  assert(raw.rows() % 2 == 0);
  const Eigen::Index d = raw.rows() / 2;
  *mean = raw.topRows(d).array().tanh().matrix();
  *std = ((1.0f + (-raw.bottomRows(d).array()).exp()).inverse() + min_std).matrix();
}

void GaussianLogLikelihood(const Eigen::Ref<const Eigen::MatrixXf>& raw,
                           const Eigen::Ref<const Eigen::MatrixXf>& target, float min_std, Eigen::MatrixXf* loglik) {
  Eigen::MatrixXf mean, std;
  GaussianMeanStd(raw, min_std, &mean, &std);
  assert(target.rows() == mean.rows() && target.cols() == mean.cols());
  auto z = (target - mean).array() / std.array();
  *loglik = (-0.5f * z.square() - std.array().log() - kHalfLog2Pi).colwise().sum().matrix();
}

float GaussianNllLoss(const Eigen::Ref<const Eigen::MatrixXf>& raw, const Eigen::Ref<const Eigen::MatrixXf>& target,
                      const Eigen::Ref<const Eigen::MatrixXf>& weights, float min_std, Eigen::MatrixXf* draw) {
  const Eigen::Index d = raw.rows() / 2, batch = raw.cols();
  Eigen::MatrixXf mean, std;
  GaussianMeanStd(raw, min_std, &mean, &std);
  Eigen::ArrayXXf diff = (target - mean).array();
  Eigen::ArrayXXf s = std.array();
  Eigen::ArrayXXf ll = -0.5f * (diff / s).square() - s.log() - kHalfLog2Pi;
  // per-sample scale of d loss / d loglik
  Eigen::ArrayXXf scale = Eigen::ArrayXXf::Constant(1, batch, -1.0f / float(batch));
  if (weights.size() > 0) scale *= weights.array();
  const float loss = (ll.colwise().sum() * scale).sum();
  // d loglik / d mean-raw and d loglik / d std-raw
  draw->resize(raw.rows(), batch);
  Eigen::ArrayXXf sig = s - min_std;
  draw->topRows(d) = (diff / s.square() * (1.0f - mean.array().square())).matrix();
  draw->bottomRows(d) = ((diff.square() / s.cube() - s.inverse()) * sig * (1.0f - sig)).matrix();
  for (Eigen::Index b = 0; b < batch; ++b) draw->col(b) *= scale(0, b);
  return loss;
}

void SquashedGaussian::Sample(const Eigen::Ref<const Eigen::MatrixXf>& raw,
                              const Eigen::Ref<const Eigen::MatrixXf>& noise, Eigen::MatrixXf* action,
                              Eigen::MatrixXf* logp) const {
  const Eigen::Index d = raw.rows() / 2;
  assert(noise.rows() == d && noise.cols() == raw.cols());
  Eigen::ArrayXXf log_std =
      log_std_min + 0.5f * (log_std_max - log_std_min) * (raw.bottomRows(d).array().tanh() + 1.0f);
  Eigen::ArrayXXf u = raw.topRows(d).array() + log_std.exp() * noise.array();
  Eigen::ArrayXXf a = u.tanh();
  *action = a.matrix();
  *logp = (-0.5f * noise.array().square() - log_std - kHalfLog2Pi - (1.0f - a.square() + kSquashEps).log())
              .colwise()
              .sum()
              .matrix();
}

void SquashedGaussian::Backward(const Eigen::Ref<const Eigen::MatrixXf>& raw,
                                const Eigen::Ref<const Eigen::MatrixXf>& noise,
                                const Eigen::Ref<const Eigen::MatrixXf>& daction,
                                const Eigen::Ref<const Eigen::MatrixXf>& dlogp, Eigen::MatrixXf* draw) const {
  const Eigen::Index d = raw.rows() / 2, batch = raw.cols();
  Eigen::ArrayXXf t = raw.bottomRows(d).array().tanh();
  Eigen::ArrayXXf log_std = log_std_min + 0.5f * (log_std_max - log_std_min) * (t + 1.0f);
  Eigen::ArrayXXf std = log_std.exp();
  Eigen::ArrayXXf a = (raw.topRows(d).array() + std * noise.array()).tanh();
  Eigen::ArrayXXf one_minus = 1.0f - a.square();
  // dlogp broadcast over the d rows
  Eigen::ArrayXXf gl = dlogp.array().replicate(d, 1);
  Eigen::ArrayXXf du = daction.array() * one_minus + gl * 2.0f * a * one_minus / (one_minus + kSquashEps);
  Eigen::ArrayXXf dls = du * std * noise.array() - gl;
  draw->resize(2 * d, batch);
  draw->topRows(d) = du.matrix();
  draw->bottomRows(d) = (dls * 0.5f * (log_std_max - log_std_min) * (1.0f - t.square())).matrix();
}

void BlockSoftmax(const Eigen::Ref<const Eigen::MatrixXf>& logits, int atoms, Eigen::MatrixXf* probs) {
  assert(logits.rows() % atoms == 0);
  probs->resize(logits.rows(), logits.cols());
  const Eigen::Index blocks = logits.rows() / atoms;
  for (Eigen::Index b = 0; b < logits.cols(); ++b)
    for (Eigen::Index a = 0; a < blocks; ++a) {
      auto in = logits.col(b).segment(a * atoms, atoms).array();
      auto out = probs->col(b).segment(a * atoms, atoms).array();
      out = (in - in.maxCoeff()).exp();
      out /= out.sum();
    }
}

void ExpectedValues(const Eigen::Ref<const Eigen::MatrixXf>& probs, const Eigen::Ref<const Eigen::VectorXf>& support,
                    Eigen::MatrixXf* q) {
  const Eigen::Index atoms = support.size(), actions = probs.rows() / atoms;
  q->resize(actions, probs.cols());
  for (Eigen::Index b = 0; b < probs.cols(); ++b)
    for (Eigen::Index a = 0; a < actions; ++a) (*q)(a, b) = probs.col(b).segment(a * atoms, atoms).dot(support);
}

float CategoricalCrossEntropy(const Eigen::Ref<const Eigen::MatrixXf>& logits, int atoms,
                              const Eigen::Ref<const Eigen::MatrixXf>& actions,
                              const Eigen::Ref<const Eigen::MatrixXf>& target,
                              const Eigen::Ref<const Eigen::MatrixXf>& weights, Eigen::MatrixXf* dlogits,
                              Eigen::MatrixXf* per_sample) {
  const Eigen::Index batch = logits.cols();
  [[maybe_unused]] const int blocks = int(logits.rows() / atoms);
  dlogits->setZero(logits.rows(), batch);
  if (per_sample) per_sample->resize(1, batch);
  double loss = 0.0;
  for (Eigen::Index b = 0; b < batch; ++b) {
    const int a = int(actions(0, b));
    assert(a >= 0 && a < blocks);
    auto in = logits.col(b).segment(a * atoms, atoms).array();
    // log-softmax of the chosen block
    const float mx = in.maxCoeff();
    const float lse = mx + std::log((in - mx).exp().sum());
    Eigen::ArrayXf logp = in - lse;
    auto t = target.col(b).array();
    const float ce = -(t * logp).sum();
    const float w = weights.size() > 0 ? weights(0, b) : 1.0f;
    loss += double(w) * ce;
    if (per_sample) (*per_sample)(0, b) = ce;
    dlogits->col(b).segment(a * atoms, atoms) = ((logp.exp() * t.sum() - t) * (w / float(batch))).matrix();
  }
  return float(loss / double(batch));
}

void ProjectDistribution(const Eigen::Ref<const Eigen::MatrixXf>& next_probs,
                         const Eigen::Ref<const Eigen::MatrixXf>& rewards,
                         const Eigen::Ref<const Eigen::MatrixXf>& discounts, float v_min, float v_max,
                         Eigen::MatrixXf* target) {
  const Eigen::Index atoms = next_probs.rows(), batch = next_probs.cols();
  assert(atoms >= 2);
  const float dz = (v_max - v_min) / float(atoms - 1);
  target->setZero(atoms, batch);
  for (Eigen::Index b = 0; b < batch; ++b)
    for (Eigen::Index k = 0; k < atoms; ++k) {
      const float z = v_min + dz * float(k);
      float tz = std::clamp(rewards(0, b) + discounts(0, b) * z, v_min, v_max);
      const float pos = (tz - v_min) / dz;
      const Eigen::Index lo = std::min<Eigen::Index>(Eigen::Index(std::floor(pos)), atoms - 1);
      const Eigen::Index hi = std::min<Eigen::Index>(lo + 1, atoms - 1);
      const float p = next_probs(k, b);
      const float frac = pos - float(lo);
      if (hi == lo) {
        (*target)(lo, b) += p;
      } else {
        (*target)(lo, b) += p * (1.0f - frac);
        (*target)(hi, b) += p * frac;
      }
    }
}

void DuelingForward(const Eigen::Ref<const Eigen::MatrixXf>& raw, int actions, int atoms, Eigen::MatrixXf* out) {
  assert(raw.rows() == (1 + actions) * atoms);
  const Eigen::Index batch = raw.cols();
  out->resize(actions * atoms, batch);
  Eigen::MatrixXf mean = Eigen::MatrixXf::Zero(atoms, batch);
  for (int a = 0; a < actions; ++a) mean += raw.middleRows((1 + a) * atoms, atoms);
  mean /= float(actions);
  for (int a = 0; a < actions; ++a)
    out->middleRows(a * atoms, atoms) = raw.topRows(atoms) + raw.middleRows((1 + a) * atoms, atoms) - mean;
}

void DuelingBackward(const Eigen::Ref<const Eigen::MatrixXf>& dout, int actions, int atoms, Eigen::MatrixXf* draw) {
  const Eigen::Index batch = dout.cols();
  draw->resize((1 + actions) * atoms, batch);
  Eigen::MatrixXf sum = Eigen::MatrixXf::Zero(atoms, batch);
  for (int a = 0; a < actions; ++a) sum += dout.middleRows(a * atoms, atoms);
  draw->topRows(atoms) = sum;
  for (int a = 0; a < actions; ++a)
    draw->middleRows((1 + a) * atoms, atoms) = dout.middleRows(a * atoms, atoms) - sum / float(actions);
}

}  // namespace coins::nn
