// Level specs built from links, and trainers whose acting weights actors can load.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include <nlohmann/json.hpp>

#include "actors/envs/env.h"
#include "common/nn/serialize.h"
#include "common/policy/policy_net.h"
#include "learner/trainers/input_remap.h"
#include "learner/trainers/level_builder.h"
#include "learner/trainers/policy_trainer.h"

namespace coins {
namespace {

msg::LinkSpec Link(const std::string& source, const std::string& target, std::vector<float> mask,
                   const std::string& kind, std::vector<float> goals, double rate) {
  msg::LinkSpec l;
  l.source(source);
  l.target(target);
  l.mask(mask);
  l.goal_kind(kind);
  l.goal_set(goals);
  l.interaction_rate(rate);
  return l;
}

struct Breakout {
  std::unique_ptr<envs::Env> env = std::move(*envs::MakeEnv("breakout"));
  const envs::EnvSpec& spec = env->spec();
  msg::LinkSpec paddle = Link("Action", "Paddle", {0, 1, 0, 0, 0}, "continuous", {7.5f, 75.5f}, 0.46);
  msg::LinkSpec ball = Link("Paddle", "Ball", {0, 0, 1, 1, 0}, "discrete", {-1, -1, -2, -1, -2, 1, -1, 1}, 0.004);
};

TEST(LevelBuilder, BreakoutChainLevels) {
  Breakout b;
  LearnerOptions o;
  auto paddle = BuildSkillSpec(b.spec, b.paddle, 1, nullptr, o.primitive);
  ASSERT_TRUE(paddle.ok()) << paddle.status().message();
  EXPECT_EQ(paddle->obs_dim(), 5 + 1);  // the paddle and its goal x
  EXPECT_EQ(paddle->action_kind, policy::ActionKind::kPrimitiveDiscrete);
  EXPECT_EQ(paddle->num_actions, 4);
  EXPECT_FALSE(paddle->terminate_on_interaction);  // the action moves the paddle one step in two
  EXPECT_NEAR(paddle->goal.epsilon, 1.0f, 0.02f);  // 1 px
  EXPECT_EQ(paddle->goal.sample_ratio, 0.0f);      // default: random goals anywhere
  LevelTrainOptions near = o.primitive;
  near.goal_sample_ratio = 0.1;
  EXPECT_FLOAT_EQ(BuildSkillSpec(b.spec, b.paddle, 1, nullptr, near)->goal.sample_ratio, 0.1f);

  auto ball = BuildSkillSpec(b.spec, b.ball, 2, &*paddle, o.skill);
  ASSERT_TRUE(ball.ok()) << ball.status().message();
  EXPECT_EQ(ball->obs_dim(), 5 + 5 + 2 + 2);  // paddle, ball, relative y and x, goal vy and vx
  EXPECT_EQ(ball->action_kind, policy::ActionKind::kChildOffsets);
  // paddle goals 0, 2, 4 and 6 px either way of the paddle (a bounce's angle is set by 2 px zones)
  ASSERT_EQ(ball->num_actions, 7);
  for (int i = 0; i < 7; ++i)
    EXPECT_NEAR(ball->child_offsets[size_t(i)] * ball->child_ratio * 68.0f, 2.0f * float(i - 3), 0.2f);
  EXPECT_EQ(ball->goal.goals.size(), 4u);
  EXPECT_TRUE(ball->terminate_on_interaction && ball->require_interaction);  // a bounce is rare
  LevelTrainOptions sustained = o.skill;  // pushing's block: a push does not end the goal
  sustained.interaction_ends_goal = "never";
  auto pushed = BuildSkillSpec(b.spec, b.ball, 2, &*paddle, sustained);
  ASSERT_TRUE(pushed.ok()) << pushed.status().message();
  EXPECT_TRUE(pushed->require_interaction);
  EXPECT_FALSE(pushed->terminate_on_interaction);
  sustained.reach_needs_interaction = false;  // the block at its goal is enough
  auto placed = BuildSkillSpec(b.spec, b.ball, 2, &*paddle, sustained);
  ASSERT_TRUE(placed.ok()) << placed.status().message();
  EXPECT_FALSE(placed->require_interaction);
  EXPECT_EQ(placed->detector, "detector/Paddle->Ball");  // still rewards and counts pushes
  EXPECT_EQ(ball->detector, "detector/Paddle->Ball");

  auto task = BuildTaskSpec(b.spec, *ball, o.task);
  ASSERT_TRUE(task.ok()) << task.status().message();
  EXPECT_TRUE(task->is_task());
  EXPECT_EQ(task->level, 3);
  EXPECT_EQ(task->action_kind, policy::ActionKind::kChildDiscrete);
  EXPECT_EQ(task->num_actions, 4);
  EXPECT_EQ(task->obs_dim(), 5 + 5 + 100 * 5 + 2);  // paddle, ball, blocks, relative
  EXPECT_EQ(task->decision_period, 0);              // default: a ball goal runs until it ends
  LevelTrainOptions periodic = o.task;              // learner.task_decision_period is honoured
  periodic.decision_period = 7;
  EXPECT_EQ(BuildTaskSpec(b.spec, *ball, periodic)->decision_period, 7);

  // a discrete goal set whose size does not fit the mask is refused, naming the link
  msg::LinkSpec bad = b.ball;
  bad.goal_set({1, 2, 3});
  auto refused = BuildSkillSpec(b.spec, bad, 2, &*paddle, o.skill);
  EXPECT_NE(refused.status().message().find("Paddle->Ball"), std::string::npos) << refused.status().message();
}

TEST(PolicyTrainer, ActingWeightsLoadIntoTheActorsNetwork) {
  Breakout b;
  LearnerOptions o;
  for (const std::string algorithm : {"dqn", "ddpg", "sac"}) {
    LevelTrainOptions g = o.skill;
    if (algorithm != "dqn") g.child_offsets.clear();  // continuous child goals: ddpg, or sac when asked
    if (algorithm == "sac") g.algorithm = "sac";
    auto paddle = BuildSkillSpec(b.spec, b.paddle, 1, nullptr, o.primitive);
    auto spec = BuildSkillSpec(b.spec, b.ball, 2, &*paddle, g);
    ASSERT_TRUE(spec.ok()) << spec.status().message();
    EXPECT_EQ(spec->algorithm, algorithm);
    EXPECT_EQ(spec->network_outputs(), algorithm == "sac" ? 2 : algorithm == "ddpg" ? 1 : 7 * 51 + 51);
    auto trainer = PolicyTrainer::Create(*spec, g, 3);
    ASSERT_TRUE(trainer.ok()) << trainer.status().message();
    auto net = policy::PolicyNet::Create(*spec);
    ASSERT_TRUE(net->Load((*trainer)->ActingBlob(), "acting").ok());
    EXPECT_EQ(nn::ToBlob(net->params()), (*trainer)->ActingBlob());
    // its state exports and imports whole
    rl::AlgorithmState st = (*trainer)->ExportState();
    auto other = PolicyTrainer::Create(*spec, g, 4);
    ASSERT_TRUE((*other)->ImportState(st).ok());
    EXPECT_EQ((*other)->ActingBlob(), (*trainer)->ActingBlob());
    EXPECT_EQ((*other)->updates(), (*trainer)->updates());
    // the sample spec reads the level's stream and features, with its rewards
    const SampleSpec& q = (*trainer)->sample_spec();
    EXPECT_EQ(q.level_mask, 1u << 2);
    EXPECT_EQ(q.features.size(), 10u);
    EXPECT_TRUE(q.require_interaction && q.terminate_on_interaction);
    EXPECT_EQ(q.goal_mask, (std::vector<float>{0, 0, 1, 1, 0}));
  }
}

// random rows of the shape a spec asks for: the features it reads, one action, the target factor as goal
class RandomRows final : public SampleSource {
 public:
  Status Sample(const SampleSpec& spec, int batch, SampleColumns* out) override {
    out->Resize(uint32_t(batch), uint32_t(spec.features.size()), 1, 5);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (auto* column : {&out->state, &out->next_state, &out->goal, &out->reward})
      for (float& x : *column) x = u(rng_);
    for (float& a : out->action) a = float(rng_() % 7);
    std::fill(out->discount.begin(), out->discount.end(), 0.9f);
    std::fill(out->weight.begin(), out->weight.end(), 1.0f);
    return Status::Ok();
  }
  void UpdatePriorities(std::span<const uint64_t>, std::span<const float>) override {}
  void UpdateWeights(std::span<const uint64_t>, std::span<const float>) override {}

