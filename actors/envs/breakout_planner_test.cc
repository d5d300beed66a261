// The angle planner on real Breakout trajectories: the ideal controller gives the requested
// angle, leaves the env untouched when the angle cannot be had, search beats random angles,
// runs repeat, and bad options are refused by name.
#include "actors/envs/breakout_planner.h"

#include <gtest/gtest.h>

namespace coins::envs {
namespace {

// the ball's velocity right after a bounce at each angle (the paddle bounce table)
constexpr int kVy[4] = {-1, -2, -2, -1};
constexpr int kVx[4] = {-1, -1, 1, 1};

TEST(AnglePlanner, ControllerGivesEveryRequestedAngle) {
  for (uint64_t seed : {1u, 2u, 3u}) {
    BreakoutEnv env(BreakoutVariant::kSingle), scratch(BreakoutVariant::kSingle);
    std::vector<float> state(env.spec().state_dim());
    env.Reset(seed, state);
    const std::vector<uint8_t> start = env.SaveState();
    for (int a = 0; a < 4; ++a) {
      ASSERT_TRUE(env.RestoreState(start).ok());
      const BounceOutcome o = BounceAt(env, scratch, a, 5000);
      ASSERT_TRUE(o.reachable) << "seed " << seed << " angle " << a;
      ASSERT_TRUE(o.bounced);
      EXPECT_EQ(env.ball_vy(), kVy[a]) << "seed " << seed << " angle " << a;
      EXPECT_EQ(env.ball_vx(), kVx[a]) << "seed " << seed << " angle " << a;
      EXPECT_FLOAT_EQ(o.reward, -1.0f);  // single charges the bounce
      EXPECT_GT(o.steps, 10);
      EXPECT_EQ(env.drops(), 0);
    }
  }
}

TEST(AnglePlanner, UnreachableAngleLeavesTheEnvAsItWas) {
  BreakoutEnv env(BreakoutVariant::kSingle), scratch(BreakoutVariant::kSingle);
  std::vector<float> state(env.spec().state_dim());
  env.Reset(1, state);
  // the ball one step above the paddle's row at the far left, the paddle at the far right
  env.SetBallForTest(BreakoutEnv::kPaddleY - 2, 14, 1, 1);
  env.SetPaddleForTest(BreakoutEnv::kPaddleMaxX);
  const std::vector<uint8_t> before = env.SaveState();
  for (int a = 0; a < 4; ++a) {
    const BounceOutcome o = BounceAt(env, scratch, a, 5000);
    EXPECT_FALSE(o.reachable) << "angle " << a;
    EXPECT_EQ(env.SaveState(), before) << "angle " << a;
  }
}

TEST(AnglePlanner, SearchBeatsRandomAnglesOnHard) {
  AnglePlanOptions o;
  o.env = "breakout-hard";
  o.episodes = 50;
  o.seed = 11;
  o.depth = 0;
  const Result<AnglePlanResult> random = PlanAngles(o);
  o.depth = 1;
  const Result<AnglePlanResult> search = PlanAngles(o);
  ASSERT_TRUE(random.ok() && search.ok());
  ASSERT_EQ(random->returns.size(), 50u);
  // hard: -1 a bounce, +1 for the target, at most 10 bounces; the controller never drops
  EXPECT_EQ(random->drops, 0);
  EXPECT_EQ(search->drops, 0);
  for (double r : search->returns) {
    EXPECT_GE(r, -10.0);
    EXPECT_LE(r, 1.0);
  }
  // one bounce of foresight finds the target in far fewer bounces than random angles
  EXPECT_LT(double(search->bounces), 0.6 * double(random->bounces));
  EXPECT_GT(search->mean(), random->mean() + 2.0);
  // the same options give the same episodes
  const Result<AnglePlanResult> again = PlanAngles(o);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->returns, search->returns);
}

TEST(AnglePlanner, RefusesBadOptionsByName) {
  AnglePlanOptions o;
  o.env = "pushing";
  Result<AnglePlanResult> r = PlanAngles(o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("'pushing' is not a Breakout env"), std::string::npos);
  o.env = "breakout-neg";
  o.depth = 5;
  r = PlanAngles(o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("depth"), std::string::npos);
  o.depth = 1;
  o.episodes = 0;
  r = PlanAngles(o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("episodes"), std::string::npos);
}

}  // namespace
}  // namespace coins::envs
