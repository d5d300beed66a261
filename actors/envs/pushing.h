// Robot pushing with negative reward regions (shared/reference/pushing.md) on MuJoCo 2.2.
//
// A fingertip on three slide joints (x, y in [-0.2, 0.2], z in [0, 0.2] above its rest height)
// is servoed by position actuators; a 5 cm free cube sits on a table whose top is z = 0, and
// the workspace centre is the origin. An action a in [-1, 1]^3 sets the servo target to the
// fingertip's current joint position + 0.05 a (clamped to the joint ranges); the physics runs
// kSubsteps steps of 2 ms (one control step = 50 ms) while the servo set-point moves linearly
// from the previous target to the new one (a smooth push rather than a kick).
// Factors, positions in metres: Action(3), Gripper(3, fingertip centre), Block(3, cube centre),
// Obstacle(15 x 3, centres of the regions; "pushing" only), Target(3, goal centre), Done(1),
// Reward(1). Interaction bits: 0 Action->Gripper (the action commanded a
// fingertip displacement of more than 0.1 mm), 1
// Gripper->Block (a fingertip-cube contact in MuJoCo's contact list during the step).
// Reward per step: -2 when the cube centre is in a region or out of bounds
// (max(|x|, |y|) >= 0.175), else -0.1. Done when the cube is within 0.05 of the goal (xy);
// truncated after 300 steps (30 for "pushing-easy", which has no regions).
// One shared read-only mjModel; each env owns its mjData.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "actors/envs/env.h"
#include "actors/envs/mujoco_util.h"
#include "actors/envs/rng.h"

namespace coins::envs {

class PushingEnv final : public Env {
 public:
  static constexpr int kSubsteps = 25;
  static constexpr int kRegions = 15;
  static constexpr int kGrid = 5;
  static constexpr double kCell = 0.06;       // grid cell side (m)
  static constexpr double kHalfSpawn = 0.15;  // spawn square half side (m)
  static constexpr double kBounds = 0.175;    // out-of-bounds limit on max(|x|, |y|)
  static constexpr double kSuccess = 0.05;    // cube-goal xy distance that ends the episode
  static constexpr double kMaxMove = 0.05;    // servo target displacement per unit action
  static constexpr double kFingerRestZ = 0.015;
  static constexpr double kCubeHalf = 0.025;
  enum Bit : uint32_t { kActionGripper = 1u << 0, kGripperBlock = 1u << 1 };

  // builds "pushing" (easy = false) or "pushing-easy"; fails if the model does not compile
  static Result<std::unique_ptr<PushingEnv>> Create(bool easy);

  const EnvSpec& spec() const override { return spec_; }
  void Reset(uint64_t seed, std::span<float> state) override;
  void ResetNext(std::span<float> state) override;
  Status Step(std::span<const float> action, std::span<float> next_state, StepResult* result) override;
  void GetState(std::span<float> state) const override;
  std::vector<uint8_t> SaveState() const override;
  Status RestoreState(std::span<const uint8_t> bytes) override;

  // read-only views for tests, rendering and benchmarks
  const mjModel* model() const { return m_; }
  const mjData* data() const { return d_.get(); }
  bool easy() const { return easy_; }
  std::array<double, 3> gripper() const;
  std::array<double, 3> cube() const;
  std::array<double, 2> goal() const { return goal_; }
  const std::vector<int>& region_cells() const { return regions_; }  // row * 5 + col
  bool InRegion(double x, double y) const;
  int steps() const { return steps_; }
  double cube_speed() const;  // linear speed of the cube (m/s)
  // test hook: puts the cube at rest at (x, y) on the table
  void SetCubeForTest(double x, double y);
  // grid helpers: the cell of a point inside the spawn square, and a cell's centre
  static int CellOf(double x, double y);
  static std::array<double, 2> CellCentre(int cell);
  // true if a 4-connected path of region-free cells joins cells a and b
  static bool FreePath(uint32_t region_mask, int a, int b);

 private:
  PushingEnv(const mjModel* m, bool easy);
  void Sample();  // cube, goal and regions from rng_
  void Place();   // writes the sampled episode into mjData and settles the cube
  void WriteState(std::span<float> out) const;

  const mjModel* m_;
  DataPtr d_;
  bool easy_;
  EnvSpec spec_;
  int horizon_;
  int gx_adr_ = 0, cube_adr_ = 0, cube_dof_ = 0, finger_geom_ = 0, cube_geom_ = 0;
  int goal_mocap_ = 0, region_mocap_[kRegions] = {};

  Rng rng_;
  std::array<double, 2> cube_start_{}, goal_{};
  std::vector<int> regions_;
  uint32_t region_mask_ = 0;
  std::array<float, 3> last_action_{};
  float last_reward_ = 0.0f, last_done_ = 0.0f;
  int steps_ = 0;
  bool episode_over_ = false;
  Status sim_error_;  // a MuJoCo failure during Reset, reported by the next Step
};

}  // namespace coins::envs
