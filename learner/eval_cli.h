// `coins eval RUN_DIR`: runs the task policy of a run (greedy but for its --explore epsilon, by
// default the one the run's own periodic evaluations used;
// the weights its best periodic evaluation scored with, or with --last its newest) or one of
// its skills with random goals (greedy) from its newest learner checkpoint, and
// reports the return's mean and standard deviation, the top skill's success (ball-angle
// accuracy in Breakout), optionally the rollout in the `coins env rollout` format and a GIF.
#pragma once

#include <cstdint>
#include <string>

#include <CLI/CLI.hpp>

#include "common/status.h"
#include "learner/learner_options.h"

namespace coins {

struct EvalFlags {
  std::string run_dir;
  std::string env;    // empty: the run's env
  std::string skill;  // empty: the task
  int episodes = 20;
  uint64_t seed = 1;
  int64_t max_steps = 20000;
  double explore = -1;  // the task level's epsilon; negative: the run's learner.eval_task_explore
  int64_t epoch = -1;   // -1: the newest checkpoint
  std::string out;      // rollout JSON lines
  std::string gif;
  int gif_steps = 1500;  // frames (env steps) in the GIF
  bool json = false;
  bool last = false;              // the task's newest weights instead of its best-evaluated ones
  double goal_sample_ratio = -1;  // --skill: random goals drawn with this sample ratio (negative: the skill's own)
  bool play_task = false;         // --skill: whole task episodes on random goals (EvalOptions::skill_plays_task)
};

// adds `eval`; its exit code goes to *exit_code
void AddEvalCommand(CLI::App& app, int* exit_code);
// runs; prints the report (text or JSON) on stdout
Status RunEval(const EvalFlags& flags);

}  // namespace coins
