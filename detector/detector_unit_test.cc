// Unit tests of the detector's parts: goal sets, the F distribution, the linear Granger test on
// synthetic data, options, transition sets, and the `detect` command's flags and JSON.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <nlohmann/json.hpp>

#include "detector/detect_cli.h"
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
  w << 10.0f, 10.5f, 30.0f;
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

TEST(Transitions, SliceAndEpisodeStarts) {
  auto env = envs::MakeEnv("breakout");
  CollectOptions co;
  co.steps = 3000;
  co.seed = 5;
  Result<TransitionSet> d = CollectTransitions(**env, co);
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->size(), 3000);
  EXPECT_TRUE(d->episode_start(0));
  const TransitionSet s = d->Slice(100, 200);
  EXPECT_EQ(s.size(), 100);
  EXPECT_TRUE(s.episode_start(0));
  EXPECT_EQ(s.state(5)[6], d->state(105)[6]);
  EXPECT_EQ(InteractionBit((*env)->spec(), "Paddle", "Ball"), 1);
  EXPECT_EQ(InteractionBit((*env)->spec(), "Action", "Ball"), -1);
  co.policy = "/nonexistent/actions.txt";
  Result<TransitionSet> bad = CollectTransitions(**env, co);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("--policy"), std::string::npos);
}

TEST(PairDetector, WeightsRoundTripThroughABlob) {
  auto env = envs::MakeEnv("breakout");
  CollectOptions co;
  co.steps = 3000;
  Result<TransitionSet> d = CollectTransitions(**env, co);
  ASSERT_TRUE(d.ok());
  DetectorOptions o;
  o.passive_steps = o.passive_hard_steps = 200;
  o.active_steps = 300;
  Result<PairDetector> det = PairDetector::Train((*env)->spec(), *d, "Action", "Paddle", o);
  ASSERT_TRUE(det.ok());
  const std::vector<uint8_t> blob = det->WeightsBlob();
  Result<PairDetector> copy = PairDetector::Create(det->layout(), o);
  ASSERT_TRUE(copy.ok());
  ASSERT_TRUE(copy->LoadWeights(blob).ok());
  const PairScores a = det->Score(*d), b = copy->Score(*d);
  EXPECT_EQ(a.interactions, b.interactions);
  EXPECT_DOUBLE_EQ(a.score, b.score);
  EXPECT_EQ(copy->TransitionFlags(*d), det->TransitionFlags(*d));
  // a blob of the wrong pair is an error naming the pair
  Result<PairDetector> other = PairDetector::Train((*env)->spec(), *d, "Action", "Ball", o);
  ASSERT_TRUE(other.ok());
  const Status st = copy->LoadWeights(other->WeightsBlob());
  EXPECT_FALSE(st.ok());
  EXPECT_NE(st.message().find("Action->Paddle"), std::string::npos) << st.message();
}

// parses args as `detect ...`; returns the exception message, or "" when it ran
std::string RunCli(std::vector<std::string> args) {
  CLI::App app{"test"};
  AddDetectCommand(app);
  args.insert(args.begin(), "detect");
  std::vector<std::string> rev(args.rbegin(), args.rend());
  try {
    app.parse(rev);
  } catch (const CLI::Error& e) {
    return std::string(e.get_name()) + ": " + e.what();
  }
  return "";
}

TEST(DetectCli, BadFlagsAreErrorsNamingTheFlag) {
  EXPECT_NE(RunCli({"--env", "breakout", "--source", "Action"}).find("--steps"), std::string::npos);
  EXPECT_NE(RunCli({"--env", "breakout", "--source", "Action", "--steps", "-3"}).find("--steps"),
            std::string::npos);
  EXPECT_NE(RunCli({"--env", "breakout", "--source", "Action", "--steps", "abc"})
                .find("must be an integer > 0, got 'abc'"),
            std::string::npos);
  EXPECT_NE(RunCli({"--env", "breakout", "--source", "Action", "--steps", "9", "--lr", "0"})
                .find("--lr"),
            std::string::npos);
  EXPECT_NE(RunCli({"--env", "breakout", "--source", "Action", "--steps", "10", "--mask-rule",
                    "odd"}).find("--mask-rule"), std::string::npos);
  // runtime errors (unknown env or factor) exit 1 after one "error:" line
  testing::internal::CaptureStderr();
  const std::string r1 = RunCli({"--env", "nope", "--source", "Action", "--steps", "10"});
  const std::string r2 = RunCli({"--env", "breakout", "--source", "Wall", "--steps", "10"});
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(r1.find("RuntimeError"), std::string::npos);
  EXPECT_NE(r2.find("RuntimeError"), std::string::npos);
  EXPECT_NE(err.find("--env"), std::string::npos);
  EXPECT_NE(err.find("--source"), std::string::npos);
}

TEST(DetectCli, JsonHasTheDocumentedKeys) {
  testing::internal::CaptureStdout();
  const std::string r = RunCli({"--env", "breakout", "--source", "Action", "--targets", "Paddle",
                                "--steps", "3000", "--passive-steps", "200",
                                "--passive-hard-steps", "200", "--active-steps", "300", "--eval",
                                "--eval-steps", "1000", "--granger", "--json"});
  const std::string out = testing::internal::GetCapturedStdout();
  ASSERT_EQ(r, "");
  const nlohmann::json j = nlohmann::json::parse(out);
  ASSERT_EQ(j["targets"].size(), 1u);
  const auto& t = j["targets"][0];
  for (const char* key : {"target", "score", "mg_score", "interactions", "mask", "goal_set",
                          "goal_kind", "pass", "fp_per_state", "fn_per_interaction"}) {
    EXPECT_TRUE(t.contains(key)) << key;
  }
  EXPECT_EQ(t["target"], "Paddle");
  EXPECT_TRUE(t["pass"].is_boolean());
  EXPECT_EQ(t["mask"].size(), 5u);
  EXPECT_EQ(j["granger"].size(), 1u);

  // the linear screen skips a target it finds unrelated (Action->Ball: p about 1)
  testing::internal::CaptureStdout();
  ASSERT_EQ(RunCli({"--env", "breakout", "--source", "Action", "--targets", "Ball", "--steps",
                    "3000", "--screen", "0.5", "--json"}),
            "");
  const nlohmann::json k = nlohmann::json::parse(testing::internal::GetCapturedStdout());
  EXPECT_EQ(k["targets"][0]["screened"], true);
  EXPECT_EQ(k["targets"][0]["pass"], false);
}

}  // namespace
}  // namespace coins::detector
