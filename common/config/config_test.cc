#include "common/config/config.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>

#include "common/dds/dds_options.h"

namespace coins {
namespace {

struct TestOptions {
  int64_t capacity = 100;
  double ratio = 0.5;
  bool enabled = true;
  std::string mode = "fast";
  std::vector<double> mask = {1, 0};
  std::vector<int> sizes = {64, 32};
  float scale = 2.5f;
  void Visit(ConfigVisitor& v) {
    v.Int("capacity", capacity, 1, 1000, "items");
    v.Float("ratio", ratio, 0.0, 1.0, "fraction");
    v.Bool("enabled", enabled, "on/off");
    v.String("mode", mode, {"fast", "slow"}, "speed");
    v.FloatList("mask", mask, "mask");
    VisitIntList(v, "sizes", sizes, 1, 100, "layer sizes");
    VisitFloat(v, "scale", scale, 0.5, 4.0, "a float field");
  }
  Status Validate() const {
    if (mode == "slow" && capacity > 10) return Errorf("capacity {} too large for slow mode", capacity);
    return Status::Ok();
  }
};

struct Fixture : ::testing::Test {
  TestOptions opts;
  DdsOptions dds;
  ConfigLoader loader{{ConfigSection::Of("replay", opts), ConfigSection::Of("dds", dds)}};
};

TEST_F(Fixture, LoadsValuesAndKeepsDefaults) {
  ASSERT_TRUE(loader.LoadText("replay:\n  capacity: 7\n  mask: [0.5, 2]\ndds:\n  domain: 12\n", "t").ok());
  EXPECT_EQ(opts.capacity, 7);
  EXPECT_DOUBLE_EQ(opts.ratio, 0.5);
  EXPECT_EQ(opts.mask, (std::vector<double>{0.5, 2}));
  EXPECT_EQ(dds.domain, 12);
  EXPECT_EQ(dds.discovery, "local");
}

TEST_F(Fixture, UnknownKeyNamesKeyAndSuggests) {
  Status s = loader.LoadText("replay:\n  capcity: 7\n", "config x.yaml");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.message(), "config x.yaml: unknown key 'replay.capcity' (did you mean 'capacity'?)");
  // a key an earlier version had says where it went
  TestOptions learner;
  ConfigLoader with_learner({ConfigSection::Of("learner", learner)});
  EXPECT_EQ(
      with_learner.ApplyOverride("learner.detect_passive_steps=100").message(),
      "override learner.detect_passive_steps=100: 'learner.detect_passive_steps' is now 'detector.passive_steps'");
  EXPECT_EQ(opts.capacity, 100);
}

// a key earlier versions wrote and this one no longer reads: ignored at the value this version
// behaves as, refused naming the key at any other
TEST_F(Fixture, ARetiredKeyIsIgnoredOnlyAtItsOldValue) {
  TestOptions learner;
  ConfigLoader old_file({ConfigSection::Of("learner", learner)});
  ASSERT_TRUE(old_file.LoadText("learner:\n  task_episode_end_reward: 0.0\n  ratio: 0.25\n", "old.yaml").ok());
  EXPECT_DOUBLE_EQ(learner.ratio, 0.25) << "the other keys of the section still load";
  Status s = old_file.LoadText("learner:\n  task_episode_end_reward: -1\n", "old.yaml");
  EXPECT_EQ(s.message(),
            "old.yaml: 'learner.task_episode_end_reward' is no longer read: only its old value 0 can be ignored, "
            "got '-1'");
  EXPECT_TRUE(IsRetiredAtItsValue("learner.task_episode_end_reward", "0"));
  EXPECT_FALSE(IsRetiredAtItsValue("learner.task_episode_end_reward", "0x"));
  EXPECT_FALSE(IsRetiredAtItsValue("learner.skill_episode_end_reward", "0"));
  EXPECT_TRUE(IsRetiredAtItsValue("learner.task_reach_needs_interaction", "true"));
  EXPECT_FALSE(IsRetiredAtItsValue("learner.task_reach_needs_interaction", "false"));
  EXPECT_EQ(RetiredKeyValue("learner.skill_episode_end_reward"), "");
}

TEST_F(Fixture, KeysThatAreNotNamesAreOneLineErrors) {
  // a list, a map or null as a key, at the top level or in a section (yaml-cpp threw, and every
  // binary aborted)
  const std::pair<const char*, const char*> cases[] = {
      {"[1]: 2\n", "a top-level key is a list, not a section name"},
      {"{a: 1}: 2\n", "a top-level key is a map, not a section name"},
      {"replay:\n  [1]: 2\n", "section 'replay' has a key that is a list, not a name"},
      {"replay:\n  ? {x: 1}\n  : 3\n", "section 'replay' has a key that is a map, not a name"},
      {"replay:\n  ~: 3\n", "section 'replay' has a key that is nothing, not a name"},
      {"learner:\n  [1]: 2\n", ""},  // another process's section: not read here
  };
  for (const auto& [text, expected] : cases) {
    Status s = loader.LoadText(text, "config k.yaml");
    if (*expected == '\0') {
      EXPECT_TRUE(s.ok()) << text << s.message();
      continue;
    }
    ASSERT_FALSE(s.ok()) << text;
    EXPECT_NE(s.message().find(expected), std::string::npos) << text << " -> " << s.message();
    EXPECT_EQ(s.message().find('\n'), std::string::npos) << s.message();
    EXPECT_EQ(s.message().rfind("config k.yaml: ", 0), 0u) << s.message();
  }
  // and through an override
  Status s = loader.ApplyOverride("replay.capacity={[1]: 2}");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("replay.capacity: expected an integer, got a map"), std::string::npos) << s.message();
}

