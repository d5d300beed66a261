// GaussianModel: a conditional diagonal Gaussian N(mu(x), sigma(x)) over a d-dimensional
// target, as the detector's passive and active models use it (coins-method.md): a leaky-ReLU
// Mlp with 2d outputs, mean = tanh(raw[0:d]), std = sigmoid(raw[d:2d]) + min_std.
//
// Shapes: inputs in_dim x M, targets d x M (features x samples, like common/nn). Training
// draws batches (with replacement) from a pool of sample indices, uniformly or in proportion
// to per-sample weights (the paper's up-sampling), and minimises the mean negative
// log-likelihood with Adam. After the first step at a batch size nothing is allocated.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/Dense>

#include "common/nn/adam.h"
#include "common/nn/mlp.h"

namespace coins::detector {

struct GaussianModelOptions {
  int input_dim = 0;
  int output_dim = 0;
  std::vector<int> hidden = {128, 128};
  float lr = 1e-3f;
  float clip_norm = 10.0f;
  float min_std = 0.01f;
};

class GaussianModel {
 public:
  GaussianModel() = default;
  GaussianModel(const GaussianModelOptions& options, uint64_t seed);

  // pool: candidate sample indices (columns); weights: one per pool entry or empty (uniform).
  // Returns the mean loss of the last 100 steps. stop (optional) is asked every 64 steps; when
  // it says true, training ends there (the caller checks it again and discards the model).
  float Train(const Eigen::MatrixXf& in, const Eigen::MatrixXf& target, const std::vector<int64_t>& pool,
              const std::vector<float>& weights, int steps, int batch, uint64_t seed,
              const std::function<bool()>& stop = nullptr);
  // per-sample log-likelihood, summed over the d dimensions: ll has M entries
  void LogLikelihood(const Eigen::MatrixXf& in, const Eigen::MatrixXf& target, Eigen::VectorXf* ll);
  // predicted mean (d x M)
  void Mean(const Eigen::MatrixXf& in, Eigen::MatrixXf* mean);

  // copies a model with the same hidden sizes whose inputs are rows
  // [first_row, first_row + other.input_dim) of this model's input; the weights of the other
  // input rows start at zero, so this model starts as exactly the other one
  void WarmStartFrom(const GaussianModel& other, int first_row);

  const GaussianModelOptions& options() const { return options_; }
  nn::Mlp& net() { return net_; }
  const nn::ParamSet& params() const { return net_.params(); }

 private:
  GaussianModelOptions options_;
  nn::Mlp net_;
  nn::Adam adam_;
  Eigen::MatrixXf bx_, by_, draw_, ll_, mean_, std_;
};

}  // namespace coins::detector
