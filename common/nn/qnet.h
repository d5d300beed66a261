// QNet: the network of one hierarchy level (a dqn's Q-network, a ddpg actor), over a flat
// observation column. Either an Mlp over the whole observation, or, with an InstanceSplit, a
// PairNet (pairnet.h) whose points are the instances of one multi-instance factor (the blocks)
// that sit contiguously in the observation, each joined with the rest of the observation; an
// instance whose presence feature is 0 (|x| <= 0.5: a broken block) is left out of the pool,
// and a class without a presence feature (presence -1: obstacles) has every instance present.
// Each point may also carry relative features (another factor's position minus the instance's).
// A pair network's weights do not depend on the number of instances, so one trained on 100
// blocks runs on a board of 10.
//
// Same contract as Mlp: Forward then Backward on the same batch, workspaces reused (no
// allocation after the first call at a batch size), all parameters in one ParamSet.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Dense>

#include "common/nn/activation.h"
#include "common/nn/mlp.h"
#include "common/nn/pairnet.h"
#include "common/nn/params.h"
#include "common/status.h"

namespace coins::nn {

struct InstanceSplit {
  int offset = 0;        // first observation row of the instances
  int instances = 0;     // N; 0: no split (a plain Mlp)
  int instance_dim = 0;  // rows per instance
  int presence = 0;      // the instance's row that is non-zero while it is present; -1: always present
  // relative features of every point (pairnet.h); here `source` is an observation row outside
  // the instances and `instance` a row of one instance
  std::vector<RelativeFeature> relative;
  std::vector<int> head;  // dense hidden layers between the pool and the outputs (pairnet.h)
  bool enabled() const { return instances > 0; }
};

struct QNetOptions {
  int obs_dim = 0;
  std::vector<int> hidden;  // Mlp hidden layers; with a split, the per-instance point layers
  int outputs = 0;
  Activation hidden_act = Activation::kRelu;
  Activation output_act = Activation::kIdentity;
  InstanceSplit split;
  Status Validate() const;
};

class QNet {
 public:
  QNet() = default;
  QNet(QNetOptions options, uint64_t seed);  // asserts options.Validate()

  const QNetOptions& options() const { return options_; }
  // obs: obs_dim x B -> outputs x B
  const Eigen::MatrixXf& Forward(const Eigen::Ref<const Eigen::MatrixXf>& obs);
  // dout: outputs x B of the last Forward; writes parameter gradients. Returns d loss / d obs
  // (obs_dim x B) when input_grad, else an empty matrix; with a split the instance rows are 0
  // (a critic needs only its action's rows, which lie outside the instances).
  const Eigen::MatrixXf& Backward(const Eigen::Ref<const Eigen::MatrixXf>& dout, bool input_grad = false);

  ParamSet& params() { return options_.split.enabled() ? pair_.params() : mlp_.params(); }
  const ParamSet& params() const { return options_.split.enabled() ? pair_.params() : mlp_.params(); }

 private:
  QNetOptions options_;
  Mlp mlp_;
  PairNet pair_;
  Eigen::MatrixXf source_, mask_;  // the split of the last Forward (the instances are read in place)
  Eigen::MatrixXf input_grad_;
};

}  // namespace coins::nn
