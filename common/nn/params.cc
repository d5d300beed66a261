#include "common/nn/params.h"

#include <cassert>

namespace coins::nn {

int ParamSet::Add(std::string name, int rows, int cols) {
  assert(rows > 0 && cols > 0);
  ParamBlock block{std::move(name), rows, cols, values.size()};
  blocks_.push_back(block);
  // grow both vectors keeping existing values
  Eigen::VectorXf grown = Eigen::VectorXf::Zero(values.size() + block.size());
  grown.head(values.size()) = values;
  values = std::move(grown);
  grads = Eigen::VectorXf::Zero(values.size());
  return int(blocks_.size()) - 1;
}

bool ParamSet::SameShape(const ParamSet& other) const {
  if (blocks_.size() != other.blocks_.size()) return false;
  for (size_t i = 0; i < blocks_.size(); ++i) {
    const ParamBlock& a = blocks_[i];
    const ParamBlock& b = other.blocks_[i];
    if (a.name != b.name || a.rows != b.rows || a.cols != b.cols) return false;
  }
  return true;
}

void SoftUpdate(const ParamSet& source, float tau, ParamSet* target) {
  assert(source.size() == target->size());
  target->values = tau * source.values + (1.0f - tau) * target->values;
}

void HardUpdate(const ParamSet& source, ParamSet* target) {
  assert(source.size() == target->size());
  target->values = source.values;
}

void InitUniform(Eigen::Map<Eigen::MatrixXf> w, float scale, std::mt19937_64* rng) {
  std::uniform_real_distribution<float> u(-scale, scale);
  for (Eigen::Index j = 0; j < w.cols(); ++j)
    for (Eigen::Index i = 0; i < w.rows(); ++i) w(i, j) = u(*rng);
}

}  // namespace coins::nn
