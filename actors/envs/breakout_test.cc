// Breakout rules checked on real trajectories: paddle moves, the four bounce angles, wall
// reflections, block hits, drops and lives, ground-truth labels, determinism, bad actions.
#include "actors/envs/breakout.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace coins::envs {
namespace {

using B = BreakoutEnv;

struct Runner {
  explicit Runner(BreakoutVariant v, uint64_t seed = 1) : env(v), state(env.spec().state_dim()) {
    env.Reset(seed, state);
  }
  StepResult Step(int a) {
    const float act = static_cast<float>(a);
    StepResult r;
    Status s = env.Step({&act, 1}, state, &r);
    EXPECT_TRUE(s.ok()) << s.message();
    return r;
  }
  float At(const std::string& factor, int instance, int feature) const {
    const auto& spec = env.spec();
    const int f = spec.factor_index(factor);
    return state[spec.factor_offset(f) + instance * spec.factors[f].features + feature];
  }
  BreakoutEnv env;
  std::vector<float> state;
};

TEST(BreakoutSpec, FactorsAndSizes) {
  BreakoutEnv env(BreakoutVariant::kBase);
  const EnvSpec& s = env.spec();
  ASSERT_EQ(s.factors.size(), 6u);
  EXPECT_EQ(s.factors[3].name, "Block");
  EXPECT_EQ(s.factors[3].instances, 100);
  EXPECT_EQ(s.state_dim(), 3 * 5 + 100 * 5 + 2);
  EXPECT_EQ(s.factor_offset(3), 15);
  EXPECT_EQ(s.action.n, 4);
  EXPECT_EQ(s.interactions[1].label(), "Paddle->Ball");
  EXPECT_EQ(BreakoutEnv(BreakoutVariant::kProx).spec().factor_index("Target"), 4);
}

TEST(Breakout, ResetServesBallInRange) {
  for (uint64_t seed = 0; seed < 200; ++seed) {
    Runner r(BreakoutVariant::kBase, seed);
    EXPECT_GE(r.env.ball_y(), 43);
    EXPECT_LE(r.env.ball_y(), 45);
    EXPECT_GE(r.env.ball_x(), 14);
    EXPECT_LE(r.env.ball_x(), 69);
    EXPECT_EQ(r.env.ball_vy(), 1);
    EXPECT_EQ(std::abs(r.env.ball_vx()), 1);
    EXPECT_EQ(r.At("Ball", 0, 0), r.env.ball_y() + 1.0f);
    EXPECT_EQ(r.At("Paddle", 0, 1), 42 + 3.5f);
  }
}

TEST(Breakout, PaddleMovesTwoAndClamps) {
  Runner r(BreakoutVariant::kBase);
  r.env.SetBallForTest(40, 40, 1, 1);
  StepResult s = r.Step(2);
  EXPECT_EQ(r.env.paddle_x(), 40);
  EXPECT_TRUE(s.interactions & B::kActionPaddle);
  s = r.Step(3);
  EXPECT_EQ(r.env.paddle_x(), 42);
  s = r.Step(1);
  EXPECT_EQ(r.env.paddle_x(), 42);
  EXPECT_FALSE(s.interactions & B::kActionPaddle);
  EXPECT_EQ(r.At("Action", 0, 4), 1.0f);
  r.env.SetPaddleForTest(5);
  s = r.Step(2);
  EXPECT_EQ(r.env.paddle_x(), 4);
  s = r.Step(2);
  EXPECT_EQ(r.env.paddle_x(), 4);
  EXPECT_FALSE(s.interactions & B::kActionPaddle);  // clamped: it did not move
  EXPECT_EQ(r.At("Paddle", 0, 2), 0.0f);
}

TEST(Breakout, FourBounceAnglesFromPaddleOffsets) {
  const int want_vy[] = {-1, -1, -2, -2, -2, -2, -1, -1};
  const int want_vx[] = {-1, -1, -1, -1, 1, 1, 1, 1};
  for (int rel = -1; rel <= 6; ++rel) {
    for (int vx : {-1, 1}) {
      Runner r(BreakoutVariant::kBase);
      r.env.SetPaddleForTest(40);
      // next position: y 70 touches the paddle top (71), x = 40 + rel
      r.env.SetBallForTest(69, 40 + rel - vx, 1, vx);
      StepResult s = r.Step(0);
      EXPECT_TRUE(s.interactions & B::kPaddleBall) << rel;
      EXPECT_EQ(r.env.ball_vy(), want_vy[rel + 1]) << rel;
      EXPECT_EQ(r.env.ball_vx(), want_vx[rel + 1]) << rel;
      EXPECT_EQ(r.env.ball_y(), 69 + want_vy[rel + 1]);
      EXPECT_EQ(r.At("Ball", 0, 2), want_vy[rel + 1]);
      EXPECT_EQ(s.reward, 0.0f);
    }
  }
  // one pixel past either end misses the paddle
  Runner r(BreakoutVariant::kBase);
  r.env.SetPaddleForTest(40);
  r.env.SetBallForTest(69, 46, 1, 1);  // next x 47 = paddle_x + 7
  StepResult s = r.Step(0);
  EXPECT_FALSE(s.interactions & B::kPaddleBall);
  EXPECT_EQ(r.env.ball_vy(), 1);
}

TEST(Breakout, WallReflections) {
  Runner r(BreakoutVariant::kBase);
  r.env.SetBallForTest(50, 12, 1, -1);  // left wall ends at x=12
  r.Step(0);
  EXPECT_EQ(r.env.ball_vx(), 1);
  EXPECT_EQ(r.env.ball_x(), 13);
  r.env.SetBallForTest(50, 70, 1, 1);  // right wall starts at x=72
  r.Step(0);
  EXPECT_EQ(r.env.ball_vx(), -1);
  EXPECT_EQ(r.env.ball_x(), 69);
  r.env.SetBallForTest(9, 40, -2, 1);  // top wall ends at y=8
  r.Step(0);
  EXPECT_EQ(r.env.ball_vy(), 2);
  EXPECT_EQ(r.env.ball_y(), 11);
  r.env.SetBallForTest(9, 40, -1, 1);  // next y 8: no contact yet
  r.Step(0);
  EXPECT_EQ(r.env.ball_vy(), -1);
  EXPECT_EQ(r.env.ball_y(), 8);
}

TEST(Breakout, BlockHitRemovesBlockAndRewards) {
  Runner r(BreakoutVariant::kBase);
  // bottom row (i=4) at y=30, block j=1 at x=15..17
  r.env.SetBallForTest(32, 15, -1, 1);
  StepResult s = r.Step(0);
  EXPECT_TRUE(s.interactions & B::kBallBlock);
  EXPECT_EQ(s.reward, 1.0f);
  EXPECT_EQ(r.env.blocks()[81].attr, 0);
  EXPECT_EQ(r.At("Block", 81, 4), 0.0f);
  EXPECT_EQ(r.At("Block", 81, 0), 31.0f);
  EXPECT_EQ(r.At("Block", 81, 1), 16.5f);
  EXPECT_EQ(r.At("Reward", 0, 0), 1.0f);
  EXPECT_EQ(r.env.ball_vy(), 1);
  EXPECT_EQ(r.env.ball_y(), 33);
  // the same place again: the block is gone, the ball passes and hits the row above
  r.env.SetBallForTest(32, 15, -1, 1);
  s = r.Step(0);
  EXPECT_FALSE(s.interactions & B::kBallBlock);
  EXPECT_EQ(r.env.ball_y(), 31);
  s = r.Step(0);  // next y 30 x 17: blocks 61 (row 3 spans 28..29)? no, row 4 j=1 gone, j=2 at x=18
  int removed = 0;
  for (const auto& b : r.env.blocks()) removed += b.attr == 0;
  EXPECT_EQ(removed, 1 + (s.interactions & B::kBallBlock ? 1 : 0));
}

TEST(Breakout, SideHitFlipsVx) {
  Runner r(BreakoutVariant::kBase);
  for (int j = 0; j < 20; ++j) r.env.SetBlockAttrForTest(80 + j, j == 10 ? 1 : 0);
  // block 90 at y=30, x=42..44; ball level with it at x=40 moving right
  r.env.SetBallForTest(30, 40, 1, 1);
  StepResult s = r.Step(0);
  EXPECT_TRUE(s.interactions & B::kBallBlock);
  EXPECT_EQ(r.env.ball_vx(), -1);
  EXPECT_EQ(r.env.ball_vy(), 1);
  EXPECT_EQ(r.env.blocks()[90].attr, 0);
}

TEST(Breakout, DropPenaltyEndsEpisodeAndBoardPersistsForFiveDrops) {
  Runner r(BreakoutVariant::kBase);
  r.env.SetBallForTest(32, 15, -1, 1);
  r.Step(0);  // break block 81
  for (int drop = 1; drop <= 5; ++drop) {
    r.env.SetPaddleForTest(4);
    r.env.SetBallForTest(77, 60, 2, 1);  // next y 79: bottom at 81 > 80
    StepResult s = r.Step(0);
    EXPECT_TRUE(s.done);
    EXPECT_FALSE(s.truncated);
    EXPECT_EQ(s.reward, -10.0f);
    EXPECT_EQ(r.At("Done", 0, 0), 1.0f);
    EXPECT_EQ(r.env.drops(), drop);
    const float a = 0;
    StepResult again;
    Status st = r.env.Step({&a, 1}, r.state, &again);
    EXPECT_FALSE(st.ok());
    EXPECT_NE(st.message().find("episode is over"), std::string::npos);
    r.env.ResetNext(r.state);
    EXPECT_EQ(r.env.ball_vy(), 1);
    // lives: the broken block stays broken until the fifth drop rebuilds the board
    EXPECT_EQ(r.env.blocks()[81].attr, drop < 5 ? 0 : 1) << drop;
  }
  EXPECT_EQ(r.env.drops(), 0);
}

TEST(Breakout, ClearingTheBoardEndsTheEpisode) {
  Runner r(BreakoutVariant::kBase);
  for (int i = 0; i < 100; ++i)
    if (i != 81) r.env.SetBlockAttrForTest(i, 0);
  r.env.SetBallForTest(32, 15, -1, 1);
  StepResult s = r.Step(0);
  EXPECT_EQ(s.reward, 1.0f);
  EXPECT_TRUE(s.done);
  r.env.ResetNext(r.state);
  for (const auto& b : r.env.blocks()) EXPECT_EQ(b.attr, 1);
}

TEST(Breakout, ReservesAfterThousandStepsWithoutTouch) {
  Runner r(BreakoutVariant::kBase);
  // a ball bouncing between the side walls above the blocks never drops nor meets the paddle
  r.env.SetBallForTest(10, 40, 1, 1);
  for (int i = 0; i < 1000; ++i) {
    r.env.SetBallForTest(10, r.env.ball_x(), 1, r.env.ball_vx());
    r.Step(0);
    if (i < 999) {
      EXPECT_EQ(r.env.ball_y(), 11);
    }
  }
  EXPECT_GE(r.env.ball_y(), 43);  // re-served
  EXPECT_LE(r.env.ball_y(), 45);
}

// random play: labels agree with what changed in the state, rewards with removed blocks
TEST(Breakout, RandomTrajectoryLabelsMatchWhatHappened) {
  Runner r(BreakoutVariant::kBase, 7);
  Rng rng(3);
  std::vector<float> prev = r.state;
  int bounces = 0, hits = 0, drops = 0;
  const int off = r.env.spec().factor_offset(3);
  for (int t = 0; t < 60000; ++t) {
    const int a = rng.UniformInt(0, 3);
    StepResult s = r.Step(a);
    // action->paddle iff the paddle x changed
    EXPECT_EQ(bool(s.interactions & B::kActionPaddle), prev[6] != r.state[6]);
    // velocities stay in the allowed sets
    EXPECT_TRUE(r.state[12] == -2 || r.state[12] == -1 || r.state[12] == 1 || r.state[12] == 2);
    EXPECT_TRUE(std::abs(r.state[13]) == 1.0f);
    int removed = 0;
    for (int i = 0; i < 100; ++i) removed += prev[off + 5 * i + 4] == 1.0f && r.state[off + 5 * i + 4] == 0.0f;
    if (s.interactions & B::kPaddleBall) {
      ++bounces;
      EXPECT_LT(r.state[12], 0.0f);
      EXPECT_GT(prev[12], 0.0f);
      EXPECT_NEAR(prev[10], 71.0f, 2.5f);  // ball centre near the paddle's top
    }
    if (s.done) {
      ++drops;
      EXPECT_EQ(s.reward, -10.0f + removed);
      r.env.ResetNext(r.state);
    } else {
      hits += removed;
      EXPECT_EQ(bool(s.interactions & B::kBallBlock), removed == 1);
      EXPECT_LE(removed, 1);
      EXPECT_EQ(s.reward, static_cast<float>(removed));
    }
    prev = r.state;
  }
  EXPECT_GT(bounces, 10);
  EXPECT_GT(hits, 10);
  EXPECT_GT(drops, 10);
}

TEST(Breakout, DeterministicAndSaveRestore) {
  for (BreakoutVariant v : {BreakoutVariant::kBase, BreakoutVariant::kProx, BreakoutVariant::kHard}) {
    Runner a(v, 42), b(v, 42);
    Rng ra(5), rb(5);
    std::vector<uint8_t> saved;
    std::vector<std::vector<float>> tail;
    for (int t = 0; t < 6000; ++t) {
      int act = ra.UniformInt(0, 3);
      StepResult sa = a.Step(act);
      StepResult sb = b.Step(rb.UniformInt(0, 3));
      ASSERT_EQ(a.state, b.state) << t;
      ASSERT_EQ(sa.reward, sb.reward);
      if (sa.done) {
        a.env.ResetNext(a.state);
        b.env.ResetNext(b.state);
      }
      if (t == 3000) saved = a.env.SaveState();
      if (t > 3000) tail.push_back(a.state);
    }
    // restore into a fresh env and replay the same actions
    Runner c(v, 999);
    ASSERT_TRUE(c.env.RestoreState(saved).ok());
    Rng rc(5);
    for (int t = 0; t <= 3000; ++t) rc.UniformInt(0, 3);
    for (size_t k = 0; k < tail.size(); ++k) {
      StepResult s = c.Step(rc.UniformInt(0, 3));
      if (s.done) c.env.ResetNext(c.state);
      ASSERT_EQ(c.state, tail[k]) << k;
    }
  }
}

TEST(Breakout, BadActionsAreErrorsAndLeaveEnvUnchanged) {
  Runner r(BreakoutVariant::kBase);
  for (int t = 0; t < 10; ++t) r.Step(3);
  const std::vector<uint8_t> before = r.env.SaveState();
  const std::vector<float> state_before = r.state;
  const float bad[] = {4.0f, -1.0f, 1.5f, std::numeric_limits<float>::quiet_NaN(),
                       std::numeric_limits<float>::infinity()};
  for (float a : bad) {
    StepResult s;
    Status st = r.env.Step({&a, 1}, r.state, &s);
    EXPECT_FALSE(st.ok()) << a;
    EXPECT_NE(st.message().find("action"), std::string::npos) << st.message();
    EXPECT_EQ(r.env.SaveState(), before);
    EXPECT_EQ(r.state, state_before);
  }
  const float two[] = {1.0f, 2.0f};
  StepResult s;
  EXPECT_FALSE(r.env.Step(two, r.state, &s).ok());
  EXPECT_EQ(r.env.SaveState(), before);
  // a corrupt saved state is refused and changes nothing
  std::vector<uint8_t> cut(before.begin(), before.end() - 3);
  EXPECT_FALSE(r.env.RestoreState(cut).ok());
  EXPECT_FALSE(BreakoutEnv(BreakoutVariant::kNeg).RestoreState(before).ok());
  EXPECT_EQ(r.env.SaveState(), before);
}

}  // namespace
}  // namespace coins::envs
