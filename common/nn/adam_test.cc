// Adam against hand-computed steps; target updates; input normalisation.
#include <gtest/gtest.h>

#include "common/nn/adam.h"
#include "common/nn/normalizer.h"
#include "common/nn/params.h"

namespace coins::nn {
namespace {

ParamSet TwoParams(float a, float b) {
  ParamSet p;
  p.Add("w", 2, 1);
  p.values << a, b;
  return p;
}

TEST(Adam, MatchesHandComputedSteps) {
  // values worked out by hand (double precision) for lr 0.1, betas 0.9 / 0.999, eps 1e-8
  ParamSet p = TwoParams(1.0f, -2.0f);
  Adam adam({.lr = 0.1f}, p.size());
  p.grads << 0.5f, -0.1f;
  adam.Step(&p);
  EXPECT_NEAR(p.values[0], 0.900000002f, 1e-6f);
  EXPECT_NEAR(p.values[1], -1.900000010f, 1e-6f);
  p.grads << 0.2f, 0.3f;
  adam.Step(&p);
  EXPECT_NEAR(p.values[0], 0.810142484f, 1e-6f);
  EXPECT_NEAR(p.values[1], -1.949418991f, 1e-6f);
  EXPECT_EQ(adam.steps(), 2);
}

TEST(Adam, ClipsTheGlobalGradientNorm) {
  ParamSet p = TwoParams(0.0f, 0.0f);
  Adam adam({.lr = 0.1f, .clip_norm = 1.0f}, p.size());
  p.grads << 3.0f, 4.0f;  // norm 5 -> clipped to (0.6, 0.8)
  EXPECT_FLOAT_EQ(adam.Step(&p), 5.0f);
  EXPECT_NEAR(adam.first_moment()[0], 0.06f, 1e-7f);
  EXPECT_NEAR(adam.first_moment()[1], 0.08f, 1e-7f);
  EXPECT_NEAR(adam.second_moment()[1], 0.001f * 0.64f, 2e-8f);
}

TEST(Adam, ValidateRejectsBadOptions) {
  EXPECT_FALSE(AdamOptions{.lr = 0.0f}.Validate().ok());
  EXPECT_FALSE(AdamOptions{.beta1 = 1.0f}.Validate().ok());
  EXPECT_FALSE(AdamOptions{.clip_norm = -1.0f}.Validate().ok());
  EXPECT_TRUE(AdamOptions{}.Validate().ok());
}

TEST(TargetUpdates, SoftAndHard) {
  ParamSet src = TwoParams(1.0f, 2.0f), dst = TwoParams(3.0f, -2.0f);
  SoftUpdate(src, 0.25f, &dst);
  EXPECT_FLOAT_EQ(dst.values[0], 0.25f * 1.0f + 0.75f * 3.0f);
  EXPECT_FLOAT_EQ(dst.values[1], 0.25f * 2.0f + 0.75f * -2.0f);
  HardUpdate(src, &dst);
  EXPECT_EQ(dst.values, src.values);
}

TEST(Normalizer, MapsBoundsToUnitRangeAndBack) {
  std::vector<float> low = {0.0f, -2.0f}, high = {84.0f, 2.0f};
  auto n = Normalizer::FromBounds(low, high);
  ASSERT_TRUE(n.ok()) << n.status().message();
  Eigen::MatrixXf x(2, 3);
  x << 0, 42, 84, -2, 1, 2;
  Eigen::MatrixXf y = x;
  n->Apply(y);
  Eigen::MatrixXf expected(2, 3);
  expected << -1, 0, 1, -1, 0.5f, 1;
  EXPECT_TRUE(y.isApprox(expected));
  n->Invert(y);
  EXPECT_TRUE(y.isApprox(x));
  std::vector<float> bad = {-1.0f, 5.0f};
  auto err = Normalizer::FromBounds(low, bad);
  ASSERT_FALSE(err.ok());
  EXPECT_NE(err.status().message().find("feature 0"), std::string::npos);
}

}  // namespace
}  // namespace coins::nn
