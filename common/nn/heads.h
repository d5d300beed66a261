// Output heads and their losses, all on batches laid out features x batch.
//
// Every loss returns its value (a mean over the batch, weighted when weights are given) and
// writes d loss / d raw (same shape as raw), ready for a network's Backward.
#pragma once

#include <Eigen/Dense>

namespace coins::nn {

// ---- diagonal Gaussian (the detector models): raw is 2d x B -----------------------------
// mean = tanh(raw[0:d]), std = sigmoid(raw[d:2d]) + min_std
inline constexpr float kGaussianMinStd = 0.01f;

void GaussianMeanStd(const Eigen::Ref<const Eigen::MatrixXf>& raw, float min_std, Eigen::MatrixXf* mean,
                     Eigen::MatrixXf* std);
// per-sample log-likelihood (1 x B) of target (d x B), summed over the d dimensions
void GaussianLogLikelihood(const Eigen::Ref<const Eigen::MatrixXf>& raw,
                           const Eigen::Ref<const Eigen::MatrixXf>& target, float min_std, Eigen::MatrixXf* loglik);
// loss = -(1/B) sum_b w_b loglik_b; weights is 1 x B or empty (all ones)
float GaussianNllLoss(const Eigen::Ref<const Eigen::MatrixXf>& raw, const Eigen::Ref<const Eigen::MatrixXf>& target,
                      const Eigen::Ref<const Eigen::MatrixXf>& weights, float min_std, Eigen::MatrixXf* draw);

// ---- tanh-squashed Gaussian policy (SAC): raw is 2d x B ----------------------------------
// u = raw[0:d] + std * noise, action = tanh(u), log_std = lo + (hi - lo) (tanh(raw[d:]) + 1) / 2
struct SquashedGaussian {
  float log_std_min = -5.0f;
  float log_std_max = 2.0f;

  // noise: d x B standard normal draws (zero for the deterministic action). Writes action
  // (d x B) and log-probability of the action (1 x B).
  void Sample(const Eigen::Ref<const Eigen::MatrixXf>& raw, const Eigen::Ref<const Eigen::MatrixXf>& noise,
              Eigen::MatrixXf* action, Eigen::MatrixXf* logp) const;
  // chain rule for a loss L(action, logp) at fixed noise: given dL/daction (d x B) and
  // dL/dlogp (1 x B), writes dL/draw (2d x B). Uses the same raw and noise as Sample.
  void Backward(const Eigen::Ref<const Eigen::MatrixXf>& raw, const Eigen::Ref<const Eigen::MatrixXf>& noise,
                const Eigen::Ref<const Eigen::MatrixXf>& daction, const Eigen::Ref<const Eigen::MatrixXf>& dlogp,
                Eigen::MatrixXf* draw) const;
};

// ---- categorical heads (C51) -------------------------------------------------------------
// logits: (A * K) x B, action a's K atoms in rows [a K, (a+1) K). probs: softmax per block.
void BlockSoftmax(const Eigen::Ref<const Eigen::MatrixXf>& logits, int atoms, Eigen::MatrixXf* probs);
// expected values: (A x B) = sum_k probs[a K + k] * support[k]; support has K entries
void ExpectedValues(const Eigen::Ref<const Eigen::MatrixXf>& probs, const Eigen::Ref<const Eigen::VectorXf>& support,
                    Eigen::MatrixXf* q);
// cross-entropy of the chosen action's distribution against target (K x B):
// loss = -(1/B) sum_b w_b sum_k target[k,b] log p[a_b K + k, b]. actions: 1 x B (integers as
// floats). Writes dlogits ((A K) x B; zero outside the chosen blocks) and, when per_sample is
// not null, each sample's unweighted cross-entropy (1 x B, for priorities).
float CategoricalCrossEntropy(const Eigen::Ref<const Eigen::MatrixXf>& logits, int atoms,
                              const Eigen::Ref<const Eigen::MatrixXf>& actions,
                              const Eigen::Ref<const Eigen::MatrixXf>& target,
                              const Eigen::Ref<const Eigen::MatrixXf>& weights, Eigen::MatrixXf* dlogits,
                              Eigen::MatrixXf* per_sample);
// the C51 projection of r + discount * z (z = support) with probabilities next_probs (K x B)
// onto the support [v_min, v_max]; rewards and discounts are 1 x B. Writes target (K x B).
void ProjectDistribution(const Eigen::Ref<const Eigen::MatrixXf>& next_probs,
                         const Eigen::Ref<const Eigen::MatrixXf>& rewards,
                         const Eigen::Ref<const Eigen::MatrixXf>& discounts, float v_min, float v_max,
                         Eigen::MatrixXf* target);

// ---- dueling combination -----------------------------------------------------------------
// raw: ((1 + A) * K) x B, the value stream (K rows) then A advantage blocks of K rows.
// out[a K + k] = V[k] + Adv[a K + k] - mean_a' Adv[a' K + k]; K = 1 for scalar Q.
void DuelingForward(const Eigen::Ref<const Eigen::MatrixXf>& raw, int actions, int atoms, Eigen::MatrixXf* out);
void DuelingBackward(const Eigen::Ref<const Eigen::MatrixXf>& dout, int actions, int atoms, Eigen::MatrixXf* draw);

}  // namespace coins::nn
