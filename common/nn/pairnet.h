// PairNet: the paper's pair network (a PointNet over instances of the target class).
//
// Input per sample: one source vector s_a (source_dim), N instances s_b of the target class
// (instance_dim each, laid out instance-major in one column), and a mask (N) that is > 0.5 for
// present instances. Each instance becomes a point [s_a; s_b; r], where r holds one relative
// feature per entry of `relative`: scale * s_a[source] + shift - s_b[instance] (the affine maps
// a normalised source feature into the instance feature's units, so r is a true difference of
// positions); a shared per-point MLP (point_sizes, the hidden activation after every layer)
// runs over all N * B points at once; a masked max-pool over instances gives one feature vector
// per sample (zero when no instance is present); dense layers of head_sizes (the hidden
// activation) then one to output_dim (options.output activation) map it to the output.
//
// Parameters are laid out exactly like an Mlp with sizes
// {point_input_dim, point_sizes..., head_sizes..., output_dim}, so with one present instance and
// no relative features the pair-net equals that Mlp on [s_a; s_b] (tested). Like Mlp, workspaces are reused
// across calls and Backward refers to the most recent Forward. Backward can return the gradient with
// respect to the source (a critic's action sits there); the instances' gradient is not provided.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Dense>

#include "common/nn/activation.h"
#include "common/nn/params.h"
#include "common/status.h"

namespace coins::nn {

// one relative feature of every point: scale * s_a[source] + shift - s_b[instance]
struct RelativeFeature {
  int source = 0;    // row of s_a
  int instance = 0;  // row of one instance
  float scale = 1.0f, shift = 0.0f;
};

// `count` relative features s_a[i] - s_b[i], i < count
std::vector<RelativeFeature> LeadingRelative(int count);

struct PairNetOptions {
  int source_dim = 0;                                         // features of s_a (may be 0)
  int instance_dim = 0;                                       // features per instance of s_b
  int max_instances = 1;                                      // N
  std::vector<RelativeFeature> relative;                      // appended to each point, in order
  std::vector<int> point_sizes = {128, 128, 128, 256, 1024};  // the paper's 1-d conv widths
  std::vector<int> head_sizes;  // dense hidden layers after the pool (the paper's 256), then the output layer
  int output_dim = 256;
  Activation hidden = Activation::kRelu;
  Activation output = Activation::kIdentity;
  int point_input_dim() const { return source_dim + instance_dim + int(relative.size()); }
  Status Validate() const;
};

class PairNet {
 public:
  PairNet() = default;
  PairNet(PairNetOptions options, uint64_t seed);  // asserts options.Validate()

  const PairNetOptions& options() const { return options_; }
  int output_dim() const { return options_.output_dim; }

  // source: source_dim x B; instances: (N * instance_dim) x B; mask: N x B (> 0.5 = present).
  // Returns output_dim x B.
  const Eigen::MatrixXf& Forward(const Eigen::Ref<const Eigen::MatrixXf>& source,
                                 const Eigen::Ref<const Eigen::MatrixXf>& instances,
                                 const Eigen::Ref<const Eigen::MatrixXf>& mask);
  // dout: output_dim x B. Writes (or adds, when accumulate) parameter gradients. Returns
  // d loss / d source (source_dim x B) when source_grad, else an empty matrix.
  const Eigen::MatrixXf& Backward(const Eigen::Ref<const Eigen::MatrixXf>& dout, bool source_grad = false,
                                  bool accumulate = false);

  // multiply-adds per sample with all N instances present
  int64_t MacsPerSample() const;

  ParamSet& params() { return params_; }
  const ParamSet& params() const { return params_; }

 private:
  int num_point_layers() const { return int(options_.point_sizes.size()); }
  int num_dense_layers() const { return int(options_.head_sizes.size()) + 1; }  // after the pool
  void SourceGrad();  // source_grad_ from the deltas of the last Backward

  PairNetOptions options_;
  ParamSet params_;
  std::vector<Eigen::MatrixXf> acts_;                     // point activations, P x (N * B); acts_[0] = points
  std::vector<Eigen::MatrixXf> deltas_;                   // point deltas
  Eigen::MatrixXf pooled_;                                // F x B
  std::vector<Eigen::MatrixXf> head_acts_, head_deltas_;  // the dense hidden layers after the pool
  Eigen::ArrayXXi argmax_;                                // F x B: instance index of the max, -1 when none
  Eigen::MatrixXf out_;                                   // output_dim x B
  Eigen::MatrixXf out_delta_;
  Eigen::MatrixXf pooled_grad_;
  Eigen::MatrixXf point_grad_, source_grad_;  // d loss / d points, d loss / d source
  Eigen::MatrixXf empty_;
  std::vector<uint8_t> present_;  // N x B flags of the last Forward
};

}  // namespace coins::nn