 private:
  std::mt19937_64 rng_{5};
};

// learner.*_acting_average: the level acts with a running average of its online weights, which
// checkpoints keep and a kept snapshot replaces
TEST(PolicyTrainer, ActsWithTheRunningAverageOfItsWeights) {
  Breakout b;
  LearnerOptions o;
  auto paddle = BuildSkillSpec(b.spec, b.paddle, 1, nullptr, o.primitive);
  auto spec = BuildSkillSpec(b.spec, b.ball, 2, &*paddle, o.skill);
  ASSERT_TRUE(spec.ok()) << spec.status().message();
  LevelTrainOptions g = o.skill;
  g.acting_average = 0.25;
  auto averaged = PolicyTrainer::Create(*spec, g, 3);
  auto plain = PolicyTrainer::Create(*spec, o.skill, 3);  // the same seed: the same online weights
  ASSERT_TRUE(averaged.ok() && plain.ok());
  ASSERT_EQ((*averaged)->ActingBlob(), (*plain)->ActingBlob());  // the average starts at the weights
  RandomRows rows_a, rows_b;
  auto as_params = [&](const std::vector<uint8_t>& blob) {
    auto net = policy::PolicyNet::Create(*spec);
    EXPECT_TRUE(net->Load(blob, "acting").ok());
    return net->params().values;
  };
  Eigen::VectorXf expected = as_params((*plain)->ActingBlob());
  for (int k = 0; k < 3; ++k) {
    ASSERT_TRUE((*averaged)->Update(&rows_a).ok());
    ASSERT_TRUE((*plain)->Update(&rows_b).ok());  // the same rows: the same online weights
    expected += 0.25f * (as_params((*plain)->ActingBlob()) - expected);
  }
  const Eigen::VectorXf acting = as_params((*averaged)->ActingBlob());
  EXPECT_GT((acting - as_params((*plain)->ActingBlob())).norm(), 1e-4f);  // not the newest weights
  EXPECT_LT((acting - expected).norm(), 1e-4f * (1.0f + expected.norm()));
  // a checkpoint round trip keeps the average; a state without it starts it at the online weights
  rl::AlgorithmState st = (*averaged)->ExportState();
  auto resumed = PolicyTrainer::Create(*spec, g, 4);
  ASSERT_TRUE((*resumed)->ImportState(st).ok());
  EXPECT_EQ((*resumed)->ActingBlob(), (*averaged)->ActingBlob());
  auto from_plain = PolicyTrainer::Create(*spec, g, 4);
  ASSERT_TRUE((*from_plain)->ImportState((*plain)->ExportState()).ok());
  EXPECT_EQ((*from_plain)->ActingBlob(), (*plain)->ActingBlob());
  // loading kept acting weights sets the average too
  ASSERT_TRUE((*averaged)->LoadActing((*plain)->ActingBlob()).ok());
  EXPECT_EQ((*averaged)->ActingBlob(), (*plain)->ActingBlob());
}

// learner.task_pair_hidden: the task's network is a pair network over the blocks; its weights fit
// any number of blocks, its spec survives JSON, and actors load what the trainer learns
TEST(LevelBuilder, TaskPairNetworkOverTheBlocks) {
  Breakout b;
  LearnerOptions o;
  o.task.pair_hidden = {32, 32};
  auto paddle = BuildSkillSpec(b.spec, b.paddle, 1, nullptr, o.primitive);
  auto ball = BuildSkillSpec(b.spec, b.ball, 2, &*paddle, o.skill);
  for (const bool vanilla : {false, true}) {
    auto task = vanilla ? BuildPrimitiveTaskSpec(b.spec, o.task) : BuildTaskSpec(b.spec, *ball, o.task);
    ASSERT_TRUE(task.ok()) << task.status().message();
    EXPECT_EQ(task->pair_factor, "Block");
    EXPECT_EQ(task->pair.offset, 10);  // after the paddle and the ball
    EXPECT_EQ(task->pair.instances, 100);
    EXPECT_EQ(task->pair.instance_dim, 5);
    EXPECT_EQ(task->pair.presence, 4);  // attr
    EXPECT_EQ(task->hidden, (std::vector<int>{32, 32}));
    EXPECT_EQ(task->num_actions, 4);  // four angles, or four primitive actions
    auto back = policy::LevelSpecFromJson(policy::ToJson(*task));
    ASSERT_TRUE(back.ok()) << back.status().message();
    EXPECT_EQ(policy::ToJson(*back), policy::ToJson(*task));
    auto trainer = PolicyTrainer::Create(*task, o.task, 3);
    ASSERT_TRUE(trainer.ok()) << trainer.status().message();
    auto net = policy::PolicyNet::Create(*task);
    ASSERT_TRUE(net.ok()) << net.status().message();
    ASSERT_TRUE(net->Load((*trainer)->ActingBlob(), "acting").ok());
    // a board of 10 blocks (neg): the same weights fit a pair network over 10
    auto neg = envs::MakeEnv("breakout-neg");
    auto small =
        vanilla ? BuildPrimitiveTaskSpec((*neg)->spec(), o.task) : BuildTaskSpec((*neg)->spec(), *ball, o.task);
    ASSERT_TRUE(small.ok()) << small.status().message();
    EXPECT_EQ(small->pair.instances, 10);
    auto small_net = policy::PolicyNet::Create(*small);
    EXPECT_TRUE(small_net->Load((*trainer)->ActingBlob(), "acting").ok());
  }
}

// pushing's gripper and block skills (sac) and the options of a task over them with a pair
// network over the obstacle regions
class PushingTask : public ::testing::Test {
 protected:
  void SetUp() override {
    auto made = envs::MakeEnv("pushing");
    ASSERT_TRUE(made.ok()) << made.status().message();
    env_ = std::move(*made);
    o.skill.algorithm = o.task.algorithm = "sac";
    o.skill.child_offsets.clear();
    o.task.pair_hidden = {16, 16};
    auto g = BuildSkillSpec(
        spec(), Link("Action", "Gripper", {1, 1, 1}, "continuous", {-0.2f, 0.2f, -0.2f, 0.2f, 0.02f, 0.2f}, 0.9), 1,
        nullptr, o.primitive);
    ASSERT_TRUE(g.ok()) << g.status().message();
    auto b = BuildSkillSpec(spec(), Link("Gripper", "Block", {1, 1, 0}, "continuous", {-0.2f, 0.2f, -0.2f, 0.2f}, 0.01),
                            2, &*g, o.skill);
    ASSERT_TRUE(b.ok()) << b.status().message();
    block = *b;
  }
  const envs::EnvSpec& spec() const { return env_->spec(); }

