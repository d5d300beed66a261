#include "common/nn/mlp.h"

#include <cassert>
#include <cmath>

namespace coins::nn {

Status MlpOptions::Validate() const {
  if (sizes.size() < 2) return Errorf("mlp needs at least an input and an output size, got {} sizes", sizes.size());
  for (size_t i = 0; i < sizes.size(); ++i)
    if (sizes[i] <= 0) return Errorf("mlp size {} is {}, must be positive", i, sizes[i]);
  return Status::Ok();
}

Mlp::Mlp(MlpOptions options, uint64_t seed) : options_(std::move(options)) {
  assert(options_.Validate().ok());
  std::mt19937_64 rng(seed);
  for (int l = 0; l < num_layers(); ++l) {
    int in = options_.sizes[l], out = options_.sizes[l + 1];
    int w = params_.Add(fmt::format("layer{}.w", l), out, in);
    int b = params_.Add(fmt::format("layer{}.b", l), out, 1);
    float scale = 1.0f / std::sqrt(float(in));
    InitUniform(params_.Value(w), scale, &rng);
    InitUniform(params_.Value(b), scale, &rng);
  }
  acts_.resize(num_layers() + 1);
  deltas_.resize(num_layers());
}

const Eigen::MatrixXf& Mlp::Forward(const Eigen::Ref<const Eigen::MatrixXf>& x) {
  assert(x.rows() == input_dim());
  acts_[0] = x;
  for (int l = 0; l < num_layers(); ++l) {
    auto w = params_.Value(2 * l);
    auto b = params_.Value(2 * l + 1);
    Eigen::MatrixXf& out = acts_[l + 1];
    out.resize(w.rows(), x.cols());
    // dense: out = W a + b, then the activation in place
    out.noalias() = w * acts_[l];
    out.colwise() += b.col(0);
    ApplyActivation(l + 1 == num_layers() ? options_.output : options_.hidden, out);
  }
  return acts_.back();
}

const Eigen::MatrixXf& Mlp::Backward(const Eigen::Ref<const Eigen::MatrixXf>& dout, bool input_grad, bool accumulate) {
  const int n = num_layers();
  assert(dout.rows() == output_dim() && dout.cols() == acts_[0].cols());
  deltas_[n - 1] = dout;
  ActivationBackward(options_.output, acts_[n], deltas_[n - 1]);
  for (int l = n - 1; l >= 0; --l) {
    const Eigen::MatrixXf& delta = deltas_[l];
    auto w = params_.Value(2 * l);
    auto gw = params_.Grad(2 * l);
    auto gb = params_.Grad(2 * l + 1);
    // parameter gradients: dW = delta a^T, db = row sums of delta
    if (accumulate) {
      gw.noalias() += delta * acts_[l].transpose();
      gb.col(0) += delta.rowwise().sum();
    } else {
      gw.noalias() = delta * acts_[l].transpose();
      gb.col(0) = delta.rowwise().sum();
    }
    if (l > 0) {
      // propagate through W and the hidden activation of the layer below
      deltas_[l - 1].resize(w.cols(), delta.cols());
      deltas_[l - 1].noalias() = w.transpose() * delta;
      ActivationBackward(options_.hidden, acts_[l], deltas_[l - 1]);
    } else if (input_grad) {
      input_grad_.resize(w.cols(), delta.cols());
      input_grad_.noalias() = w.transpose() * delta;
    }
  }
  return input_grad ? input_grad_ : empty_;
}

int64_t Mlp::MacsPerSample() const {
  int64_t macs = 0;
  for (int l = 0; l < num_layers(); ++l) macs += int64_t(options_.sizes[l]) * options_.sizes[l + 1];
  return macs;
}

}  // namespace coins::nn
