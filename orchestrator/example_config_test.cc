// deploy/configs/breakout.yaml, the config users start from, stays complete: it lists every key
// of every section, each with its default unless the key is one the example sets on purpose.
#include <set>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "common/files.h"
#include "orchestrator/system_config.h"

namespace coins {
namespace {

// the keys the example sets to values of its own (each with a comment in the file)
const std::set<std::string> kSetByTheExample = {"run.steps",
                                                "run.dir",
                                                "run.report_returns",
                                                "orchestrator.skill_max_steps",
                                                "orchestrator.n_complete_goals",
                                                "learner.skill_acting_average",
                                                "learner.primitive_goal_sample_ratio",
                                                "learner.skill_interaction_reward"};

TEST(ExampleConfig, ListsEveryKeyWithItsDefault) {
  auto text = ReadFileText(COINS_EXAMPLE_CONFIG);
  ASSERT_TRUE(text.ok()) << text.status().message();
  SystemConfig defaults, loaded;
  ConfigLoader loader = loaded.Loader();
  ASSERT_TRUE(loader.LoadText(*text, "breakout.yaml").ok());
  std::set<std::string> listed;
  for (const auto& section : YAML::Load(*text))
    for (const auto& key : section.second)
      listed.insert(section.first.as<std::string>() + "." + key.first.as<std::string>());
  const ConfigValues want = defaults.Values(), got = loaded.Values();
  for (const auto& [key, value] : want) {
    EXPECT_TRUE(listed.count(key)) << key << " (default " << value << ") is missing from " << COINS_EXAMPLE_CONFIG;
    if (!kSetByTheExample.count(key)) {
      EXPECT_EQ(got.at(key), value) << key << " is not its default";
    }
  }
}

}  // namespace
}  // namespace coins
