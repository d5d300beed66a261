// Unit tests of the detector's parts on synthetic data: goal sets, the F distribution, the linear
// Granger test, options.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <nlohmann/json.hpp>

#include "detector/goal_set.h"
#include "detector/granger.h"
#include "detector/interaction.h"
#include "detector/options.h"
#include "detector/transitions.h"

namespace coins::detector {
namespace {

TEST(GoalSet, FourVelocitiesAreDiscreteAndRareOnesDropped) {
  DetectorOptions o;
  // 60 values of four velocities and one rare misdetection (1/61 < goal_min_fraction)
  Eigen::MatrixXf v(2, 61);
  const float goals[4][2] = {{-1, -1}, {-2, -1}, {-2, 1}, {-1, 1}};
  for (int j = 0; j < 60; ++j) v.col(j) << goals[j % 4][0], goals[j % 4][1];
  v.col(60) << 1, 1;
  const GoalSet g = BuildGoalSet({2, 3}, v, {2.0f, 1.0f}, o);
  EXPECT_EQ(g.kind, GoalSet::Kind::kDiscrete);
  EXPECT_EQ(g.raw_unique, 5);
  ASSERT_EQ(g.goals.size(), 4u);  // the rare (1, 1) is below goal_min_fraction
  EXPECT_EQ(g.goals[0], (std::vector<float>{-2, -1}));
  EXPECT_EQ(g.counts[0], 15);
}

TEST(GoalSet, ManyValuesAreContinuousWithBounds) {
  DetectorOptions o;
  Eigen::MatrixXf v(1, 200);
  for (int j = 0; j < 200; ++j) v(0, j) = 8.0f + 0.34f * float(j);
  const GoalSet g = BuildGoalSet({1}, v, {42.0f}, o);
  EXPECT_EQ(g.kind, GoalSet::Kind::kContinuous);
  EXPECT_FLOAT_EQ(g.low[0], 8.0f);
  EXPECT_NEAR(g.high[0], 8.0f + 0.34f * 199.0f, 1e-4);
  // values closer than goal_dedup (normalised L1) are one goal
  Eigen::MatrixXf w(1, 3);
  w << 10.0f, 10.2f, 30.0f;
  const GoalSet h = BuildGoalSet({1}, w, {42.0f}, o);
  EXPECT_EQ(h.kind, GoalSet::Kind::kDiscrete);
  EXPECT_EQ(h.raw_unique, 2);
  EXPECT_EQ(BuildGoalSet({}, Eigen::MatrixXf(0, 0), {}, o).kind, GoalSet::Kind::kEmpty);
}

TEST(Granger, FDistributionTail) {
  // F(1, large) is chi-square(1): P(F > 3.841) = 0.05; F(5, 10) at 3.326 is 0.05
  EXPECT_NEAR(FDistributionUpperTail(3.841, 1, 1e7), 0.05, 1e-3);
  EXPECT_NEAR(FDistributionUpperTail(3.326, 5, 10), 0.05, 1e-3);
  EXPECT_NEAR(FDistributionUpperTail(1.0, 4, 4), 0.5, 1e-9);
  EXPECT_EQ(FDistributionUpperTail(0.0, 3, 30), 1.0);
}

// a synthetic two-factor env spec and data: b follows a with one step of delay, c is noise
envs::EnvSpec SyntheticSpec() {
  envs::EnvSpec spec;
  spec.name = "synthetic";
  for (const char* n : {"A", "B", "C"}) {
    envs::FactorSpec f;
    f.name = n;
    f.features = 1;
    f.low = {-10};
    f.high = {10};
    f.feature_names = {"x"};
    spec.factors.push_back(f);
  }
  spec.action.discrete = true;
  spec.action.n = 2;
  spec.action.dim = 1;
  return spec;
}

TEST(Granger, SparseSolveFindsTheLaggedCause) {
  const envs::EnvSpec spec = SyntheticSpec();
  TransitionSet data(3, 1);
  std::mt19937_64 rng(3);
  std::normal_distribution<float> noise(0.0f, 1.0f);
  float a = 0, b = 0, c = 0;
  for (int t = 0; t < 3000; ++t) {
    const float a2 = 0.5f * a + noise(rng);
    const float b2 = 0.3f * b + 0.8f * a + 0.1f * noise(rng);
    const float c2 = 0.3f * c + noise(rng);
    const float s[3] = {a, b, c}, s2[3] = {a2, b2, c2}, act[1] = {0};
    data.Append(s, act, s2, 0, t == 0);
    a = a2;
    b = b2;
    c = c2;
  }
  for (int w : {1, 2}) {
    GrangerOptions go;
    go.window = w;
    Result<std::vector<GrangerResult>> r = LinearGrangerTest(spec, data, "A", {"B", "C"}, go);
    ASSERT_TRUE(r.ok()) << r.status().message();
    EXPECT_TRUE((*r)[0].causes);
    EXPECT_EQ((*r)[0].df1, w);
    EXPECT_GT((*r)[0].f_stat, 1000.0);
    EXPECT_FALSE((*r)[1].causes) << "p " << (*r)[1].p_value;
    EXPECT_GT((*r)[1].p_value, 1e-3);
  }
  GrangerOptions bad;
  bad.window = 0;
  EXPECT_FALSE(LinearGrangerTest(spec, data, "A", {"B"}, bad).ok());
  EXPECT_FALSE(LinearGrangerTest(spec, data, "Z", {"B"}, GrangerOptions()).ok());
}

// the mask test measures positions in one unit per target (the largest half range of its x, y,
// z), other features in half their own range
TEST(PairLayout, MaskUnitsShareOneScaleAcrossPositions) {
  PairLayout L;
  L.target_feature_names = {"x", "y", "z", "vx"};
  L.target_low = {-0.25f, -0.25f, 0.0f, -2.0f};
  L.target_high = {0.25f, 0.25f, 0.1f, 2.0f};
  EXPECT_FLOAT_EQ(L.mask_unit(0), 0.25f);
  EXPECT_FLOAT_EQ(L.mask_unit(1), 0.25f);
  EXPECT_FLOAT_EQ(L.mask_unit(2), 0.25f);  // not 0.05: 1 mm of height is 1 mm of x
  EXPECT_FLOAT_EQ(L.mask_unit(3), 2.0f);
  L.target_feature_names = {};  // without names every feature is its own unit
  EXPECT_FLOAT_EQ(L.mask_unit(2), 0.05f);
}

TEST(Evaluation, FalsePositivesAfterLabelsStayInTheWindowAndTheEpisode) {
  // t:                        0  1  2  3  4  5  6  7  8  9
  const std::vector<uint8_t> truth = {0, 1, 0, 0, 0, 0, 1, 0, 0, 0};
  const std::vector<uint8_t> flags = {1, 1, 1, 0, 1, 1, 0, 0, 1, 1};
  std::vector<uint8_t> starts(truth.size(), 0);
  starts[0] = 1;
  // after label 1: t 2 and 4 are within 3, t 5 is not; t 0 comes before any label; a detection
  // at a label (t 1) is no false positive; after label 6: t 8 and 9
  EXPECT_EQ(FalsePositivesAfterLabels(flags, truth, starts, 3), 4);
  EXPECT_EQ(FalsePositivesAfterLabels(flags, truth, starts, 1), 1);  // t 2
  starts[8] = 1;  // a new episode at t 8: label 6 no longer reaches t 8 and 9
  EXPECT_EQ(FalsePositivesAfterLabels(flags, truth, starts, 3), 2);
  EXPECT_EQ(FalsePositivesAfterLabels(flags, truth, starts, 0), 0);
}

TEST(Options, ValidateNamesTheBadValue) {
  DetectorOptions o;
  EXPECT_TRUE(o.Validate().ok());
  o.lr = 0.0f;
  EXPECT_NE(o.Validate().message().find("lr"), std::string::npos);
  o = DetectorOptions();
  o.active_hidden = {};
  EXPECT_NE(o.Validate().message().find("active_hidden"), std::string::npos);
  o = DetectorOptions();
  o.eps_eta_relative = 1.5f;
  EXPECT_FALSE(o.Validate().ok());
  EXPECT_FLOAT_EQ(DefaultDetectorOptions("pushing").close_distance, 0.13f);
  EXPECT_EQ(DefaultDetectorOptions("breakout", true, "Paddle", "Ball").active_hidden,
            (std::vector<int>{512, 256, 256, 128, 128}));
}

}  // namespace
}  // namespace coins::detector
