// Elementwise activations for batched layers (features x batch, column-major).
//
// Every derivative is computed from the activation's output, so layers keep only their
// post-activation matrices: relu' = [a > 0], leaky' = a > 0 ? 1 : slope, tanh' = 1 - a^2,
// sigmoid' = a (1 - a), identity' = 1.
#pragma once

#include <string>

#include <Eigen/Dense>

#include "common/status.h"

namespace coins::nn {

enum class Activation { kIdentity, kRelu, kLeakyRelu, kTanh, kSigmoid };

inline constexpr float kLeakySlope = 0.01f;

// parses "identity", "relu", "leaky_relu", "tanh", "sigmoid"
Result<Activation> ParseActivation(const std::string& name);
const char* ActivationName(Activation a);

// z <- act(z), in place
void ApplyActivation(Activation a, Eigen::Ref<Eigen::MatrixXf> z);
// grad <- grad .* act'(out), in place, where out = act(z) from the forward pass
void ActivationBackward(Activation a, const Eigen::Ref<const Eigen::MatrixXf>& out, Eigen::Ref<Eigen::MatrixXf> grad);

}  // namespace coins::nn
