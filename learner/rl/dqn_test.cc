// DQN learns a small discrete MDP: a chain of 8 states, the goal at the right end, reward -1
// per step and 0 on reaching it, horizon 20. Success = the greedy policy reaches the goal from
// every start state. Runs the paddle-skill configuration (C51 + dueling + double + n-step 2)
// and a plain Huber DQN.
#include <gtest/gtest.h>

#include "learner/rl/dqn.h"
#include "learner/rl/exploration.h"
#include "learner/rl/memory_replay.h"

namespace coins::rl {
namespace {

constexpr int kStates = 8;
constexpr int kHorizon = 20;

std::vector<float> OneHot(int s) {
  std::vector<float> v(kStates, 0.0f);
  v[size_t(s)] = 1.0f;
  return v;
}
// actions: 0 left, 1 right, 2 and 3 stay
int Move(int s, int a) { return std::clamp(s + (a == 0 ? -1 : a == 1 ? 1 : 0), 0, kStates - 1); }

double GreedySuccess(Dqn* dqn) {
  int ok = 0;
  std::mt19937_64 rng(0);
  for (int start = 0; start < kStates - 1; ++start) {
    int s = start;
    for (int t = 0; t < kHorizon && s != kStates - 1; ++t) s = Move(s, dqn->Act(OneHot(s), 0.0f, &rng));
    ok += s == kStates - 1;
  }
  return double(ok) / (kStates - 1);
}

class DqnChain : public ::testing::TestWithParam<bool> {};

TEST_P(DqnChain, ReachesTheGoalFromEveryState) {
  const bool rainbow = GetParam();
  DqnOptions o;
  o.obs_dim = kStates;
  o.num_actions = 4;
  o.hidden = {32, 32};
  o.distributional = rainbow;
  o.dueling = rainbow;
  o.double_q = rainbow;
  o.target_update_period = 100;
  o.lr = 1e-3f;
  o.batch_size = 32;
  o.seed = 3;
  ASSERT_TRUE(o.Validate().ok());
  Dqn dqn(o);
  MemoryReplayOptions ro;
  ro.obs_dim = kStates;
  ro.n_step = rainbow ? 2 : 1;
  ro.seed = 4;
  MemoryReplay replay(ro);
  LinearSchedule eps{1.0f, 0.05f, 2000};
  std::mt19937_64 rng(5);
  int s = 0, t = 0;
  for (int step = 0; step < 4000; ++step) {
    const int a = dqn.Act(OneHot(s), eps.Value(step), &rng);
    const int next = Move(s, a);
    const bool goal = next == kStates - 1;
    ++t;
    std::vector<float> obs = OneHot(s), next_obs = OneHot(next);
    float act = float(a);
    ReplayStep rs;
    rs.obs = obs;
    rs.next_obs = next_obs;
    rs.action = {&act, 1};
    rs.reward = goal ? 0.0f : -1.0f;
    rs.terminal = goal;
    rs.segment_end = goal || t == kHorizon;
    replay.Add(rs);
    s = next;
    if (rs.segment_end) {
      s = std::uniform_int_distribution<int>(0, kStates - 2)(rng);
      t = 0;
    }
    if (step >= 200) {
      ASSERT_TRUE(dqn.Train(&replay).ok());
    }
  }
  EXPECT_GE(GreedySuccess(&dqn), 1.0);
  // the value of the state next to the goal is about -1 / 0 (one step then success)
  Eigen::MatrixXf q;
  dqn.QValues(Eigen::Map<const Eigen::MatrixXf>(OneHot(kStates - 2).data(), kStates, 1), &q);
  EXPECT_NEAR(q(1, 0), 0.0f, 0.5f);
  EXPECT_LT(q(0, 0), -1.0f);
}

INSTANTIATE_TEST_SUITE_P(Variants, DqnChain, ::testing::Values(true, false));

}  // namespace
}  // namespace coins::rl
