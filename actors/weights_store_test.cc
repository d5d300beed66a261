// The actor's weights: checked before use, rejected ones counted, the old ones kept.
#include "actors/weights_store.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "actors/envs/env.h"
#include "common/nn/serialize.h"
#include "common/policy/weights_msg.h"

namespace coins {
namespace {

// the paddle skill's spec on Breakout
policy::LevelSpec PaddleSpec(const envs::EnvSpec& env) {
  policy::LevelSpec s;
  s.name = "skill/Paddle";
  s.level = 1;
  s.source = "Action";
  auto g = policy::MakeGoalSpace(env, "Paddle", {0, 1, 0, 0, 0});
  s.goal = *g;
  s.goal.kind = policy::GoalKind::kContinuous;
  s.goal.low = {7.5f};
  s.goal.high = {75.5f};
  s.goal.epsilon = 1.0f;
  const int p = env.factor_offset(env.factor_index("Paddle"));
  for (int i = 0; i < 5; ++i) {
    s.obs_index.push_back(p + i);
    s.obs_low.push_back(-100);
    s.obs_high.push_back(100);
  }
  s.num_actions = 4;
  s.hidden = {16};
  return s;
}

std::vector<uint8_t> Blob(const policy::LevelSpec& s, uint64_t seed) {
  return nn::ToBlob(policy::PolicyNet::Create(s, seed)->params());
}

TEST(WeightsStore, AcceptsNewerWeightsAndRejectsBadOnesKeepingTheOld) {
  auto env = envs::MakeEnv("breakout");
  ASSERT_TRUE(env.ok());
  WeightsStore store((*env)->spec());
  const policy::LevelSpec spec = PaddleSpec((*env)->spec());
  const std::string text = ToJson(spec).dump();
  ASSERT_TRUE(store.Apply(policy::MakeWeights("skill/Paddle", 2, 10, text, Blob(spec, 1))).ok());
  ASSERT_NE(store.models().at(1), nullptr);
  EXPECT_EQ(store.models().at(1)->version, 2u);
  EXPECT_TRUE(store.models().at(1)->trained);
  EXPECT_EQ(store.structure_changes(), 1u);
  const nn::ParamSet held = store.models().at(1)->net.params();

  // an older version, a corrupt blob, a blob of another shape, a spec that does not parse
  Status s = store.Apply(policy::MakeWeights("skill/Paddle", 1, 10, text, Blob(spec, 2)));
  EXPECT_NE(s.message().find("not newer"), std::string::npos) << s.message();
  msg::PolicyWeights corrupt = policy::MakeWeights("skill/Paddle", 3, 10, text, Blob(spec, 3));
  corrupt.blob()[40] ^= 0xff;
  s = store.Apply(corrupt);
  EXPECT_NE(s.message().find("checksum"), std::string::npos) << s.message();
  policy::LevelSpec wider = spec;
  wider.hidden = {32};
  s = store.Apply(policy::MakeWeights("skill/Paddle", 4, 10, text, Blob(wider, 4)));
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("skill/Paddle"), std::string::npos) << s.message();
  s = store.Apply(policy::MakeWeights("skill/Paddle", 5, 10, "{\"level\": 1}", Blob(spec, 5)));
  EXPECT_NE(s.message().find("level spec"), std::string::npos) << s.message();
  EXPECT_EQ(store.rejected(), 4u);
  EXPECT_EQ(store.models().at(1)->version, 2u);
  EXPECT_EQ(store.models().at(1)->net.params().values, held.values);

  // a newer good version loads in place: no structure change
  ASSERT_TRUE(store.Apply(policy::MakeWeights("skill/Paddle", 6, 20, text, Blob(spec, 6))).ok());
  EXPECT_EQ(store.models().at(1)->version, 6u);
  EXPECT_NE(store.models().at(1)->net.params().values, held.values);
  EXPECT_EQ(store.structure_changes(), 1u);
  EXPECT_EQ(store.versions()[0], 6u);
}

TEST(WeightsStore, AStateBeyondTheEnvIsRefused) {
  auto env = envs::MakeEnv("breakout");
  WeightsStore store((*env)->spec());
  policy::LevelSpec spec = PaddleSpec((*env)->spec());
  spec.obs_index[0] = 100000;
  Status s = store.Apply(policy::MakeWeights("skill/Paddle", 1, 1, ToJson(spec).dump(), Blob(spec, 1)));
  EXPECT_NE(s.message().find("beyond"), std::string::npos) << s.message();
  EXPECT_EQ(store.rejected(), 1u);
}

}  // namespace
}  // namespace coins
