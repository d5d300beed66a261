// Finite-difference gradient checks for every layer, head and loss in coins_nn.
//
// Losses are computed in double from float outputs; central differences with a step suited to
// float32 (1e-2 for smooth functions, 1e-3 where kinks exist). The figure of merit is the
// relative error ||g - fd|| / (||g|| + ||fd||) over the checked coordinates; a wrong transpose
// or a missing factor gives errors of order one, float noise stays below ~1e-3.
#include <functional>
#include <random>

#include <gtest/gtest.h>

#include "common/nn/heads.h"
#include "common/nn/mlp.h"
#include "common/nn/pairnet.h"

namespace coins::nn {
namespace {

Eigen::MatrixXf Random(int rows, int cols, uint64_t seed, float scale = 1.0f) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> n(0.0f, scale);
  Eigen::MatrixXf m(rows, cols);
  for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] = n(rng);
  return m;
}

double Dot(const Eigen::MatrixXf& a, const Eigen::MatrixXf& b) {
  return (a.cast<double>().array() * b.cast<double>().array()).sum();
}

// relative error between analytic gradient g of x and central differences of loss()
double RelError(float* x, int64_t n, const Eigen::VectorXf& g, const std::function<double()>& loss, float eps,
                int max_checks = 400) {
  std::mt19937_64 rng(7);
  std::vector<int64_t> idx;
  if (n <= max_checks) {
    for (int64_t i = 0; i < n; ++i) idx.push_back(i);
  } else {
    std::uniform_int_distribution<int64_t> u(0, n - 1);
    for (int i = 0; i < max_checks; ++i) idx.push_back(u(rng));
  }
  double num = 0.0, den = 0.0;
  for (int64_t i : idx) {
    const float saved = x[i];
    x[i] = saved + eps;
    const double up = loss();
    x[i] = saved - eps;
    const double down = loss();
    x[i] = saved;
    const double fd = (up - down) / (2.0 * double(eps));
    num += (fd - g[i]) * (fd - g[i]);
    den += fd * fd + double(g[i]) * g[i];
  }
  return std::sqrt(num) / (std::sqrt(den) + 1e-12);
}

class MlpGrad : public ::testing::TestWithParam<std::pair<Activation, Activation>> {};

TEST_P(MlpGrad, ParamsAndInputMatchFiniteDifferences) {
  auto [hidden, output] = GetParam();
  const bool kinks = hidden == Activation::kRelu || hidden == Activation::kLeakyRelu;
  Mlp net({{5, 7, 6, 3}, hidden, output}, 11);
  Eigen::MatrixXf x = Random(5, 4, 1);
  Eigen::MatrixXf r = Random(3, 4, 2);
  auto loss = [&] { return Dot(net.Forward(x), r); };
  loss();
  Eigen::MatrixXf dx = net.Backward(r, /*input_grad=*/true);
  Eigen::VectorXf g = net.params().grads;
  const float eps = kinks ? 1e-3f : 1e-2f;
  EXPECT_LT(RelError(net.params().values.data(), net.params().size(), g, loss, eps), 1e-2);
  Eigen::VectorXf gx = Eigen::Map<Eigen::VectorXf>(dx.data(), dx.size());
  EXPECT_LT(RelError(x.data(), x.size(), gx, loss, eps), 1e-2);
}

INSTANTIATE_TEST_SUITE_P(Activations, MlpGrad,
                         ::testing::Values(std::pair{Activation::kTanh, Activation::kIdentity},
                                           std::pair{Activation::kSigmoid, Activation::kTanh},
                                           std::pair{Activation::kRelu, Activation::kSigmoid},
                                           std::pair{Activation::kLeakyRelu, Activation::kLeakyRelu},
                                           std::pair{Activation::kRelu, Activation::kRelu}));

TEST(MlpGrad, AccumulateAddsGradients) {
  Mlp net({{3, 4, 2}, Activation::kTanh, Activation::kIdentity}, 3);
  Eigen::MatrixXf x = Random(3, 5, 4), r = Random(2, 5, 5);
  net.Forward(x);
  net.Backward(r);
  Eigen::VectorXf once = net.params().grads;
  net.Forward(x);
  net.Backward(r, false, /*accumulate=*/true);
  EXPECT_TRUE(net.params().grads.isApprox(2.0f * once, 1e-6f));
}

