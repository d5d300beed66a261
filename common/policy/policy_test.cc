// Level specs, observations and actions of the hierarchy, with numbers worked out by hand.
#include <gtest/gtest.h>

#include <limits>

#include <nlohmann/json.hpp>

#include "common/nn/serialize.h"
#include "common/policy/actions.h"
#include "common/policy/level_spec.h"
#include "common/policy/policy_net.h"
#include "common/policy/weights_msg.h"

namespace coins::policy {
namespace {

// a ball-skill-like level: paddle (2 features) and ball (2 features), relative x, goal on the
// ball's second feature
LevelSpec BallLike() {
  LevelSpec s;
  s.name = "skill/Ball";
  s.level = 2;
  s.source = "Paddle";
  s.goal.factor = "Ball";
  s.goal.offset = 2;
  s.goal.features = 2;
  s.goal.mask = {0, 1};
  s.goal.masked = {1};
  s.goal.scale_low = {-2};
  s.goal.scale_high = {2};
  s.goal.kind = GoalKind::kDiscrete;
  s.goal.goals = {{-1}, {1}};
  s.goal.epsilon = 0.01f;
  s.obs_index = {0, 1, 2, 3};
  s.obs_low = {0, 0, 0, -2};
  s.obs_high = {84, 84, 84, 2};
  s.relative = {{1, 2}};
  s.relative_scale = {42};
  s.action_kind = ActionKind::kChildOffsets;
  s.num_actions = 3;
  s.child_offsets = {-1, 0, 1};
  s.child_ratio = 0.25f;
  s.hidden = {8};
  s.atoms = 11;
  return s;
}

TEST(LevelSpec, JsonRoundTripAndValidation) {
  const LevelSpec s = BallLike();
  ASSERT_TRUE(s.Validate().ok()) << s.Validate().message();
  auto back = ParseLevelSpec(ToJson(s).dump());
  ASSERT_TRUE(back.ok()) << back.status().message();
  EXPECT_EQ(ToJson(*back), ToJson(s));
  EXPECT_EQ(back->obs_dim(), 4 + 1 + 1);
  LevelSpec near = s;  // the goal sample ratio travels; weights written before it read as 0
  near.goal.sample_ratio = 0.2f;
  EXPECT_FLOAT_EQ(ParseLevelSpec(ToJson(near).dump())->goal.sample_ratio, 0.2f);
  nlohmann::json older = ToJson(near);
  older["goal"].erase("sample_ratio");
  EXPECT_EQ(ParseLevelSpec(older.dump())->goal.sample_ratio, 0.0f);
  near.goal.sample_ratio = -1;
  EXPECT_NE(near.Validate().message().find("sample_ratio"), std::string::npos);
  LevelSpec bad = s;
  bad.child_offsets = {0, 1};
  EXPECT_NE(bad.Validate().message().find("child_offsets"), std::string::npos);
  bad = s;
  bad.algorithm = "ddpg";
  EXPECT_NE(bad.Validate().message().find("ddpg needs continuous"), std::string::npos);
  EXPECT_FALSE(ParseLevelSpec("{\"name\": 1}").ok());
  EXPECT_FALSE(ParseLevelSpec("not json").ok());
}

TEST(Observation, NormalisesFeaturesRelativePositionsAndGoal) {
  const LevelSpec s = BallLike();
  const float state[4] = {42, 63, 21, 1};
  float features[4], obs[6];
  GatherFeatures(s, state, features);
  const float goal[1] = {-1};
  BuildObservation(s, features, goal, obs);
  EXPECT_FLOAT_EQ(obs[0], 0.0f);   // 42 in [0, 84]
  EXPECT_FLOAT_EQ(obs[1], 0.5f);   // 63
  EXPECT_FLOAT_EQ(obs[2], -0.5f);  // 21
  EXPECT_FLOAT_EQ(obs[3], 0.5f);   // 1 in [-2, 2]
  EXPECT_FLOAT_EQ(obs[4], (63.0f - 21.0f) / 42.0f);
  EXPECT_FLOAT_EQ(obs[5], -0.5f);  // goal -1 in [-2, 2]
}

TEST(Actions, ChildGoalsFromOffsetsDiscreteAndContinuous) {
  LevelSpec parent = BallLike();
  GoalSpace child;
  child.offset = 1;
  child.masked = {0};
  child.low = {10};
  child.high = {50};
  const float state[4] = {0, 40, 0, 0};
  float goal[1], action[1] = {2};
  EXPECT_FALSE(ToChildGoal(parent, child, action, state, goal));
  EXPECT_FLOAT_EQ(goal[0], 50.0f);  // 40 + 1 * 0.25 * 40 = 50
  action[0] = 0;
  ToChildGoal(parent, child, action, state, goal);
  EXPECT_FLOAT_EQ(goal[0], 30.0f);  // 40 - 10
  parent.action_kind = ActionKind::kChildContinuous;
  action[0] = -1;
  const float low_state[4] = {0, 12, 0, 0};
  EXPECT_TRUE(ToChildGoal(parent, child, action, low_state, goal));
  EXPECT_FLOAT_EQ(goal[0], 10.0f);  // clipped to the child's bounds (and said so)
  action[0] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_TRUE(ToChildGoal(parent, child, action, state, goal));
  EXPECT_FLOAT_EQ(goal[0], 40.0f);  // a non-finite action leaves the goal where the child is
  child.kind = GoalKind::kDiscrete;
  child.goals = {{-1}, {2}};
  parent.action_kind = ActionKind::kChildDiscrete;
  action[0] = 1;
  ToChildGoal(parent, child, action, state, goal);
  EXPECT_FLOAT_EQ(goal[0], 2.0f);
  std::mt19937_64 rng(1);
  child.kind = GoalKind::kContinuous;
  for (int i = 0; i < 100; ++i) {
    RandomGoal(child, 0.0f, state, &rng, goal);
    ASSERT_GE(goal[0], 10.0f);
    ASSERT_LE(goal[0], 50.0f);
  }
}

TEST(Actions, RandomGoalsNearTheTargetWithASampleRatio) {
  GoalSpace g;
  g.kind = GoalKind::kContinuous;
  g.offset = 1;
  g.masked = {0, 2};  // the target's features 0 and 2: state[1] and state[3]
  g.low = {10, -1};
  g.high = {50, 1};
  g.sample_ratio = 0.1f;  // within 4 of x, 0.2 of the second
  const float state[4] = {0, 40, 0, 0.95f};
  std::mt19937_64 rng(7);
  float goal[2];
  float x_min = 1e9f, x_max = -1e9f, y_min = 1e9f, y_max = -1e9f;
  for (int i = 0; i < 2000; ++i) {
    RandomGoal(g, g.sample_ratio, state, &rng, goal);
    x_min = std::min(x_min, goal[0]), x_max = std::max(x_max, goal[0]);
    y_min = std::min(y_min, goal[1]), y_max = std::max(y_max, goal[1]);
  }
  EXPECT_GE(x_min, 36.0f);
  EXPECT_LE(x_max, 44.0f);
  EXPECT_LT(x_min, 36.2f);  // the whole window is used
  EXPECT_GT(x_max, 43.8f);
  EXPECT_GE(y_min, 0.75f);  // 0.95 - 0.2, and clipped to the bound 1 above
  EXPECT_LE(y_max, 1.0f);
  EXPECT_GT(y_max, 0.99f);
  const float outside[4] = {0, 90, 0, 0};  // a target outside the bounds: the window starts at the bound
  RandomGoal(g, g.sample_ratio, outside, &rng, goal);
  EXPECT_GE(goal[0], 46.0f);
  EXPECT_LE(goal[0], 50.0f);
}

TEST(PolicyNet, GreedyActionIsTheArgmaxAndBlobsRoundTrip) {
  const LevelSpec s = BallLike();
  auto a = PolicyNet::Create(s, 3), b = PolicyNet::Create(s, 4);
  ASSERT_TRUE(a.ok() && b.ok());
  const float obs[6] = {0.1f, -0.2f, 0.3f, 0.4f, -0.5f, 0.6f};
  std::mt19937_64 rng(1);
  float act_a[1], act_b[1];
  a->Act(obs, 0.0f, &rng, act_a);
  Eigen::Index best;
  a->last_q().maxCoeff(&best);
  EXPECT_EQ(int(act_a[0]), int(best));
  const Status empty = b->Load({}, "empty weights");
  EXPECT_NE(empty.message().find("empty weights"), std::string::npos) << empty.message();
  ASSERT_TRUE(b->Load(nn::ToBlob(a->params()), "a").ok());
  b->Act(obs, 0.0f, &rng, act_b);
  EXPECT_EQ(act_a[0], act_b[0]);
  EXPECT_TRUE(a->last_q().isApprox(b->last_q()));
}

// sac levels act with tanh of the policy's mean when greedy and sample it (spread by its own
// log-std, not by `explore`) otherwise
TEST(PolicyNet, SacActsWithTheSquashedMeanOrSamplesItsPolicy) {
  LevelSpec s = BallLike();
  s.action_kind = ActionKind::kChildContinuous;
  s.num_actions = 0;
  s.child_offsets.clear();
  s.action_dim = 1;
  s.algorithm = "sac";
  s.atoms = 1;
  auto net = PolicyNet::Create(s, 5);
  ASSERT_TRUE(net.ok()) << net.status().message();
  EXPECT_EQ(s.network_outputs(), 2);
  nn::QNet same(ActingNetworkOptions(s), 5);
  const float obs[6] = {0.1f, -0.2f, 0.3f, 0.4f, -0.5f, 0.6f};
  const Eigen::MatrixXf raw = same.Forward(Eigen::Map<const Eigen::MatrixXf>(obs, 6, 1));
  std::mt19937_64 rng(2);
  float greedy[1];
  net->Act(obs, 0.0f, &rng, greedy);
  EXPECT_FLOAT_EQ(greedy[0], std::tanh(raw(0, 0)));
  double sum = 0.0, sq = 0.0;
  for (int i = 0; i < 2000; ++i) {
    float a[1];
    net->Act(obs, 0.01f, &rng, a);
    ASSERT_TRUE(a[0] >= -1.0f && a[0] <= 1.0f);
    sum += std::atanh(std::clamp(double(a[0]), -0.999999, 0.999999));
    sq += std::pow(std::atanh(std::clamp(double(a[0]), -0.999999, 0.999999)) - raw(0, 0), 2);
  }
  // u = mean + std * noise with log_std = -5 + 7 (tanh(raw[1]) + 1) / 2
  const double std_expected = std::exp(-5.0 + 7.0 * (std::tanh(raw(1, 0)) + 1.0) / 2.0);
  EXPECT_NEAR(sum / 2000.0, raw(0, 0), 4.0 * std_expected / std::sqrt(2000.0) + 1e-3);
  EXPECT_NEAR(std::sqrt(sq / 2000.0), std_expected, 0.1 * std_expected);
  s.action_kind = ActionKind::kChildOffsets;
  s.num_actions = 3;
  s.child_offsets = {-1, 0, 1};
  EXPECT_NE(s.Validate().message().find("sac needs continuous actions"), std::string::npos);
}

TEST(Weights, ChecksumAndVersionAreChecked) {
  msg::PolicyWeights w = MakeWeights("skill/Ball", 5, 10, "{}", {1, 2, 3});
  EXPECT_TRUE(CheckWeights(w, 4).ok());
  EXPECT_NE(CheckWeights(w, 5).message().find("not newer"), std::string::npos);
  w.blob()[1] = 9;
  EXPECT_NE(CheckWeights(w, 0).message().find("checksum"), std::string::npos);
}

}  // namespace
}  // namespace coins::policy
