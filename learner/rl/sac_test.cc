// SAC + HER learns 2-D point-mass goal reaching (sparse reward -1 / 0, horizon 25), and DDPG
// learns a 1-D "move to the goal" control; both from fixed seeds in a few seconds.
#include <cstdio>

#include <gtest/gtest.h>

#include "learner/rl/ddpg.h"
#include "learner/rl/memory_replay.h"
#include "learner/rl/sac.h"

namespace coins::rl {
namespace {

constexpr int kHorizon = 25;
constexpr float kStep = 0.15f;
constexpr float kEps = 0.1f;

struct PointMass {
  float pos[2];
  float goal[2];
  void Reset(std::mt19937_64* rng) {
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (float& p : pos) p = u(*rng);
    for (float& g : goal) g = u(*rng);
  }
  void Step(std::span<const float> a) {
    for (int i = 0; i < 2; ++i) pos[i] = std::clamp(pos[i] + kStep * a[size_t(i)], -1.0f, 1.0f);
  }
  bool Reached() const { return GoalReached({pos, 2}, {goal, 2}, {}, kEps, GoalNorm::kLinf); }
};

template <typename Policy>
double EvalSuccess(Policy&& act, int episodes, uint64_t seed) {
  std::mt19937_64 rng(seed);
  int ok = 0;
  for (int e = 0; e < episodes; ++e) {
    PointMass env;
    env.Reset(&rng);
    for (int t = 0; t < kHorizon && !env.Reached(); ++t) {
      float in[4] = {env.pos[0], env.pos[1], env.goal[0], env.goal[1]}, a[2];
      act(std::span<const float>(in, 4), std::span<float>(a, 2));
      env.Step(a);
    }
    ok += env.Reached();
  }
  return double(ok) / episodes;
}

TEST(SacHer, PointMassReachesGoals) {
  SacOptions o;
  o.obs_dim = 4;
  o.action_dim = 2;
  o.hidden = {64, 64};
  o.actor_lr = o.critic_lr = o.alpha_lr = 1e-3f;
  o.tau = 0.01f;
  o.batch_size = 128;
  o.seed = 1;
  ASSERT_TRUE(o.Validate().ok());
  Sac sac(o);
  MemoryReplayOptions ro;
  ro.obs_dim = 2;
  ro.action_dim = 2;
  ro.goal_dim = 2;
  ro.goal_epsilon = kEps;
  ro.goal_norm = GoalNorm::kLinf;
  ro.her = HerStrategy::kFuture;
  ro.her_ratio = 0.8f;
  ro.gamma = 0.95f;
  ro.seed = 2;
  MemoryReplay replay(ro);
  std::mt19937_64 rng(3);
  PointMass env;
  env.Reset(&rng);
  int t = 0;
  for (int step = 0; step < 6000; ++step) {
    float in[4] = {env.pos[0], env.pos[1], env.goal[0], env.goal[1]}, a[2];
    sac.Act(std::span<const float>(in, 4), false, &rng, a);
    float obs[2] = {env.pos[0], env.pos[1]};
    env.Step(a);
    ++t;
    ReplayStep s;
    s.obs = {obs, 2};
    s.action = {a, 2};
    s.next_obs = {env.pos, 2};
    s.goal = {env.goal, 2};
    s.achieved = {env.pos, 2};
    s.segment_end = env.Reached() || t == kHorizon;
    replay.Add(s);
    if (s.segment_end) {
      env.Reset(&rng);
      t = 0;
    }
    if (step >= 300) {
      ASSERT_TRUE(sac.Train(&replay).ok());
    }
  }
  const double success =
      EvalSuccess([&](std::span<const float> in, std::span<float> a) { sac.Act(in, true, &rng, a); }, 100, 9);
  RecordProperty("success", std::to_string(success));
  std::printf("sac+her point-mass greedy success %.2f\n", success);
  EXPECT_GE(success, 0.9);
}

TEST(Ddpg, LearnsToMoveTowardTheGoal) {
  // one-step task: obs = (pos, goal) in [-1, 1]; reward -|pos + 0.5 a - goal|; terminal
  DdpgOptions o;
  o.obs_dim = 2;
  o.action_dim = 1;
  o.hidden = {32, 32};
  o.actor_lr = 1e-3f;
  o.critic_lr = 1e-3f;
  o.batch_size = 64;
  o.exploration_sigma = 0.3f;
  o.seed = 4;
  Ddpg ddpg(o);
  MemoryReplayOptions ro;
  ro.obs_dim = 2;
  ro.action_dim = 1;
  MemoryReplay replay(ro);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<float> u(-0.5f, 0.5f);
  auto reward = [](float pos, float goal, float a) { return -std::abs(pos + a - goal); };
  for (int step = 0; step < 3000; ++step) {
    float obs[2] = {u(rng), u(rng)}, a;
    ddpg.Act(obs, true, &rng, {&a, 1});
    ReplayStep s;
    s.obs = {obs, 2};
    s.next_obs = {obs, 2};
    s.action = {&a, 1};
    s.reward = reward(obs[0], obs[1], a);
    s.terminal = true;
    replay.Add(s);
    if (step >= 200) {
      ASSERT_TRUE(ddpg.Train(&replay).ok());
    }
  }
  double err = 0.0;
  for (int i = 0; i < 100; ++i) {
    float obs[2] = {u(rng), u(rng)}, a;
    ddpg.Act(obs, false, &rng, {&a, 1});
    err += -reward(obs[0], obs[1], a);
  }
  std::printf("ddpg mean error %.3f\n", err / 100);
  EXPECT_LT(err / 100, 0.1);  // random actions give about 0.5
}

}  // namespace
}  // namespace coins::rl
