// Pair-net behaviour: reduces to an MLP for one instance, respects the mask, is invariant to
// the order of instances.
#include <cmath>

#include <gtest/gtest.h>

#include "common/nn/mlp.h"
#include "common/nn/pairnet.h"

namespace coins::nn {
namespace {

PairNetOptions Options(int instances, int relative) {
  PairNetOptions o;
  o.source_dim = 3;
  o.instance_dim = 4;
  o.max_instances = instances;
  o.relative = LeadingRelative(relative);
  o.point_sizes = {16, 12};
  o.output_dim = 5;
  o.hidden = Activation::kRelu;
  o.output = Activation::kTanh;
  return o;
}

// a pair-net of one present instance (o: no relative features) equals the Mlp of `sizes` on
// [s_a; s_b] given the same parameters, in its outputs and in its gradients
void ExpectEqualsMlp(const PairNetOptions& o, std::vector<int> sizes) {
  PairNet pair(o, 3);
  Mlp mlp({std::move(sizes), Activation::kRelu, Activation::kTanh}, 99);
  ASSERT_TRUE(pair.params().SameShape(mlp.params()));
  mlp.params().values = pair.params().values;
  Eigen::MatrixXf src = Eigen::MatrixXf::Random(3, 6), inst = Eigen::MatrixXf::Random(4, 6);
  Eigen::MatrixXf cat(7, 6);
  cat << src, inst;
  Eigen::MatrixXf a = pair.Forward(src, inst, Eigen::MatrixXf::Ones(1, 6));
  Eigen::MatrixXf b = mlp.Forward(cat);
  EXPECT_TRUE(a.isApprox(b, 1e-6f)) << (a - b).norm();
  Eigen::MatrixXf r = Eigen::MatrixXf::Random(5, 6);
  pair.Backward(r);
  mlp.Backward(r);
  EXPECT_TRUE(pair.params().grads.isApprox(mlp.params().grads, 1e-5f));
}

TEST(PairNet, OneInstanceEqualsMlpOnConcatenatedInput) { ExpectEqualsMlp(Options(1, 0), {7, 16, 12, 5}); }

TEST(PairNet, OneInstanceWithAHeadEqualsTheMlpWithThoseLayers) {
  PairNetOptions o = Options(1, 0);
  o.head_sizes = {9, 8};
  ExpectEqualsMlp(o, {7, 16, 12, 9, 8, 5});
  EXPECT_EQ(PairNet(o, 3).MacsPerSample(), 7 * 16 + 16 * 12 + 12 * 9 + 9 * 8 + 8 * 5);
}

TEST(PairNet, MaskedInstancesDoNotMatterAndOrderDoesNot) {
  PairNet net(Options(3, 2), 5);
  Eigen::MatrixXf src = Eigen::MatrixXf::Random(3, 2), inst = Eigen::MatrixXf::Random(12, 2);
  Eigen::MatrixXf mask = Eigen::MatrixXf::Ones(3, 2);
  mask(2, 0) = 0.0f;
  Eigen::MatrixXf base = net.Forward(src, inst, mask);
  // change the absent instance: output unchanged
  Eigen::MatrixXf changed = inst;
  changed.col(0).segment(8, 4).setConstant(50.0f);
  EXPECT_EQ(net.Forward(src, changed, mask), base);
  // swap instances 0 and 1: output unchanged
  Eigen::MatrixXf swapped = inst;
  swapped.col(1).segment(0, 4) = inst.col(1).segment(4, 4);
  swapped.col(1).segment(4, 4) = inst.col(1).segment(0, 4);
  EXPECT_TRUE(net.Forward(src, swapped, mask).isApprox(base, 1e-6f));
  // a present instance does matter
  Eigen::MatrixXf moved = inst;
  moved.col(0).segment(0, 4).setConstant(3.0f);
  EXPECT_FALSE(net.Forward(src, moved, mask).col(0).isApprox(base.col(0), 1e-3f));
}

TEST(PairNet, NoInstancePoolsToZero) {
  PairNet net(Options(2, 0), 7);
  Eigen::MatrixXf src = Eigen::MatrixXf::Random(3, 1), inst = Eigen::MatrixXf::Random(8, 1);
  Eigen::MatrixXf mask = Eigen::MatrixXf::Zero(2, 1);
  Eigen::MatrixXf out = net.Forward(src, inst, mask);
  // the output is then tanh(bias of the dense layer)
  Eigen::VectorXf expected = net.params().Value(5).col(0).array().tanh();
  EXPECT_TRUE(out.col(0).isApprox(expected, 1e-6f));
}

TEST(PairNet, ValidateNamesTheProblem) {
  PairNetOptions o = Options(2, 5);
  Status s = o.Validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("relative feature 3 pairs source row 3"), std::string::npos) << s.message();
  o = Options(2, 1);
  o.relative[0].scale = std::nanf("");
  s = o.Validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("relative feature 0 has scale nan"), std::string::npos) << s.message();
}

// a relative feature is scale * s_a[source] + shift - s_b[instance], appended after s_b
TEST(PairNet, RelativeFeaturesAreAffineDifferencesAppendedToEachPoint) {
  PairNetOptions o = Options(1, 0);
  o.relative = {{2, 1, 0.6f, -0.25f}, {0, 3, 1.0f, 0.0f}};
  PairNet pair(o, 3);
  Mlp mlp({{9, 16, 12, 5}, Activation::kRelu, Activation::kTanh}, 99);
  ASSERT_TRUE(pair.params().SameShape(mlp.params()));
  mlp.params().values = pair.params().values;
  Eigen::MatrixXf src = Eigen::MatrixXf::Random(3, 4), inst = Eigen::MatrixXf::Random(4, 4);
  Eigen::MatrixXf cat(9, 4);
  cat << src, inst, 0.6f * src.row(2).array() - 0.25f - inst.row(1).array(), src.row(0) - inst.row(3);
  Eigen::MatrixXf a = pair.Forward(src, inst, Eigen::MatrixXf::Ones(1, 4));
  EXPECT_TRUE(a.isApprox(mlp.Forward(cat), 1e-6f));
}

}  // namespace
}  // namespace coins::nn
