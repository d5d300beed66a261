// Pushing on MuJoCo: episode sampling (regions always leave a path), the servo, contact
// labels, "the cube moves only when touched", rewards, determinism, bad actions, and MuJoCo
// errors turned into Status.
#include "actors/envs/pushing.h"

#include <cmath>
#include <limits>
#include <set>

#include <gtest/gtest.h>

namespace coins::envs {
namespace {

using P = PushingEnv;

struct Runner {
  explicit Runner(bool easy = false, uint64_t seed = 1) {
    auto e = PushingEnv::Create(easy);
    EXPECT_TRUE(e.ok()) << e.status().message();
    env = std::move(e).value();
    state.resize(env->spec().state_dim());
    env->Reset(seed, state);
  }
  StepResult Step(float x, float y, float z) {
    const float a[3] = {x, y, z};
    StepResult r;
    Status s = env->Step(a, state, &r);
    EXPECT_TRUE(s.ok()) << s.message();
    return r;
  }
  // a proportional action towards a fingertip position
  StepResult MoveTo(double x, double y, double z) {
    const auto g = env->gripper();
    auto c = [](double v) { return static_cast<float>(std::clamp(v / P::kMaxMove, -1.0, 1.0)); };
    return Step(c(x - g[0]), c(y - g[1]), c(z - g[2]));
  }
  std::unique_ptr<PushingEnv> env;
  std::vector<float> state;
};

TEST(Pushing, SpecAndNames) {
  Runner r;
  const EnvSpec& s = r.env->spec();
  EXPECT_EQ(s.name, "pushing");
  EXPECT_EQ(s.state_dim(), 3 + 3 + 3 + 45 + 3 + 2);
  EXPECT_EQ(s.factors[s.factor_index("Obstacle")].instances, 15);
  EXPECT_FALSE(s.action.discrete);
  EXPECT_EQ(s.action.dim, 3);
  EXPECT_EQ(s.max_episode_steps, 300);
  auto easy = MakeEnv("pushing-easy");
  ASSERT_TRUE(easy.ok());
  EXPECT_EQ((*easy)->spec().factor_index("Obstacle"), -1);
  EXPECT_EQ((*easy)->spec().max_episode_steps, 30);
}

TEST(Pushing, FreePathSearch) {
  // a full wall on column 2 separates the left from the right
  uint32_t wall = 0;
  for (int r = 0; r < 5; ++r) wall |= 1u << (r * 5 + 2);
  EXPECT_FALSE(P::FreePath(wall, 0, 4));
  EXPECT_TRUE(P::FreePath(wall, 0, 20));
  // a gap at the bottom opens it
  EXPECT_TRUE(P::FreePath(wall & ~(1u << 22), 0, 4));
  // diagonal moves do not count
  const uint32_t diag = (1u << 1) | (1u << 5);
  EXPECT_FALSE(P::FreePath(diag, 0, 6));
}

TEST(Pushing, ResetSamplesRegionsWithAFreePath) {
  Runner r;
  std::set<int> cells_seen;
  for (uint64_t seed = 0; seed < 300; ++seed) {
    r.env->Reset(seed, r.state);
    const auto cube = r.env->cube();
    const auto goal = r.env->goal();
    EXPECT_LT(std::abs(cube[0]), 0.15);
    EXPECT_LT(std::abs(cube[1]), 0.15);
    EXPECT_NEAR(cube[2], 0.025, 0.002);
    EXPECT_GE(std::hypot(cube[0] - goal[0], cube[1] - goal[1]), 0.05);
    const auto& cells = r.env->region_cells();
    ASSERT_EQ(cells.size(), 15u);
    uint32_t mask = 0;
    for (int c : cells) mask |= 1u << c;
    EXPECT_EQ(std::popcount(mask), 15);
    const int cc = P::CellOf(cube[0], cube[1]), gc = P::CellOf(goal[0], goal[1]);
    EXPECT_FALSE(mask >> cc & 1);
    EXPECT_FALSE(mask >> gc & 1);
    EXPECT_TRUE(P::FreePath(mask, cc, gc));
    for (int c : cells) cells_seen.insert(c);
    // the Obstacle factor carries the region centres
    const int off = r.env->spec().factor_offset(r.env->spec().factor_index("Obstacle"));
    const auto c0 = P::CellCentre(cells[0]);
    EXPECT_FLOAT_EQ(r.state[off], static_cast<float>(c0[0]));
    EXPECT_FLOAT_EQ(r.state[off + 1], static_cast<float>(c0[1]));
  }
  EXPECT_EQ(cells_seen.size(), 25u);
}

TEST(Pushing, ServoMovesFingertipAndHoldsHeight) {
  Runner r(false, 3);
  const auto g0 = r.env->gripper();
  EXPECT_NEAR(g0[2], 0.1, 0.003);
  StepResult s = r.Step(1, 0, 0);
  EXPECT_TRUE(s.interactions & P::kActionGripper);
  const auto g1 = r.env->gripper();
  // the set-point ramps 5 cm over the step; the servo trails it by about a centimetre
  EXPECT_GT(g1[0] - g0[0], 0.035);
  EXPECT_LT(g1[0] - g0[0], 0.052);
  EXPECT_NEAR(g1[1], g0[1], 0.002);
  for (int i = 0; i < 10; ++i) s = r.Step(0, 0, 0);
  EXPECT_FALSE(s.interactions & P::kActionGripper);
  EXPECT_NEAR(r.env->gripper()[2], 0.1, 0.003);  // gravity is compensated
  for (int i = 0; i < 10; ++i) s = r.Step(1, -1, 1);
  const auto g2 = r.env->gripper();
  EXPECT_NEAR(g2[0], 0.2, 0.003);
  EXPECT_NEAR(g2[1], -0.2, 0.003);
  EXPECT_NEAR(g2[2], 0.215, 0.003);
  EXPECT_FALSE(s.interactions & P::kActionGripper);  // at the limits: nothing to move
  EXPECT_FLOAT_EQ(r.state[3], static_cast<float>(g2[0]));
}

// random play: whenever there was no fingertip-cube contact and the cube was at rest,
// the cube stays where it is
TEST(Pushing, CubeMovesOnlyWhenTouched) {
  Runner r(false, 5);
  Rng rng(9);
  int quiet_steps = 0;
  for (int t = 0; t < 1500; ++t) {
    const auto before = r.env->cube();
    const double speed = r.env->cube_speed();
    StepResult s = r.Step(rng.Uniform(-1, 1), rng.Uniform(-1, 1), rng.Uniform(-1, 1));
    const auto after = r.env->cube();
    if (!(s.interactions & P::kGripperBlock) && speed < 1e-3) {
      ++quiet_steps;
      EXPECT_LT(std::hypot(after[0] - before[0], after[1] - before[1]), 2e-4) << t;
    }
    if (s.done || s.truncated) r.env->ResetNext(r.state);
  }
  EXPECT_GT(quiet_steps, 1000);
}

// a scripted push: contacts are labelled exactly while the fingertip pushes, and the cube moves
TEST(Pushing, ScriptedPushLabelsContactAndMovesCube) {
  Runner r(true, 2);
  const auto c0 = r.env->cube();
  // approach from -x at height, go down behind the cube, then push along +x
  for (int i = 0; i < 12; ++i) r.MoveTo(c0[0] - 0.07, c0[1], 0.1);
  for (int i = 0; i < 6; ++i) {
    StepResult s = r.MoveTo(c0[0] - 0.07, c0[1], 0.025);
    EXPECT_FALSE(s.interactions & P::kGripperBlock);
  }
  EXPECT_LT(std::hypot(r.env->cube()[0] - c0[0], r.env->cube()[1] - c0[1]), 1e-3);
  int touches = 0;
  for (int i = 0; i < 8; ++i) {
    StepResult s = r.Step(0.5f, 0, 0);
    touches += (s.interactions & P::kGripperBlock) != 0;
    if (s.done || s.truncated) break;
  }
  const auto c1 = r.env->cube();
  EXPECT_GT(touches, 2);
  EXPECT_GT(c1[0] - c0[0], 0.02);            // pushed along +x
  EXPECT_LT(std::abs(c1[1] - c0[1]), 0.01);  // and not much sideways
  // the fingertip stays behind the cube face it pushes
  EXPECT_LT(r.env->gripper()[0], c1[0] - 0.025);
}

TEST(Pushing, RewardsRegionsBoundsSuccessAndHorizon) {
  Runner r(false, 4);
  const auto& cells = r.env->region_cells();
  uint32_t mask = 0;
  for (int c : cells) mask |= 1u << c;
  // the cube in each grid cell gives -2 exactly on region cells
  for (int cell = 0; cell < 25; ++cell) {
    const auto cc = P::CellCentre(cell);
    const auto goal = r.env->goal();
    if (std::hypot(cc[0] - goal[0], cc[1] - goal[1]) < 0.06) continue;
    r.env->SetCubeForTest(cc[0], cc[1]);
    StepResult s = r.Step(0, 0, 0);
    EXPECT_FLOAT_EQ(s.reward, (mask >> cell & 1) ? -2.0f : -0.1f) << cell;
    EXPECT_FALSE(s.done);
  }
  // out of bounds
  r.env->SetCubeForTest(0.18, 0.0);
  EXPECT_FLOAT_EQ(r.Step(0, 0, 0).reward, -2.0f);
  r.env->SetCubeForTest(0.16, 0.0);  // outside the grid, inside the bounds
  EXPECT_FLOAT_EQ(r.Step(0, 0, 0).reward, -0.1f);
  // success
  const auto goal = r.env->goal();
  r.env->SetCubeForTest(goal[0] + 0.03, goal[1]);
  StepResult s = r.Step(0, 0, 0);
  EXPECT_TRUE(s.done);
  EXPECT_FALSE(s.truncated);
  EXPECT_EQ(r.state.back(), -0.1f);
  // the horizon truncates without touching: 300 steps of -0.1 (easy: 30)
  for (bool easy : {false, true}) {
    Runner q(easy, 8);
    float total = 0;
    int t = 0;
    StepResult last;
    do {
      last = q.Step(0, 0, 0);
      total += last.reward;
      ++t;
    } while (!last.done && !last.truncated);
    EXPECT_EQ(t, easy ? 30 : 300);
    EXPECT_TRUE(last.truncated);
    EXPECT_NEAR(total, easy ? -3.0f : -30.0f, 1e-3);
  }
}

TEST(Pushing, DeterministicAndSaveRestore) {
  Runner a(false, 21), b(false, 21);
  Rng ra(4), rb(4);
  std::vector<uint8_t> saved;
  std::vector<std::vector<float>> tail;
  std::vector<std::array<float, 3>> tail_actions;
  for (int t = 0; t < 400; ++t) {
    std::array<float, 3> act = {float(ra.Uniform(-1, 1)), float(ra.Uniform(-1, 1)), float(ra.Uniform(-1, 1))};
    std::array<float, 3> bct = {float(rb.Uniform(-1, 1)), float(rb.Uniform(-1, 1)), float(rb.Uniform(-1, 1))};
    StepResult sa = a.Step(act[0], act[1], act[2]);
    b.Step(bct[0], bct[1], bct[2]);
    if (sa.done || sa.truncated) {
      a.env->ResetNext(a.state);
      b.env->ResetNext(b.state);
    }
    ASSERT_EQ(a.state, b.state) << t;
    if (t == 200) saved = a.env->SaveState();
    if (t > 200) {
      tail.push_back(a.state);
      tail_actions.push_back(act);
    }
  }
  Runner c(false, 77);
  ASSERT_TRUE(c.env->RestoreState(saved).ok());
  for (size_t k = 0; k < tail.size(); ++k) {
    StepResult s = c.Step(tail_actions[k][0], tail_actions[k][1], tail_actions[k][2]);
    if (s.done || s.truncated) c.env->ResetNext(c.state);
    ASSERT_EQ(c.state, tail[k]) << k;
  }
}

TEST(Pushing, BadActionsAreErrorsAndLeaveEnvUnchanged) {
  Runner r;
  r.Step(0.3f, 0.2f, -0.1f);
  const std::vector<uint8_t> before = r.env->SaveState();
  const std::vector<float> state_before = r.state;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::array<float, 3> bad[] = {
      {nan, 0, 0}, {0, 1.5f, 0}, {0, 0, -1.01f}, {0, 0, std::numeric_limits<float>::infinity()}};
  for (const auto& a : bad) {
    StepResult s;
    Status st = r.env->Step(a, r.state, &s);
    EXPECT_FALSE(st.ok());
    EXPECT_NE(st.message().find("action["), std::string::npos) << st.message();
    EXPECT_EQ(r.env->SaveState(), before);
    EXPECT_EQ(r.state, state_before);
  }
  const float one[1] = {0.0f};
  StepResult s;
  EXPECT_FALSE(r.env->Step(one, r.state, &s).ok());
  EXPECT_EQ(r.env->SaveState(), before);
  std::vector<uint8_t> cut(before.begin(), before.end() - 8);
  EXPECT_FALSE(r.env->RestoreState(cut).ok());
  EXPECT_EQ(r.env->SaveState(), before);
}

TEST(Mujoco, ErrorsBecomeStatus) {
  InstallMujocoHandlers();
  Status st = MujocoGuarded("probe", [] { mju_error("probe failure 42"); });
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("probe failure 42"), std::string::npos);
  // nested guards unwind to the innermost one
  Status outer = MujocoGuarded("outer", [] {
    Status inner = MujocoGuarded("inner", [] { mju_error("inner boom"); });
    EXPECT_FALSE(inner.ok());
  });
  EXPECT_TRUE(outer.ok());
  auto bad = LoadModelFromString("<mujoco><worldbody><geom type='nope'/></worldbody></mujoco>", "bad");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("bad"), std::string::npos);
}

}  // namespace
}  // namespace coins::envs