// with and without dense hidden layers between the pool and the output
class PairNetGrad : public testing::TestWithParam<std::vector<int>> {};

TEST_P(PairNetGrad, ParamsAndSourceMatchFiniteDifferences) {
  PairNetOptions o;
  o.source_dim = 3;
  o.instance_dim = 4;
  o.max_instances = 3;
  o.relative = {{0, 0, 1.0f, 0.0f}, {2, 1, 0.6f, 0.3f}};  // a scaled source row feeds its gradient
  o.point_sizes = {6, 5};
  o.head_sizes = GetParam();
  o.output_dim = 3;
  o.hidden = Activation::kTanh;
  o.output = Activation::kTanh;
  PairNet net(o, 5);
  const int batch = 4;
  Eigen::MatrixXf src = Random(3, batch, 1), inst = Random(12, batch, 2), r = Random(3, batch, 3);
  Eigen::MatrixXf mask = Eigen::MatrixXf::Ones(3, batch);
  mask(1, 0) = 0.0f;      // one absent instance
  mask.col(2).setZero();  // a sample with no instance at all
  auto loss = [&] { return Dot(net.Forward(src, inst, mask), r); };
  loss();
  Eigen::MatrixXf ds = net.Backward(r, /*source_grad=*/true);
  Eigen::VectorXf g = net.params().grads;
  EXPECT_LT(RelError(net.params().values.data(), net.params().size(), g, loss, 1e-2f), 1e-2);
  ASSERT_EQ(ds.rows(), 3);
  EXPECT_EQ(ds.col(2).norm(), 0.0f);  // no instance, no path from the source
  Eigen::VectorXf gs = Eigen::Map<Eigen::VectorXf>(ds.data(), ds.size());
  EXPECT_LT(RelError(src.data(), src.size(), gs, loss, 1e-2f), 1e-2);
}

INSTANTIATE_TEST_SUITE_P(Heads, PairNetGrad, testing::Values(std::vector<int>{}, std::vector<int>{4, 6}));

TEST(HeadGrad, GaussianNll) {
  const int d = 3, batch = 5;
  Eigen::MatrixXf raw = Random(2 * d, batch, 1);
  Eigen::MatrixXf target = Random(d, batch, 2, 0.5f);
  Eigen::MatrixXf w = Random(1, batch, 3).cwiseAbs();
  Eigen::MatrixXf draw;
  auto loss = [&] {
    Eigen::MatrixXf tmp;
    return double(GaussianNllLoss(raw, target, w, kGaussianMinStd, &tmp));
  };
  GaussianNllLoss(raw, target, w, kGaussianMinStd, &draw);
  Eigen::VectorXf g = Eigen::Map<Eigen::VectorXf>(draw.data(), draw.size());
  EXPECT_LT(RelError(raw.data(), raw.size(), g, loss, 1e-2f), 1e-2);
  // the loss is the weighted mean negative log-likelihood
  Eigen::MatrixXf ll;
  GaussianLogLikelihood(raw, target, kGaussianMinStd, &ll);
  EXPECT_NEAR(loss(), -Dot(ll, w) / batch, 1e-4);
}

TEST(HeadGrad, SquashedGaussian) {
  const int d = 2, batch = 6;
  SquashedGaussian head;
  Eigen::MatrixXf raw = Random(2 * d, batch, 1, 0.7f);
  Eigen::MatrixXf noise = Random(d, batch, 2);
  Eigen::MatrixXf ra = Random(d, batch, 3), rl = Random(1, batch, 4);
  auto loss = [&] {
    Eigen::MatrixXf a, logp;
    head.Sample(raw, noise, &a, &logp);
    return Dot(a, ra) + Dot(logp, rl);
  };
  Eigen::MatrixXf draw;
  head.Backward(raw, noise, ra, rl, &draw);
  Eigen::VectorXf g = Eigen::Map<Eigen::VectorXf>(draw.data(), draw.size());
  EXPECT_LT(RelError(raw.data(), raw.size(), g, loss, 1e-2f), 1e-2);
}

