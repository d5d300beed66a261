#include "common/nn/adam.h"

#include <cassert>
#include <cmath>

namespace coins::nn {

Status AdamOptions::Validate() const {
  if (!(lr > 0.0f)) return Errorf("adam: lr {} must be > 0", lr);
  if (!(beta1 >= 0.0f && beta1 < 1.0f)) return Errorf("adam: beta1 {} must be in [0, 1)", beta1);
  if (!(beta2 >= 0.0f && beta2 < 1.0f)) return Errorf("adam: beta2 {} must be in [0, 1)", beta2);
  if (!(eps > 0.0f)) return Errorf("adam: eps {} must be > 0", eps);
  if (!(clip_norm >= 0.0f)) return Errorf("adam: clip_norm {} must be >= 0", clip_norm);
  return Status::Ok();
}

Adam::Adam(AdamOptions options, int64_t size)
    : options_(options), m_(Eigen::VectorXf::Zero(size)), v_(Eigen::VectorXf::Zero(size)) {
  assert(options_.Validate().ok());
}

float Adam::Step(ParamSet* params) {
  assert(params->size() == m_.size());
  const float norm = params->grads.norm();
  float scale = 1.0f;
  if (options_.clip_norm > 0.0f && norm > options_.clip_norm) scale = options_.clip_norm / norm;
  ++t_;
  const float b1 = options_.beta1, b2 = options_.beta2;
  const float c1 = 1.0f - float(std::pow(double(b1), double(t_)));
  const float c2 = 1.0f - float(std::pow(double(b2), double(t_)));
  // moments then the bias-corrected step, all in one pass each
  auto g = params->grads.array() * scale;
  m_.array() = b1 * m_.array() + (1.0f - b1) * g;
  v_.array() = b2 * v_.array() + (1.0f - b2) * g.square();
  params->values.array() -= options_.lr * (m_.array() / c1) / ((v_.array() / c2).sqrt() + options_.eps);
  return norm;
}

}  // namespace coins::nn