TEST_F(Fixture, UnknownSectionIsAnErrorButOtherProcessSectionsAreAllowed) {
  EXPECT_TRUE(loader.LoadText("learner:\n  anything: 1\n", "t").ok());
  Status s = loader.LoadText("replai:\n  capacity: 1\n", "t");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("unknown section 'replai' (did you mean 'replay'?)"), std::string::npos);
}

TEST_F(Fixture, WrongTypesAndRanges) {
  Status s = loader.LoadText("replay:\n  capacity: lots\n", "t");
  EXPECT_EQ(s.message(), "t: replay.capacity: expected an integer, got 'lots'");
  s = loader.LoadText("replay:\n  capacity: 0\n", "t");
  EXPECT_EQ(s.message(), "t: replay.capacity: must be in [1, 1000], got 0");
  s = loader.LoadText("replay:\n  capacity: -5\n", "t");
  EXPECT_EQ(s.message(), "t: replay.capacity: must be in [1, 1000], got -5");
  s = loader.LoadText("replay:\n  ratio: .nan\n", "t");
  EXPECT_EQ(s.message(), "t: replay.ratio: expected a finite number, got '.nan'");
  s = loader.LoadText("replay:\n  enabled: maybe\n", "t");
  EXPECT_EQ(s.message(), "t: replay.enabled: expected true or false, got 'maybe'");
  s = loader.LoadText("replay:\n  mode: medium\n", "t");
  EXPECT_EQ(s.message(), "t: replay.mode: 'medium' is not one of: fast, slow");
  s = loader.LoadText("replay:\n  mask: 3\n", "t");
  EXPECT_EQ(s.message(), "t: replay.mask: expected a list of numbers, got '3'");
  s = loader.LoadText("replay: [1, 2]\n", "t");
  EXPECT_EQ(s.message(), "t: section 'replay' must be a map of keys");
  s = loader.LoadText("replay:\n  capacity: [\n", "t");
  EXPECT_NE(s.message().find("t: not valid YAML at line"), std::string::npos);
  EXPECT_EQ(opts.capacity, 100);
}