  LearnerOptions o;
  policy::LevelSpec block;

 private:
  std::unique_ptr<envs::Env> env_;
};

// pushing's task (sac over relative block goals) and its vanilla baseline (sac on primitive
// actions) with learner.task_pair_hidden: a pair network over the 15 obstacle regions, every
// region present (the class has no attr), with and without dense layers after the pool
// (learner.task_pair_head); actors load what the trainer learns, and the state round-trips
TEST_F(PushingTask, PairNetworkOverTheObstacles) {
  const envs::EnvSpec& spec = this->spec();
  for (const bool vanilla : {false, true, false}) {
    if (vanilla) o.task.pair_head = {24};  // from the vanilla pass on, with a head
    auto task = vanilla ? BuildPrimitiveTaskSpec(spec, o.task) : BuildTaskSpec(spec, block, o.task);
    ASSERT_TRUE(task.ok()) << task.status().message();
    auto parsed = policy::ParseLevelSpec(policy::ToJson(*task).dump());
    ASSERT_TRUE(parsed.ok()) << parsed.status().message();
    EXPECT_EQ(parsed->pair.head, task->pair.head);
    EXPECT_EQ(task->pair.head, o.task.pair_head.empty() ? std::vector<int>{} : std::vector<int>{24});
    EXPECT_EQ(task->algorithm, "sac");
    EXPECT_EQ(task->pair_factor, "Obstacle");
    EXPECT_EQ(task->pair.instances, 15);
    EXPECT_EQ(task->pair.instance_dim, 3);
    EXPECT_EQ(task->pair.presence, -1);
    EXPECT_EQ(task->action_dim, vanilla ? 3 : 2);  // primitive displacements, or block x, y goals
    auto trainer = PolicyTrainer::Create(*task, o.task, 5);
    ASSERT_TRUE(trainer.ok()) << trainer.status().message();
    auto net = policy::PolicyNet::Create(*parsed);
    ASSERT_TRUE(net.ok()) << net.status().message();
    ASSERT_TRUE(net->Load((*trainer)->ActingBlob(), "acting").ok());
    EXPECT_EQ(nn::ToBlob(net->params()), (*trainer)->ActingBlob());
    auto other = PolicyTrainer::Create(*task, o.task, 6);
    ASSERT_TRUE((*other)->ImportState((*trainer)->ExportState()).ok());
    EXPECT_EQ((*other)->ActingBlob(), (*trainer)->ActingBlob());
    // the greedy action moves when one obstacle region moves (the pool sees every region)
    std::vector<float> obs(size_t(task->obs_dim()), 0.1f), a(size_t(task->action_dim)), a2 = a;
    std::mt19937_64 rng(1);
    net->Act(obs.data(), 0.0f, &rng, a.data());
    obs[size_t(task->pair.offset + 3 * 7)] = 3.0f;
    net->Act(obs.data(), 0.0f, &rng, a2.data());
    EXPECT_NE(a, a2);
  }
}

// learner.task_relative all: the pushing task over the block skill sees every pair of single
// factors (Block-Target among them) and each obstacle region's point sees every single factor's
// position minus the region's, in the region's units; the spec's JSON carries them
TEST_F(PushingTask, SeesEveryRelativePositionWithTaskRelativeAll) {
  const envs::EnvSpec& spec = this->spec();
  auto link = BuildTaskSpec(spec, block, o.task);
  ASSERT_TRUE(link.ok()) << link.status().message();
  EXPECT_EQ(link->relative.size(), 3u);  // Gripper-Block x, y, z
  EXPECT_TRUE(link->pair.relative.empty());
  o.task.relative = "all";
  for (const bool vanilla : {false, true}) {
    auto task = vanilla ? BuildPrimitiveTaskSpec(spec, o.task) : BuildTaskSpec(spec, block, o.task);
    ASSERT_TRUE(task.ok()) << task.status().message();
    EXPECT_EQ(task->relative.size(), 9u);       // Gripper-Block, Gripper-Target, Block-Target
    ASSERT_EQ(task->pair.relative.size(), 9u);  // Gripper, Block, Target minus each region
    const std::vector<std::string> names = NetworkInputNames(*task, spec);
    EXPECT_NE(std::find(names.begin(), names.end(), "Block.x-Target.x"), names.end());
    auto bx = std::find(names.begin(), names.end(), "Block.x-Obstacle.x");
    ASSERT_NE(bx, names.end());
    // the feature of region 7 for a block at x = 0.1 and the region at x = 0.04: (0.1 - 0.04) / 0.15
    std::vector<float> state(size_t(spec.state_dim()), 0.0f), features(task->obs_index.size());
    state[size_t(spec.factor_offset(spec.factor_index("Block")))] = 0.1f;
    state[size_t(spec.factor_offset(spec.factor_index("Obstacle")) + 3 * 7)] = 0.04f;
    std::vector<float> obs(size_t(task->obs_dim()));
    policy::GatherFeatures(*task, state.data(), features.data());
    policy::BuildObservation(*task, features.data(), nullptr, obs.data());
    const int first = names.end() - names.begin() - 9;  // the relative features end a point
    const nn::RelativeFeature& r = task->pair.relative[size_t(bx - names.begin() - first)];
    const float value = r.scale * obs[size_t(r.source)] + r.shift - obs[size_t(task->pair.offset + 3 * 7 + r.instance)];
    EXPECT_NEAR(value, (0.1f - 0.04f) / 0.15f, 1e-5f);
    auto back = policy::ParseLevelSpec(policy::ToJson(*task).dump());
    ASSERT_TRUE(back.ok()) << back.status().message();
    EXPECT_EQ(policy::ToJson(*back), policy::ToJson(*task));
    ASSERT_EQ(back->pair.relative.size(), 9u);
    EXPECT_EQ(back->pair.relative[4].shift, task->pair.relative[4].shift);
    auto trainer = PolicyTrainer::Create(*task, o.task, 5);
    ASSERT_TRUE(trainer.ok()) << trainer.status().message();
    auto net = policy::PolicyNet::Create(*back);
    ASSERT_TRUE(net.ok() && net->Load((*trainer)->ActingBlob(), "acting").ok());
  }
}

// fine-tuning a vanilla task trained on base Breakout in breakout-prox, which adds a Target
// factor: the re-laid network keeps every trained input weight, gives the target's inputs zero
// weights and zero optimiser moments, and so computes exactly what the trained one did
TEST(InputRemap, ABreakoutTaskNetworkReLaidForProxComputesTheSameValues) {
  Breakout b;
  auto prox_env = envs::MakeEnv("breakout-prox");
  ASSERT_TRUE(prox_env.ok());
  const envs::EnvSpec& prox = (*prox_env)->spec();
  LearnerOptions o;
  o.task.pair_hidden = {16, 16};
  auto from = BuildPrimitiveTaskSpec(b.spec, o.task);
  auto to = BuildPrimitiveTaskSpec(prox, o.task);
  ASSERT_TRUE(from.ok() && to.ok());
  const std::vector<std::string> names = NetworkInputNames(*to, prox);
  auto input_of = MatchNetworkInputs(*from, b.spec, *to, prox);
  ASSERT_TRUE(input_of.ok()) << input_of.status().message();
  ASSERT_EQ(input_of->size(), names.size());
  const std::vector<std::string> old_names = NetworkInputNames(*from, b.spec);
  int fresh_inputs = 0;
  for (size_t i = 0; i < names.size(); ++i) {
    const bool target = names[i].find("Target") != std::string::npos;
    fresh_inputs += target;
    if (target) {
      EXPECT_EQ((*input_of)[i], -1) << names[i];
    } else {
      ASSERT_GE((*input_of)[i], 0) << names[i];
      EXPECT_EQ(old_names[size_t((*input_of)[i])], names[i]);
    }
  }
  EXPECT_EQ(fresh_inputs, 5 + 4) << "Target's features, and the paddle's and ball's y, x relative to it";
  EXPECT_NE(std::find(names.begin(), names.end(), "Block.x"), names.end()) << "a point's instance features";

  auto trained = PolicyTrainer::Create(*from, o.task, 3);
  auto fresh = PolicyTrainer::Create(*to, o.task, 4);
  ASSERT_TRUE(trained.ok() && fresh.ok());
  rl::AlgorithmState st = (*trained)->ExportState();
  ASSERT_FALSE((*fresh)->ImportState(st).ok()) << "the shapes differ";
  std::mt19937_64 rng(9);
  std::normal_distribution<float> normal;
  for (auto& set : st.sets)  // optimiser moments as if trained: every value non-zero
    if (set.blocks().size() == 1)
      for (Eigen::Index i = 0; i < set.values.size(); ++i) set.values[i] = 1.0f + std::abs(normal(rng));
  auto relaid = RelayInputs(st, (*fresh)->ExportState(), *input_of);
  ASSERT_TRUE(relaid.ok()) << relaid.status().message();
  ASSERT_TRUE((*fresh)->ImportState(*relaid).ok());
  // the first layer's columns: trained ones moved, the target's zero, in weights and moments
  for (const auto& set : relaid->sets) {
    const Eigen::Map<const Eigen::MatrixXf> w(set.values.data(), 16, Eigen::Index(names.size()));
    for (size_t c = 0; c < names.size(); ++c)
      if ((*input_of)[c] < 0) {
        EXPECT_EQ(w.col(Eigen::Index(c)).norm(), 0.0f) << set.blocks().front().name << names[c];
      }
  }
  for (size_t s = 0; s < st.sets.size(); ++s)
    if (st.sets[s].blocks().size() == 1) {
      EXPECT_EQ((relaid->sets[s].values.array() == 0).count(), 16 * fresh_inputs) << "moments of new inputs only";
    }

  // the same board seen by both: prox's state, and base Breakout's with its first 60 blocks
  // those of prox and the other 40 broken
  auto old_net = policy::PolicyNet::Create(*from);
  auto new_net = policy::PolicyNet::Create(*to);
  ASSERT_TRUE(old_net->Load((*trained)->ActingBlob(), "trained").ok());
  ASSERT_TRUE(new_net->Load((*fresh)->ActingBlob(), "relaid").ok());
  std::vector<float> ps(size_t(prox.state_dim())), bs(size_t(b.spec.state_dim()), 0.0f);
  (*prox_env)->Reset(5, ps);
  for (const char* f : {"Paddle", "Ball"}) {
    const int po = prox.factor_offset(prox.factor_index(f)), bo = b.spec.factor_offset(b.spec.factor_index(f));
    std::copy_n(ps.begin() + po, 5, bs.begin() + bo);
  }
  std::copy_n(ps.begin() + prox.factor_offset(prox.factor_index("Block")), 60 * 5,
              bs.begin() + b.spec.factor_offset(b.spec.factor_index("Block")));
  auto q = [&](policy::PolicyNet& net, const std::vector<float>& state) {
    const policy::LevelSpec& spec = net.spec();
    std::vector<float> features(spec.obs_index.size()), obs(size_t(spec.obs_dim()));
    policy::GatherFeatures(spec, state.data(), features.data());
    policy::BuildObservation(spec, features.data(), nullptr, obs.data());
    float a = 0;
    net.Act(obs.data(), 0.0f, &rng, &a);
    return Eigen::VectorXf(net.last_q());
  };
  const Eigen::VectorXf before = q(*old_net, bs);
  EXPECT_LT((q(*new_net, ps) - before).norm(), 1e-5f * (1.0f + before.norm()));
  const int target = prox.factor_offset(prox.factor_index("Target"));
  ps[size_t(target) + 1] += 20.0f;  // the target moves: no input weight reads it yet
  EXPECT_LT((q(*new_net, ps) - before).norm(), 1e-5f * (1.0f + before.norm()));

  // the other way, prox's network onto base Breakout, would drop the target's inputs: refused
  auto back = MatchNetworkInputs(*to, prox, *from, b.spec);
  ASSERT_FALSE(back.ok());
  EXPECT_NE(back.status().message().find(
                "input Target.y of the network trained on breakout-prox is not observed in breakout"),
            std::string::npos)
      << back.status().message();
}

}  // namespace
}  // namespace coins
