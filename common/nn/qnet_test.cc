// QNet: the observation split into a pair network's source, instances and presence mask.
#include "common/nn/qnet.h"

#include <cmath>

#include <gtest/gtest.h>

namespace coins::nn {
namespace {

// observation: 2 rows before, 3 instances of 4 rows (presence row 3), 1 row after
QNetOptions Split() {
  QNetOptions o;
  o.obs_dim = 2 + 3 * 4 + 1;
  o.hidden = {8, 6};
  o.outputs = 5;
  o.split = {2, 3, 4, 3, {}};
  return o;
}

Eigen::MatrixXf Observations(int B) {
  Eigen::MatrixXf obs = Eigen::MatrixXf::Random(15, B);
  for (int b = 0; b < B; ++b)
    for (int n = 0; n < 3; ++n) obs(2 + 4 * n + 3, b) = 1.0f;  // present
  return obs;
}

// with relative features read from rows on both sides of the instances (observation rows 14 and
// 0 are rows 2 and 0 of the pair network's source)
TEST(QNet, ASplitObservationIsThePairNetOfItsParts) {
  QNetOptions o = Split();
  o.split.relative = {{14, 1, 2.0f, 0.1f}, {0, 0, 1.0f, 0.0f}};
  ASSERT_TRUE(o.Validate().ok());
  QNet net(o, 7);
  PairNetOptions p;
  p.relative = {{2, 1, 2.0f, 0.1f}, {0, 0, 1.0f, 0.0f}};
  p.source_dim = 3;
  p.instance_dim = 4;
  p.max_instances = 3;
  p.point_sizes = {8, 6};
  p.output_dim = 5;
  PairNet pair(p, 1);
  ASSERT_TRUE(pair.params().SameShape(net.params()));
  pair.params().values = net.params().values;
  Eigen::MatrixXf obs = Observations(4);
  obs(2 + 4 * 1 + 3, 2) = 0.0f;  // instance 1 of sample 2 is gone
  Eigen::MatrixXf source(3, 4), mask = Eigen::MatrixXf::Ones(3, 4);
  source << obs.topRows(2), obs.bottomRows(1);
  mask(1, 2) = 0.0f;
  const Eigen::MatrixXf a = net.Forward(obs);
  const Eigen::MatrixXf b = pair.Forward(source, obs.middleRows(2, 12), mask);
  EXPECT_TRUE(a.isApprox(b, 1e-6f)) << (a - b).norm();
  const Eigen::MatrixXf dout = Eigen::MatrixXf::Random(5, 4);
  const Eigen::MatrixXf dobs = net.Backward(dout, /*input_grad=*/true);
  const Eigen::MatrixXf dsource = pair.Backward(dout, /*source_grad=*/true);
  EXPECT_TRUE(net.params().grads.isApprox(pair.params().grads, 1e-5f));
  // the observation's gradient: the source's rows where they came from, the instances' rows 0
  ASSERT_EQ(dobs.rows(), 15);
  EXPECT_TRUE(dobs.topRows(2).isApprox(dsource.topRows(2), 1e-5f));
  EXPECT_TRUE(dobs.bottomRows(1).isApprox(dsource.bottomRows(1), 1e-5f));
  EXPECT_EQ(dobs.middleRows(2, 12).norm(), 0.0f);
  EXPECT_GT(dobs.bottomRows(1).norm(), 0.0f);
}

TEST(QNet, WithoutAPresenceRowEveryInstanceIsPooled) {
  QNetOptions o = Split();
  o.split.presence = -1;
  ASSERT_TRUE(o.Validate().ok());
  QNet net(o, 4);
  Eigen::MatrixXf obs = Observations(1);
  obs(2 + 4 * 1 + 3, 0) = 0.0f;  // with a presence row this instance would be gone
  const Eigen::MatrixXf before = net.Forward(obs);
  obs.block(2 + 4 * 1, 0, 4, 1).setConstant(9.0f);
  EXPECT_FALSE(net.Forward(obs).isApprox(before, 1e-3f));  // it is pooled: a large value shows
}

TEST(QNet, AnAbsentInstanceChangesNothingAndTheOrderOfInstancesNeither) {
  QNet net(Split(), 3);
  Eigen::MatrixXf obs = Observations(1);
  obs(2 + 4 * 2 + 3, 0) = 0.0f;  // instance 2 absent
  const Eigen::MatrixXf before = net.Forward(obs);
  obs.block(2 + 4 * 2, 0, 3, 1).setConstant(9.0f);  // whatever an absent instance holds
  EXPECT_TRUE(net.Forward(obs).isApprox(before, 1e-6f));
  Eigen::MatrixXf swapped = obs;
  swapped.block(2, 0, 4, 1) = obs.block(6, 0, 4, 1);
  swapped.block(6, 0, 4, 1) = obs.block(2, 0, 4, 1);
  EXPECT_TRUE(net.Forward(swapped).isApprox(before, 1e-5f));
}

TEST(QNet, WithoutASplitItIsAnMlpAndBadSplitsAreRefused) {
  QNetOptions o = Split();
  o.split = {};
  QNet net(o, 5);
  Mlp mlp({{15, 8, 6, 5}, Activation::kRelu, Activation::kIdentity}, 5);
  EXPECT_TRUE(net.params().SameShape(mlp.params()));
  QNetOptions bad = Split();
  bad.split.instances = 4;  // 2 + 16 rows > 15
  EXPECT_FALSE(bad.Validate().ok());
  bad = Split();
  bad.split.presence = 4;
  EXPECT_FALSE(bad.Validate().ok());
  bad.split.presence = -2;
  EXPECT_FALSE(bad.Validate().ok());
  bad = Split();
  bad.split.relative = {{5, 0, 1.0f, 0.0f}};  // row 5 is inside instance 0
  EXPECT_NE(bad.Validate().message().find("relative feature 0 reads observation row 5"), std::string::npos);
  bad.split.relative = {{1, 4, 1.0f, 0.0f}};
  EXPECT_NE(bad.Validate().message().find("reads instance row 4 of 4"), std::string::npos);
  bad.split.relative = {{1, 0, std::nanf(""), 0.0f}};  // the pair network's own rules apply too
  EXPECT_NE(bad.Validate().message().find("relative feature 0 has scale nan"), std::string::npos);
}

}  // namespace
}  // namespace coins::nn
