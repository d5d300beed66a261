// The paper's first skill as an end-to-end check: the Breakout paddle skill.
//
// Goal: a paddle x (one of the reachable x centres), policy input: the paddle factor
// normalised by its bounds plus the normalised goal x; actions: the 4 primitive actions;
// reward -1 per step and 0 on reaching the goal (|x - goal| <= 1 px, L1 on the x mask);
// a segment ends on success, after `timeout` steps, or when the env's episode ends (ball
// drop), and then a new random goal is drawn. Learner: Dqn with the paddle defaults of
// coins-method.md (C51 in [-30, 0], dueling, double, n-step 2, 128-128, lr 7e-4, batch 64,
// target copy every 1000 updates, buffer 1e5) and hindsight relabelling (future, p = 0.5).
// Every eval_every env steps the greedy policy is scored on eval_goals fresh random goals in
// a separate env; evaluation steps are not counted as training env steps.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "common/status.h"
#include "learner/rl/dqn.h"
#include "learner/rl/exploration.h"

namespace coins::rl {

struct PaddleSkillOptions {
  int64_t max_env_steps = 20000;  // the budget
  int timeout = 30;               // paddle skill timeout
  int learning_starts = 1000;     // random steps before updates
  int updates_per_step = 1;
  LinearSchedule epsilon{1.0f, 0.05f, 5000};
  float her_ratio = 0.5f;
  int eval_every = 1000;
  int eval_goals = 100;
  double target_success = 0.95;
  bool stop_at_target = true;
  uint64_t seed = 1;
  DqnOptions dqn;  // obs_dim is set by the trainer
  Status Validate() const;
};

struct PaddleSkillResult {
  int64_t env_steps = 0;             // training env steps taken
  int64_t env_steps_to_target = -1;  // first evaluation at >= target_success, or -1
  double seconds_to_target = -1.0;   // wall time until then (training + evaluation)
  double wall_seconds = 0.0;
  double final_success = 0.0;                     // the last evaluation
  std::vector<std::pair<int64_t, double>> curve;  // (env steps, greedy success)
};

// trains on MakeEnv("breakout"); errors when the env is missing or misbehaves
Result<PaddleSkillResult> TrainPaddleSkill(const PaddleSkillOptions& options);

}  // namespace coins::rl