TEST_F(Fixture, OverridesApplyAndAreChecked) {
  ASSERT_TRUE(loader.ApplyOverride("replay.capacity=9").ok());
  EXPECT_EQ(opts.capacity, 9);
  ASSERT_TRUE(loader.ApplyOverride("replay.mask=[1,1,0]").ok());
  EXPECT_EQ(opts.mask.size(), 3u);
  EXPECT_EQ(loader.ApplyOverride("replay.capacity=x").message(),
            "override replay.capacity=x: replay.capacity: expected an integer, got 'x'");
  EXPECT_EQ(loader.ApplyOverride("capacity=3").message(), "override 'capacity=3': expected section.key=value");
  EXPECT_EQ(loader.ApplyOverride("nope.capacity=3").message(), "override 'nope.capacity=3': unknown section 'nope'");
  EXPECT_FALSE(loader.ApplyOverride("replay.nokey=3").ok());
}

TEST_F(Fixture, CrossFieldValidation) {
  ASSERT_TRUE(loader.ApplyOverride("replay.mode=slow").ok());
  Status s = loader.Validate();
  EXPECT_EQ(s.message(), "config: replay: capacity 100 too large for slow mode");
}

TEST_F(Fixture, MissingFileIsAnError) {
  Status s = loader.LoadFile("/nonexistent/coins.yaml");
  EXPECT_EQ(s.message(), "config file '/nonexistent/coins.yaml' cannot be read");
}

TEST_F(Fixture, DumpRoundTrips) {
  ASSERT_TRUE(loader.LoadText("replay:\n  capacity: 42\n  mode: slow\n", "t").ok());
  std::string dumped = loader.Dump();
  TestOptions other;
  DdsOptions other_dds;
  ConfigLoader again{{ConfigSection::Of("replay", other), ConfigSection::Of("dds", other_dds)}};
  ASSERT_TRUE(again.LoadText(dumped, "dump").ok()) << dumped;
  EXPECT_EQ(other.capacity, 42);
  EXPECT_EQ(other.mode, "slow");
  EXPECT_EQ(other.mask, opts.mask);
}

TEST_F(Fixture, NarrowFieldsAndIntegerListsAreReadAndChecked) {
  ASSERT_TRUE(loader.LoadText("replay:\n  sizes: [8, 100]\n  scale: 0.75\n", "t").ok());
  EXPECT_EQ(opts.sizes, (std::vector<int>{8, 100}));
  EXPECT_FLOAT_EQ(opts.scale, 0.75f);
  EXPECT_EQ(loader.LoadText("replay:\n  sizes: [8, 101]\n", "t").message(),
            "t: replay.sizes: entries must be in [1, 100], got 101");
  EXPECT_EQ(loader.LoadText("replay:\n  sizes: [8, 2.5]\n", "t").message(),
            "t: replay.sizes: expected a list of integers, found '2.5'");
  EXPECT_EQ(loader.LoadText("replay:\n  scale: 5\n", "t").message(), "t: replay.scale: must be in [0.5, 4], got 5");
  EXPECT_EQ(opts.sizes, (std::vector<int>{8, 100}));  // a refused value changes nothing
  EXPECT_NE(loader.Dump().find("sizes: [8, 100]"), std::string::npos) << loader.Dump();
}

TEST_F(Fixture, RangesAreCheckedOnValuesSetInCode) {
  EXPECT_TRUE(CheckConfigRanges(opts).ok());
  opts.sizes = {4, 0};
  EXPECT_EQ(CheckConfigRanges(opts).message(), "sizes entries must be in [1, 100], got 0");
  opts = TestOptions();
  opts.ratio = std::nan("");
  EXPECT_EQ(CheckConfigRanges(opts).message(), "ratio must be in [0, 1], got nan");
  opts = TestOptions();
  opts.mode = "medium";
  EXPECT_EQ(CheckConfigRanges(opts).message(), "mode 'medium' is not one of: fast, slow");
}

TEST_F(Fixture, ConfigJsonHasEveryField) {
  opts.capacity = 9;
  opts.sizes = {3};
  EXPECT_EQ(ConfigJson(ConfigSection::Of("replay", opts)),
            R"({"capacity":9,"enabled":true,"mask":[1.0,0.0],"mode":"fast","ratio":0.5,"scale":2.5,"sizes":[3]})");
}

}  // namespace
}  // namespace coins
