// Mlp: a stack of dense layers on batches laid out features x batch (column-major).
//
// Layer l computes a_{l+1} = act(W_l a_l + b_l) with W_l (out x in) and b_l (out x 1); hidden
// layers use options.hidden, the last uses options.output. Parameters live in one ParamSet in
// the order layer0.w, layer0.b, layer1.w, ... (the pair-net relies on this order).
//
// Workspaces (activations and deltas) are kept between calls and reused: after the first call
// at a given batch size, Forward/Backward allocate nothing. Backward uses the activations of
// the most recent Forward, so call them in pairs on the same batch.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Dense>

#include "common/nn/activation.h"
#include "common/nn/params.h"
#include "common/status.h"

namespace coins::nn {

struct MlpOptions {
  std::vector<int> sizes;                     // input, hidden..., output (at least 2 entries)
  Activation hidden = Activation::kRelu;      // after every layer but the last
  Activation output = Activation::kIdentity;  // after the last layer
  Status Validate() const;
};

// the sizes of an Mlp: in, then the hidden layers, then out
inline std::vector<int> LayerSizes(int in, const std::vector<int>& hidden, int out) {
  std::vector<int> s = {in};
  s.insert(s.end(), hidden.begin(), hidden.end());
  s.push_back(out);
  return s;
}

// out = [top; bottom] (rows stacked; both have the same columns), e.g. a critic's (obs, action)
inline void StackRows(const Eigen::MatrixXf& top, const Eigen::MatrixXf& bottom, Eigen::MatrixXf* out) {
  out->resize(top.rows() + bottom.rows(), top.cols());
  out->topRows(top.rows()) = top;
  out->bottomRows(bottom.rows()) = bottom;
}

class Mlp {
 public:
  Mlp() = default;
  // asserts options.Validate(); weights ~ U(-1/sqrt(fan_in), 1/sqrt(fan_in)) from seed
  Mlp(MlpOptions options, uint64_t seed);

  int input_dim() const { return options_.sizes.front(); }
  int output_dim() const { return options_.sizes.back(); }
  int num_layers() const { return int(options_.sizes.size()) - 1; }
  const MlpOptions& options() const { return options_; }

  // x: input_dim x B -> returns output_dim x B (a reference into the workspace)
  const Eigen::MatrixXf& Forward(const Eigen::Ref<const Eigen::MatrixXf>& x);
  // dout: output_dim x B, d loss / d output of the last Forward. Writes parameter gradients
  // into params().grads (added to them when accumulate). Returns d loss / d x (input_dim x B)
  // when input_grad, else an empty matrix.
  const Eigen::MatrixXf& Backward(const Eigen::Ref<const Eigen::MatrixXf>& dout, bool input_grad = false,
                                  bool accumulate = false);

  // multiply-add count of one forward pass per sample (for FLOP figures: 2 FLOP each)
  int64_t MacsPerSample() const;

  ParamSet& params() { return params_; }
  const ParamSet& params() const { return params_; }

 private:
  MlpOptions options_;
  ParamSet params_;
  std::vector<Eigen::MatrixXf> acts_;    // acts_[l]: input of layer l; acts_.back(): output
  std::vector<Eigen::MatrixXf> deltas_;  // deltas_[l]: d loss / d pre-activation of layer l
  Eigen::MatrixXf input_grad_;
  Eigen::MatrixXf empty_;
};

}  // namespace coins::nn
