// Adam with global gradient-norm clipping, over a network's flat ParamSet.
//
// One Step: g = grads, scaled by clip_norm / ||g|| when clip_norm > 0 and ||g|| > clip_norm;
// m = b1 m + (1 - b1) g; v = b2 v + (1 - b2) g^2; t += 1;
// values -= lr * (m / (1 - b1^t)) / (sqrt(v / (1 - b2^t)) + eps). Allocates nothing.
#pragma once

#include <cstdint>

#include <Eigen/Dense>

#include "common/nn/params.h"
#include "common/status.h"

namespace coins::nn {

struct AdamOptions {
  float lr = 1e-4f;  // the detector models' rate in coins-method.md; skills set their own
  float beta1 = 0.9f;
  float beta2 = 0.999f;
  float eps = 1e-8f;
  float clip_norm = 0.0f;  // global L2 gradient-norm clip; 0 turns clipping off
  Status Validate() const;
};

class Adam {
 public:
  Adam() = default;
  Adam(AdamOptions options, int64_t size);  // size: the ParamSet's size()

  // applies one update from params->grads; returns the gradient norm before clipping
  float Step(ParamSet* params);

  int64_t steps() const { return t_; }
  const AdamOptions& options() const { return options_; }
  void set_lr(float lr) { options_.lr = lr; }
  const Eigen::VectorXf& first_moment() const { return m_; }
  const Eigen::VectorXf& second_moment() const { return v_; }
  // restores the moments and step count of a checkpoint; false when the sizes differ
  bool Restore(const Eigen::VectorXf& m, const Eigen::VectorXf& v, int64_t t) {
    if (m.size() != m_.size() || v.size() != v_.size() || t < 0) return false;
    m_ = m;
    v_ = v;
    t_ = t;
    return true;
  }

 private:
  AdamOptions options_;
  Eigen::VectorXf m_, v_;
  int64_t t_ = 0;
};

}  // namespace coins::nn
