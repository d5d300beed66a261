// Normalizer: maps features from their bounds [low, high] to [-1, 1], per row of a
// features x batch matrix: x' = (x - (high + low) / 2) / ((high - low) / 2).
#pragma once

#include <span>

#include <Eigen/Dense>

#include "common/status.h"

namespace coins::nn {

class Normalizer {
 public:
  Normalizer() = default;
  // errors when sizes differ or some high <= low
  static Result<Normalizer> FromBounds(std::span<const float> low, std::span<const float> high);

  int dim() const { return int(mid_.size()); }
  // in place, x: dim x B
  void Apply(Eigen::Ref<Eigen::MatrixXf> x) const;
  void Invert(Eigen::Ref<Eigen::MatrixXf> x) const;
  const Eigen::VectorXf& mid() const { return mid_; }
  const Eigen::VectorXf& half_range() const { return half_; }

 private:
  Eigen::VectorXf mid_, half_;
};

}  // namespace coins::nn
