// The six Breakout transfer variants: layouts and reward / episode rules, on real steps.
#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "actors/envs/breakout.h"

namespace coins::envs {
namespace {

using B = BreakoutEnv;
using K = BreakoutEnv::Kind;

struct Runner {
  explicit Runner(BreakoutVariant v, uint64_t seed = 1) : env(v), state(env.spec().state_dim()) {
    env.Reset(seed, state);
  }
  StepResult Step(int a = 0) {
    const float act = static_cast<float>(a);
    StepResult r;
    Status s = env.Step({&act, 1}, state, &r);
    EXPECT_TRUE(s.ok()) << s.message();
    return r;
  }
  // puts the ball just below block i moving up-right, then steps: the block is hit
  StepResult Hit(int i) {
    const auto& b = env.blocks()[i];
    env.SetBallForTest(b.y + b.h, b.x, -1, 1);
    return Step();
  }
  StepResult Bounce() {
    env.SetPaddleForTest(40);
    env.SetBallForTest(69, 42, 1, 1);
    return Step();
  }
  StepResult Drop() {
    env.SetPaddleForTest(4);
    env.SetBallForTest(78, 60, 1, 1);
    return Step();
  }
  int Count(K kind, int attr) const {
    int n = 0;
    for (const auto& b : env.blocks()) n += b.kind == kind && b.attr == attr;
    return n;
  }
  BreakoutEnv env;
  std::vector<float> state;
};

TEST(BreakoutVariants, NamesAndBlockCounts) {
  const std::pair<BreakoutVariant, int> want[] = {{BreakoutVariant::kBase, 100}, {BreakoutVariant::kSingle, 1},
                                                  {BreakoutVariant::kHard, 60},  {BreakoutVariant::kBig, 1},
                                                  {BreakoutVariant::kNeg, 10},   {BreakoutVariant::kCenter, 45},
                                                  {BreakoutVariant::kProx, 60}};
  for (auto [v, n] : want) {
    auto env = MakeEnv(BreakoutName(v));
    ASSERT_TRUE(env.ok()) << BreakoutName(v);
    const EnvSpec& s = (*env)->spec();
    EXPECT_EQ(s.name, BreakoutName(v));
    EXPECT_EQ(s.factors[s.factor_index("Block")].instances, n);
  }
  EXPECT_FALSE(MakeEnv("breakout-nope").ok());
  EXPECT_NE(MakeEnv("breakout-nope").status().message().find("breakout-single"), std::string::npos);
}

TEST(BreakoutVariants, SingleBlockRules) {
  std::set<int> ys, xs;
  for (uint64_t seed = 0; seed < 300; ++seed) {
    Runner r(BreakoutVariant::kSingle, seed);
    const auto& b = r.env.blocks()[0];
    EXPECT_EQ(b.w, 6);
    EXPECT_EQ(b.h, 4);
    EXPECT_GE(b.y, 17);
    EXPECT_LE(b.y, 36);
    EXPECT_GE(b.x, 15);
    EXPECT_LE(b.x, 65);
    ys.insert(b.y);
    xs.insert(b.x);
  }
  EXPECT_GT(ys.size(), 15u);
  EXPECT_GT(xs.size(), 40u);
  Runner r(BreakoutVariant::kSingle);
  StepResult s = r.Bounce();
  EXPECT_EQ(s.reward, -1.0f);
  EXPECT_FALSE(s.done);
  s = r.Hit(0);
  EXPECT_EQ(s.reward, 1.0f);
  EXPECT_TRUE(s.done);
  EXPECT_TRUE(s.interactions & B::kBallBlock);
  r.env.ResetNext(r.state);
  EXPECT_EQ(r.env.blocks()[0].attr, 1);
  s = r.Drop();
  EXPECT_EQ(s.reward, -10.0f);
  EXPECT_TRUE(s.done);
}

TEST(BreakoutVariants, HardBlocksReflectAndTheTargetEnds) {
  Runner r(BreakoutVariant::kHard, 3);
  EXPECT_EQ(r.Count(K::kGoal, 1), 1);
  EXPECT_EQ(r.Count(K::kHard, -1), 10);
  EXPECT_EQ(r.Count(K::kNormal, 0), 49);
  for (const auto& b : r.env.blocks()) {
    EXPECT_EQ(b.w, 5);
    EXPECT_EQ(b.h, 2);
  }
  int hard = -1, goal = -1;
  for (int i = 0; i < 60; ++i) {
    if (r.env.blocks()[i].kind == K::kHard && hard < 0) hard = i;
    if (r.env.blocks()[i].kind == K::kGoal) goal = i;
  }
  StepResult s = r.Hit(hard);
  EXPECT_TRUE(s.interactions & B::kBallBlock);
  EXPECT_EQ(s.reward, 0.0f);
  EXPECT_EQ(r.env.blocks()[hard].attr, -1);  // unbreakable
  EXPECT_EQ(r.env.ball_vy(), 1);             // reflected
  s = r.Hit(goal);
  EXPECT_EQ(s.reward, 1.0f);
  EXPECT_TRUE(s.done);
  // ten bounces end the episode, -1 each
  r.env.ResetNext(r.state);
  float total = 0;
  for (int k = 1; k <= 10; ++k) {
    s = r.Bounce();
    total += s.reward;
    EXPECT_EQ(s.done, k == 10) << k;
  }
  EXPECT_EQ(total, -10.0f);
  r.env.ResetNext(r.state);
  s = r.Drop();
  EXPECT_EQ(s.reward, -2.0f);
  EXPECT_TRUE(s.done);
}

TEST(BreakoutVariants, BigBlockAndTopWallDrop) {
  std::set<int> xs;
  for (uint64_t seed = 0; seed < 100; ++seed) {
    Runner r(BreakoutVariant::kBig, seed);
    const auto& b = r.env.blocks()[0];
    EXPECT_EQ(b.y, 17);
    EXPECT_EQ((b.x - 15) % 15, 0);
    xs.insert(b.x);
  }
  EXPECT_EQ(xs, (std::set<int>{15, 30, 45, 60}));
  Runner r(BreakoutVariant::kBig);
  r.env.SetBallForTest(9, 12, -2, 1);  // heads into the top wall, left of every position
  StepResult s = r.Step();
  EXPECT_TRUE(s.done);
  EXPECT_EQ(s.reward, -10.0f);
  r.env.ResetNext(r.state);
  s = r.Hit(0);
  EXPECT_EQ(s.reward, 1.0f);
  EXPECT_TRUE(s.done);
}

TEST(BreakoutVariants, NegativeBlocksRestoreAndFiveHitsEnd) {
  Runner r(BreakoutVariant::kNeg, 5);
  EXPECT_EQ(r.Count(K::kNegative, -1), 5);
  EXPECT_EQ(r.Count(K::kNormal, 1), 5);
  int neg = -1, pos = -1;
  for (int i = 0; i < 10; ++i) (r.env.blocks()[i].kind == K::kNegative ? neg : pos) = i;
  StepResult s = r.Hit(neg);
  EXPECT_EQ(s.reward, -1.0f);
  EXPECT_EQ(r.env.blocks()[neg].attr, -1);  // restored within the step
  s = r.Hit(pos);
  EXPECT_EQ(s.reward, 1.0f);
  EXPECT_EQ(r.env.blocks()[pos].attr, 1);
  const int off = r.env.spec().factor_offset(3);
  EXPECT_EQ(r.state[off + 5 * pos + 4], 1.0f);
  r.Hit(pos);
  r.Hit(pos);
  s = r.Hit(neg);
  EXPECT_TRUE(s.done);  // fifth hit
  r.env.ResetNext(r.state);
  s = r.Drop();
  EXPECT_EQ(s.reward, -10.0f);
}

TEST(BreakoutVariants, CenterHardBlocksAndClearBonus) {
  Runner r(BreakoutVariant::kCenter);
  EXPECT_EQ(r.Count(K::kHard, -1), 18);
  EXPECT_EQ(r.Count(K::kNormal, 1), 27);
  for (const auto& b : r.env.blocks()) EXPECT_EQ(b.kind == K::kHard, b.x > 28 && b.x < 56);
  int hard = -1;
  for (int i = 30; i < 45; ++i)
    if (r.env.blocks()[i].kind == K::kHard) hard = i;
  StepResult s = r.Hit(hard);
  EXPECT_EQ(s.reward, 0.0f);
  EXPECT_EQ(r.env.blocks()[hard].attr, -1);
  s = r.Hit(30);  // a normal block on the bottom row
  EXPECT_EQ(s.reward, 0.0f);
  EXPECT_EQ(r.env.blocks()[30].attr, 0);
  s = r.Bounce();
  EXPECT_EQ(s.reward, -1.0f);
  // clear all normal blocks but one, then hit it
  for (int i = 0; i < 45; ++i)
    if (r.env.blocks()[i].kind == K::kNormal && i != 44) r.env.SetBlockAttrForTest(i, 0);
  s = r.Hit(44);
  EXPECT_EQ(s.reward, 5.0f);
  EXPECT_TRUE(s.done);
  r.env.ResetNext(r.state);
  EXPECT_EQ(r.Count(K::kNormal, 1), 27);
}

TEST(BreakoutVariants, ProximityRewardTopRowAndTarget) {
  Runner r(BreakoutVariant::kProx, 11);
  ASSERT_GE(r.env.target(), 0);
  const int toff = r.env.spec().factor_offset(r.env.spec().factor_index("Target"));
  int hits = 0;
  for (int k = 0; k < 60; ++k) {
    const int t = r.env.target();
    const auto& tb = r.env.blocks()[t];
    EXPECT_EQ(r.state[toff + 0], tb.y + 1.0f);
    EXPECT_EQ(r.state[toff + 1], tb.x + 2.0f);
    // hit a live bottom-most block in a column chosen by k
    int i = -1;
    for (int row = 3; row >= 0 && i < 0; --row)
      if (r.env.blocks()[row * 15 + k % 15].attr != 0) i = row * 15 + k % 15;
    ASSERT_GE(i, 0);
    const auto b = r.env.blocks()[i];
    const float d = std::abs((b.y + 1.0f) - (tb.y + 1.0f)) + std::abs((b.x + 2.0f) - (tb.x + 2.0f));
    StepResult s = r.Hit(i);
    ++hits;
    EXPECT_NEAR(s.reward, 2.0f * (std::exp(-d / 10.0f) - 0.2f), 1e-5f);
    EXPECT_EQ(r.env.blocks()[i].attr, i < 15 ? 1 : 0);  // top row restored
    EXPECT_NE(r.env.blocks()[r.env.target()].attr, 0);  // target among live blocks
    EXPECT_EQ(s.done, hits == 60);
  }
  Runner q(BreakoutVariant::kProx, 12);
  EXPECT_EQ(q.Drop().reward, -10.0f);
}

// every variant: random play keeps rewards within the rule set and ends episodes
TEST(BreakoutVariants, RandomPlayRewardsFollowRules) {
  for (int v = 0; v <= 6; ++v) {
    Runner r(static_cast<BreakoutVariant>(v), 100 + v);
    Rng rng(v);
    int episodes = 0;
    for (int t = 0; t < 20000; ++t) {
      StepResult s = r.Step(rng.UniformInt(0, 3));
      if (!(s.interactions & (B::kBallBlock | B::kPaddleBall)) && !s.done) {
        EXPECT_EQ(s.reward, 0.0f);
      }
      EXPECT_GE(s.reward, -10.0f);
      EXPECT_LE(s.reward, 5.0f);
      if (s.done) {
        ++episodes;
        r.env.ResetNext(r.state);
      }
    }
    EXPECT_GT(episodes, 3) << BreakoutName(static_cast<BreakoutVariant>(v));
  }
}

}  // namespace
}  // namespace coins::envs
