// The detector on data collected from real environments: transition sets, the weights blob,
// and the `detect` command's flags and JSON.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>

#include <nlohmann/json.hpp>

#include "actors/collect.h"
#include "actors/envs/env.h"
#include "detector/interaction.h"
#include "detector/options.h"
#include "detector/transitions.h"
#include "learner/detect/detect_cli.h"

namespace coins::detector {
namespace {

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

// `steps` steps of random actions in env (collection seed 1)
Result<TransitionSet> RandomSteps(envs::Env& env, int64_t steps) {
  CollectOptions co;
  co.steps = steps;
  return CollectTransitions(env, co);
}

TEST(PairDetector, WeightsRoundTripThroughABlob) {
  auto env = envs::MakeEnv("breakout");
  Result<TransitionSet> d = RandomSteps(**env, 3000);
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

TEST(PairDetector, AStopRequestEndsTrainingWithANotReadyError) {
  auto env = envs::MakeEnv("breakout");
  Result<TransitionSet> d = RandomSteps(**env, 2000);
  ASSERT_TRUE(d.ok());
  DetectorOptions o;
  o.passive_steps = o.active_steps = 10'000'000;  // hours of training unless stopped
  int asked = 0;
  const auto t0 = std::chrono::steady_clock::now();
  Result<PairDetector> det = PairDetector::Train((*env)->spec(), *d, "Paddle", "Ball", o, [&] { return ++asked > 3; });
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(20));
  ASSERT_FALSE(det.ok());
  EXPECT_EQ(det.status().message(), "not ready: stopped while training the Paddle->Ball models");
  EXPECT_EQ(asked, 5);  // three answers of "go on" (64 steps each), the stop, then the check after
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
  EXPECT_NE(RunCli({"--env", "breakout", "--source", "Action", "--steps", "-3"}).find("--steps"), std::string::npos);
  EXPECT_NE(RunCli({"--env", "breakout", "--source", "Action", "--steps", "abc"})
                .find("--steps: must be an integer in [1, 2147483647], got 'abc'"),
            std::string::npos);
  EXPECT_NE(RunCli({"--env", "breakout", "--source", "Action", "--steps", "9", "--lr", "0"}).find("--lr"),
            std::string::npos);
  EXPECT_NE(
      RunCli({"--env", "breakout", "--source", "Action", "--steps", "10", "--mask-rule", "odd"}).find("--mask-rule"),
      std::string::npos);
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

TEST(DetectCli, HugeOrNonFiniteNumbersAreOneLineErrorsNotAborts) {
  const std::vector<std::string> base = {"--env", "breakout", "--source", "Action"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = base;
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  // flag checks: the value is named, nothing is clamped
  EXPECT_NE(
      RunCli(with({"--steps", "2147483648"})).find("--steps: must be an integer in [1, 2147483647], got '2147483648'"),
      std::string::npos);
  EXPECT_NE(RunCli(with({"--steps", "18446744073709551616"})).find("got '18446744073709551616'"), std::string::npos);
  EXPECT_NE(RunCli(with({"--steps", "10", "--seed", "18446744073709551616"}))
                .find("--seed: must be an integer in [0, 18446744073709551615], got '18446744073709551616'"),
            std::string::npos);
  EXPECT_NE(RunCli(with({"--steps", "10", "--seed", "-1"})).find("--seed"), std::string::npos);
  EXPECT_NE(
      RunCli(with({"--steps", "10", "--hidden", "128,100000000"})).find("--hidden: must be an integer in [1, 8192]"),
      std::string::npos);
  for (const char* flag : {"--eps-act", "--eps-pas", "--eps-si"})
    for (const char* value : {"nan", "inf", "-inf", "abc"})
      EXPECT_NE(RunCli(with({"--steps", "10", flag, value})).find(std::string(flag) + ": must be a finite number"),
                std::string::npos)
          << flag << " " << value;
  // sizes the machine cannot hold are refused before any data is collected, saying why
  testing::internal::CaptureStderr();
  const auto t0 = std::chrono::steady_clock::now();
  const std::string big = RunCli(with({"--steps", "100000000"}));
  const std::string eval = RunCli(with({"--steps", "1000", "--eval", "--eval-steps", "2147483647"}));
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(5));
  EXPECT_NE(big.find("RuntimeError"), std::string::npos) << big;
  EXPECT_NE(eval.find("RuntimeError"), std::string::npos) << eval;
  EXPECT_NE(err.find("coins detect: --steps 100000000: the data would take about"), std::string::npos) << err;
  EXPECT_NE(err.find("coins detect: --steps 1000 and --eval-steps 2147483647: the data would take about"),
            std::string::npos)
      << err;
  EXPECT_NE(err.find("of memory; use fewer steps"), std::string::npos) << err;
}

TEST(DetectCli, APolicyFileWithNonNumbersIsAnErrorNamingTheLine) {
  const std::string path = ::testing::TempDir() + "coins_detect_policy.txt";
  for (const char* bad : {"nan", "abc", "inf", "1e99"}) {
    std::ofstream(path) << "1\n" << bad << "\n2\n";
    testing::internal::CaptureStderr();
    const std::string r = RunCli({"--env", "breakout", "--source", "Action", "--steps", "100", "--policy", path});
    const std::string err = testing::internal::GetCapturedStderr();
    EXPECT_NE(r.find("RuntimeError"), std::string::npos) << bad << ": " << r;
    EXPECT_NE(err.find("line 2: '" + std::string(bad) + "' is not a finite number"), std::string::npos) << err;
  }
  std::remove(path.c_str());
}

TEST(DetectCli, JsonHasTheDocumentedKeys) {
  testing::internal::CaptureStdout();
  const std::string r = RunCli({"--env", "breakout", "--source", "Action", "--targets", "Paddle", "--steps", "3000",
                                "--passive-steps", "200", "--passive-hard-steps", "200", "--active-steps", "300",
                                "--eval", "--eval-steps", "1000", "--granger", "--json"});
  const std::string out = testing::internal::GetCapturedStdout();
  ASSERT_EQ(r, "");
  const nlohmann::json j = nlohmann::json::parse(out);
  ASSERT_EQ(j["targets"].size(), 1u);
  const auto& t = j["targets"][0];
  for (const char* key : {"target", "score", "mg_score", "interactions", "mask", "goal_set", "goal_kind", "pass",
                          "fp_per_state", "fn_per_interaction", "false_positives", "fp_after_interaction"}) {
    EXPECT_TRUE(t.contains(key)) << key;
  }
  EXPECT_EQ(t["target"], "Paddle");
  EXPECT_LE(t["fp_after_interaction"].get<int64_t>(), t["false_positives"].get<int64_t>());
  EXPECT_TRUE(t["pass"].is_boolean());
  EXPECT_EQ(t["mask"].size(), 5u);
  EXPECT_EQ(j["granger"].size(), 1u);

  // the linear screen skips a target it finds unrelated (Action->Ball: p about 1)
  testing::internal::CaptureStdout();
  ASSERT_EQ(RunCli({"--env", "breakout", "--source", "Action", "--targets", "Ball", "--steps", "3000", "--screen",
                    "0.5", "--json"}),
            "");
  const nlohmann::json k = nlohmann::json::parse(testing::internal::GetCapturedStdout());
  EXPECT_EQ(k["targets"][0]["screened"], true);
  EXPECT_EQ(k["targets"][0]["pass"], false);
}

}  // namespace
}  // namespace coins::detector
