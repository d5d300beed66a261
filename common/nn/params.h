// ParamSet: the flat parameter store every network in coins_nn keeps its weights in.
//
// Contract: all parameters of a network live in one contiguous float vector `values`, with a
// same-sized `grads` vector beside it. Each tensor is a named block (rows x cols, column-major)
// at an offset; layers build Eigen::Map views on demand, so copying a network copies its
// weights and never leaves dangling views. Optimisers, target updates and serialisation work on
// the flat vectors and need no knowledge of the layer structure.
#pragma once

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>

namespace coins::nn {

struct ParamBlock {
  std::string name;  // e.g. "layer0.w"
  int rows = 0;
  int cols = 0;
  int64_t offset = 0;  // first float of this block in ParamSet::values
  int64_t size() const { return int64_t(rows) * cols; }
};

class ParamSet {
 public:
  // appends a rows x cols block (zero-initialised) and returns its index; call before use
  int Add(std::string name, int rows, int cols);

  int64_t size() const { return values.size(); }
  const std::vector<ParamBlock>& blocks() const { return blocks_; }

  // views of block i (rows x cols)
  Eigen::Map<Eigen::MatrixXf> Value(int i) {
    const ParamBlock& b = blocks_[i];
    return Eigen::Map<Eigen::MatrixXf>(values.data() + b.offset, b.rows, b.cols);
  }
  Eigen::Map<const Eigen::MatrixXf> Value(int i) const {
    const ParamBlock& b = blocks_[i];
    return Eigen::Map<const Eigen::MatrixXf>(values.data() + b.offset, b.rows, b.cols);
  }
  Eigen::Map<Eigen::MatrixXf> Grad(int i) {
    const ParamBlock& b = blocks_[i];
    return Eigen::Map<Eigen::MatrixXf>(grads.data() + b.offset, b.rows, b.cols);
  }

  // true when both sets have the same block names and shapes
  bool SameShape(const ParamSet& other) const;
  void ZeroGrads() { grads.setZero(); }

  Eigen::VectorXf values;  // all parameters, size()
  Eigen::VectorXf grads;   // d loss / d values, size()

 private:
  std::vector<ParamBlock> blocks_;
};

// target <- tau * source + (1 - tau) * target (Polyak averaging); shapes must match
void SoftUpdate(const ParamSet& source, float tau, ParamSet* target);
// target <- source
void HardUpdate(const ParamSet& source, ParamSet* target);

// He / Glorot-style uniform init of a fan_in x fan_out weight block: U(-s, s), s = gain/sqrt(fan_in)
void InitUniform(Eigen::Map<Eigen::MatrixXf> w, float scale, std::mt19937_64* rng);

}  // namespace coins::nn
