#include "common/config/config_flags.h"

#include <gtest/gtest.h>

namespace coins {
namespace {

struct Options {
  int64_t steps = 100;
  double rate = 0.5;
  bool gate = true;
  std::string rule = "relative";
  std::vector<int> hidden = {128, 128};
  int64_t seed = 1;
  void Visit(ConfigVisitor& v) {
    v.Int("steps", steps, 1, 1000, "Adam steps");
    v.Float("rate", rate, 0, 1, "a rate");
    v.Bool("gate", gate, "a switch");
    v.String("rule", rule, {"relative", "absolute"}, "a rule");
    VisitIntList(v, "hidden_sizes", hidden, 1, 8192, "layer sizes");
    v.Int("seed", seed, 0, 10, "set by the command");
  }
  Status Validate() const { return Status::Ok(); }
};

// parses args into a fresh Options through flags made from its fields; returns CLI11's error
// text ("" when parsed) and the Apply status
struct Parsed {
  std::string cli_error;
  Status applied;
  Options options;
  bool steps_given = false;
};
Parsed Parse(std::vector<std::string> args) {
  CLI::App app("test");
  Options defaults;
  ConfigFlags flags(&app, ConfigSection::Of("detector", defaults), {"seed"});
  std::reverse(args.begin(), args.end());
  Parsed out;
  try {
    app.parse(args);
  } catch (const CLI::ParseError& e) {
    out.cli_error = e.what();
    return out;
  }
  ConfigLoader loader({ConfigSection::Of("detector", out.options)});
  out.applied = flags.Apply(loader);
  out.steps_given = flags.Given("steps");
  return out;
}

TEST(ConfigFlags, EveryFieldIsAFlagWithDashes) {
  Parsed p = Parse(
      {"--steps", "7", "--rate", "0.25", "--gate", "false", "--rule", "absolute", "--hidden-sizes", "512,256,128"});
  ASSERT_EQ(p.cli_error, "");
  ASSERT_TRUE(p.applied.ok()) << p.applied.message();
  EXPECT_EQ(p.options.steps, 7);
  EXPECT_DOUBLE_EQ(p.options.rate, 0.25);
  EXPECT_FALSE(p.options.gate);
  EXPECT_EQ(p.options.rule, "absolute");
  EXPECT_EQ(p.options.hidden, (std::vector<int>{512, 256, 128}));
  EXPECT_TRUE(p.steps_given);
}

TEST(ConfigFlags, FlagsNotGivenKeepTheDefaultsAndSkippedKeysHaveNoFlag) {
  Parsed p = Parse({"--rate", "1"});
  ASSERT_EQ(p.cli_error, "");
  EXPECT_EQ(p.options.steps, 100);
  EXPECT_EQ(p.options.hidden, (std::vector<int>{128, 128}));
  EXPECT_FALSE(p.steps_given);
  EXPECT_NE(Parse({"--seed", "3"}).cli_error, "");
}

TEST(ConfigFlags, ValuesOutsideTheFieldsRangesAreRefusedNamingTheFlag) {
  EXPECT_EQ(Parse({"--steps", "1001"}).cli_error, "--steps: must be an integer in [1, 1000], got '1001'");
  EXPECT_EQ(Parse({"--rate", "nan"}).cli_error, "--rate: must be a finite number in [0, 1], got 'nan'");
  EXPECT_EQ(Parse({"--hidden-sizes", "64,0"}).cli_error, "--hidden-sizes: must be an integer in [1, 8192], got '0'");
  EXPECT_NE(Parse({"--rule", "odd"}).cli_error.find("--rule"), std::string::npos);
  EXPECT_NE(Parse({"--gate", "maybe"}).cli_error.find("--gate"), std::string::npos);
}

}  // namespace
}  // namespace coins