TEST(HeadGrad, CategoricalCrossEntropy) {
  const int actions = 3, atoms = 5, batch = 4;
  Eigen::MatrixXf logits = Random(actions * atoms, batch, 1);
  Eigen::MatrixXf acts(1, batch);
  acts << 0, 2, 1, 2;
  Eigen::MatrixXf target = Random(atoms, batch, 2).array().exp();
  target.array().rowwise() /= target.colwise().sum().array();
  Eigen::MatrixXf w = Random(1, batch, 3).cwiseAbs();
  Eigen::MatrixXf dl, per;
  auto loss = [&] {
    Eigen::MatrixXf tmp;
    return double(CategoricalCrossEntropy(logits, atoms, acts, target, w, &tmp, nullptr));
  };
  CategoricalCrossEntropy(logits, atoms, acts, target, w, &dl, &per);
  Eigen::VectorXf g = Eigen::Map<Eigen::VectorXf>(dl.data(), dl.size());
  EXPECT_LT(RelError(logits.data(), logits.size(), g, loss, 1e-2f), 1e-2);
  EXPECT_NEAR(loss(), Dot(per, w) / batch, 1e-5);
}

TEST(HeadGrad, Dueling) {
  const int actions = 4, atoms = 3, batch = 2;
  Eigen::MatrixXf raw = Random((1 + actions) * atoms, batch, 1);
  Eigen::MatrixXf r = Random(actions * atoms, batch, 2);
  auto loss = [&] {
    Eigen::MatrixXf out;
    DuelingForward(raw, actions, atoms, &out);
    return Dot(out, r);
  };
  Eigen::MatrixXf draw;
  DuelingBackward(r, actions, atoms, &draw);
  Eigen::VectorXf g = Eigen::Map<Eigen::VectorXf>(draw.data(), draw.size());
  EXPECT_LT(RelError(raw.data(), raw.size(), g, loss, 1e-2f), 1e-3);
}

TEST(HeadGrad, GaussianThroughMlpEndToEnd) {
  Mlp net({{4, 8, 4}, Activation::kLeakyRelu, Activation::kIdentity}, 9);
  Eigen::MatrixXf x = Random(4, 6, 1), target = Random(2, 6, 2, 0.3f);
  Eigen::MatrixXf none(0, 0), draw;
  auto loss = [&] {
    Eigen::MatrixXf tmp;
    return double(GaussianNllLoss(net.Forward(x), target, none, 0.01f, &tmp));
  };
  GaussianNllLoss(net.Forward(x), target, none, 0.01f, &draw);
  net.Backward(draw);
  Eigen::VectorXf g = net.params().grads;
  EXPECT_LT(RelError(net.params().values.data(), net.params().size(), g, loss, 1e-3f), 2e-2);
}

TEST(C51, ProjectionKeepsMassAndMovesAtoms) {
  // support {-2,-1,0,1,2}; reward 0.5, discount 1 moves every atom half a step right
  Eigen::MatrixXf p(5, 1);
  p << 0.1f, 0.2f, 0.3f, 0.25f, 0.15f;
  Eigen::MatrixXf r(1, 1), disc(1, 1), m;
  r << 0.5f;
  disc << 1.0f;
  ProjectDistribution(p, r, disc, -2.0f, 2.0f, &m);
  Eigen::MatrixXf expected(5, 1);
  expected << 0.05f, 0.15f, 0.25f, 0.275f, 0.275f;
  EXPECT_TRUE(m.isApprox(expected, 1e-6f)) << m.transpose();
  // a terminal transition puts all mass at the reward
  disc << 0.0f;
  r << -1.0f;
  ProjectDistribution(p, r, disc, -2.0f, 2.0f, &m);
  EXPECT_NEAR(m(1, 0), 1.0f, 1e-6f);
  EXPECT_NEAR(m.sum(), 1.0f, 1e-6f);
}

}  // namespace
}  // namespace coins::nn
