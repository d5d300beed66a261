#include "detector/gaussian_model.h"

#include <algorithm>
#include <cassert>
#include <random>

#include "common/nn/heads.h"

namespace coins::detector {

GaussianModel::GaussianModel(const GaussianModelOptions& options, uint64_t seed) : options_(options) {
  nn::MlpOptions mo;
  mo.sizes.push_back(options.input_dim);
  for (int h : options.hidden) mo.sizes.push_back(h);
  mo.sizes.push_back(2 * options.output_dim);
  mo.hidden = nn::Activation::kLeakyRelu;
  mo.output = nn::Activation::kIdentity;
  net_ = nn::Mlp(mo, seed);
  nn::AdamOptions ao;
  ao.lr = options.lr;
  ao.clip_norm = options.clip_norm;
  adam_ = nn::Adam(ao, net_.params().size());
}

float GaussianModel::Train(const Eigen::MatrixXf& in, const Eigen::MatrixXf& target, const std::vector<int64_t>& pool,
                           const std::vector<float>& weights, int steps, int batch, uint64_t seed,
                           const std::function<bool()>& stop) {
  assert(weights.empty() || weights.size() == pool.size());
  if (pool.empty()) return 0.0f;
  std::mt19937_64 rng(seed);
  // cumulative weights for proportional sampling
  std::vector<double> cum;
  if (!weights.empty()) {
    cum.resize(weights.size());
    double acc = 0.0;
    for (size_t i = 0; i < weights.size(); ++i) cum[i] = acc += weights[i];
  }
  bx_.resize(in.rows(), batch);
  by_.resize(target.rows(), batch);
  const Eigen::MatrixXf no_weights;
  double loss_sum = 0.0;
  int loss_n = 0;
  std::uniform_int_distribution<size_t> uni(0, pool.size() - 1);
  std::uniform_real_distribution<double> ur(0.0, cum.empty() ? 1.0 : cum.back());
  for (int step = 0; step < steps; ++step) {
    if (stop && step % 64 == 0 && stop()) break;
    // draw a batch
    for (int b = 0; b < batch; ++b) {
      size_t k;
      if (cum.empty()) {
        k = uni(rng);
      } else {
        k = size_t(std::upper_bound(cum.begin(), cum.end(), ur(rng)) - cum.begin());
        k = std::min(k, pool.size() - 1);
      }
      bx_.col(b) = in.col(pool[k]);
      by_.col(b) = target.col(pool[k]);
    }
    // one Adam step on the negative log-likelihood
    const Eigen::MatrixXf& raw = net_.Forward(bx_);
    const float loss = nn::GaussianNllLoss(raw, by_, no_weights, options_.min_std, &draw_);
    net_.Backward(draw_);
    adam_.Step(&net_.params());
    if (step >= steps - 100) {
      loss_sum += loss;
      ++loss_n;
    }
  }
  return loss_n ? float(loss_sum / loss_n) : 0.0f;
}

void GaussianModel::WarmStartFrom(const GaussianModel& other, int first_row) {
  assert(options_.hidden == other.options_.hidden);
  assert(options_.output_dim == other.options_.output_dim);
  assert(first_row + other.options_.input_dim <= options_.input_dim);
  nn::ParamSet& p = net_.params();
  const nn::ParamSet& q = other.net_.params();
  for (size_t i = 0; i < p.blocks().size(); ++i) {
    if (i == 0) {
      // layer0.w: hidden x input; the other model's columns go to its input rows
      p.Value(0).setZero();
      p.Value(0).middleCols(first_row, other.options_.input_dim) = q.Value(0);
    } else {
      p.Value(int(i)) = q.Value(int(i));
    }
  }
}

void GaussianModel::LogLikelihood(const Eigen::MatrixXf& in, const Eigen::MatrixXf& target, Eigen::VectorXf* ll) {
  const int64_t m = in.cols();
  ll->resize(m);
  constexpr int64_t kChunk = 4096;
  for (int64_t j = 0; j < m; j += kChunk) {
    const int64_t c = std::min(kChunk, m - j);
    const Eigen::MatrixXf& raw = net_.Forward(in.middleCols(j, c));
    nn::GaussianLogLikelihood(raw, target.middleCols(j, c), options_.min_std, &ll_);
    ll->segment(j, c) = ll_.row(0).transpose();
  }
}

void GaussianModel::Mean(const Eigen::MatrixXf& in, Eigen::MatrixXf* mean) {
  const int64_t m = in.cols();
  mean->resize(options_.output_dim, m);
  constexpr int64_t kChunk = 4096;
  for (int64_t j = 0; j < m; j += kChunk) {
    const int64_t c = std::min(kChunk, m - j);
    const Eigen::MatrixXf& raw = net_.Forward(in.middleCols(j, c));
    nn::GaussianMeanStd(raw, options_.min_std, &mean_, &std_);
    mean->middleCols(j, c) = mean_;
  }
}

}  // namespace coins::detector
