#include "common/nn/activation.h"

namespace coins::nn {

Result<Activation> ParseActivation(const std::string& name) {
  if (name == "identity" || name == "linear") return Activation::kIdentity;
  if (name == "relu") return Activation::kRelu;
  if (name == "leaky_relu") return Activation::kLeakyRelu;
  if (name == "tanh") return Activation::kTanh;
  if (name == "sigmoid") return Activation::kSigmoid;
  return Errorf("unknown activation '{}' (known: identity, relu, leaky_relu, tanh, sigmoid)", name);
}

const char* ActivationName(Activation a) {
  switch (a) {
    case Activation::kIdentity: return "identity";
    case Activation::kRelu: return "relu";
    case Activation::kLeakyRelu: return "leaky_relu";
    case Activation::kTanh: return "tanh";
    case Activation::kSigmoid: return "sigmoid";
  }
  return "?";
}

void ApplyActivation(Activation a, Eigen::Ref<Eigen::MatrixXf> z) {
  auto x = z.array();
  switch (a) {
    case Activation::kIdentity: break;
    case Activation::kRelu: x = x.max(0.0f); break;
    case Activation::kLeakyRelu: x = x.max(kLeakySlope * x); break;
    case Activation::kTanh: x = x.tanh(); break;
    case Activation::kSigmoid: x = (1.0f + (-x).exp()).inverse(); break;
  }
}

void ActivationBackward(Activation a, const Eigen::Ref<const Eigen::MatrixXf>& out, Eigen::Ref<Eigen::MatrixXf> grad) {
  auto g = grad.array();
  auto y = out.array();
  switch (a) {
    case Activation::kIdentity: break;
    case Activation::kRelu: g = (y > 0.0f).select(g, 0.0f); break;
    case Activation::kLeakyRelu: g = (y > 0.0f).select(g, kLeakySlope * g); break;
    case Activation::kTanh: g *= 1.0f - y.square(); break;
    case Activation::kSigmoid: g *= y * (1.0f - y); break;
  }
}

}  // namespace coins::nn
