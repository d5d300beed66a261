#include "common/nn/normalizer.h"

#include <cassert>

namespace coins::nn {

Result<Normalizer> Normalizer::FromBounds(std::span<const float> low, std::span<const float> high) {
  if (low.size() != high.size()) return Errorf("normalizer: {} low bounds but {} high bounds", low.size(), high.size());
  Normalizer n;
  n.mid_.resize(Eigen::Index(low.size()));
  n.half_.resize(Eigen::Index(low.size()));
  for (size_t i = 0; i < low.size(); ++i) {
    if (!(high[i] > low[i])) return Errorf("normalizer: feature {} has high {} <= low {}", i, high[i], low[i]);
    n.mid_[Eigen::Index(i)] = 0.5f * (high[i] + low[i]);
    n.half_[Eigen::Index(i)] = 0.5f * (high[i] - low[i]);
  }
  return n;
}

void Normalizer::Apply(Eigen::Ref<Eigen::MatrixXf> x) const {
  assert(x.rows() == mid_.size());
  x.array().colwise() -= mid_.array();
  x.array().colwise() /= half_.array();
}

void Normalizer::Invert(Eigen::Ref<Eigen::MatrixXf> x) const {
  assert(x.rows() == mid_.size());
  x.array().colwise() *= half_.array();
  x.array().colwise() += mid_.array();
}

}  // namespace coins::nn
