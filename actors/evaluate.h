// Evaluation of a hierarchy: greedy rollouts in an env of one's own (the learner's periodic
// evaluations, `coins eval`, the final GIF of `coins run`).
//
// Every level acts greedily, except that a task level takes a uniformly random action with
// probability `task_explore` (the usual small evaluation epsilon): a greedy task policy in a
// deterministic env can fall into a cycle (the ball bouncing between the same places for ever,
// blocks left) that one random angle breaks. Skills are always evaluated greedily.
//
// Task (the acting level is the task, or acting 0: uniform random primitive actions, the
// reference a task's return is read against): `episodes` episodes, each from Reset(seed + i) (a fresh
// board), until the env ends it or max_steps; the return is the sum of env rewards.
// Skill (the acting level is a skill): its goals drawn at random, until `episodes` goals ended
// or max_steps in all, over as many episodes as that takes, each from Reset(seed + i); success
// is the fraction reached (for a link whose skill needs an interaction: reached at an
// interaction, the ball-angle accuracy in Breakout). The returns are those of the episodes the
// env ended (how the skill with random goals plays the task; the budget's last, cut episode is
// left out). A skill with discrete goals (the ball's four angles) is also counted per goal: the
// goal in force when an attempt ended (the random goal, or the task's request).
// Skill playing the task (`skill_plays_task`): the skill acts on its random goals for `episodes`
// whole episodes, each cut at max_steps, as a task would be evaluated: the return of a chain
// before any task policy chooses its goals (how the paper scores its Breakout skill). Its goals
// are counted as above.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "actors/envs/env.h"
#include "actors/hierarchy.h"

namespace coins {

struct EvalOptions {
  int episodes = 20;
  int64_t max_steps = 20000;  // per task episode; in all for a skill
  uint64_t seed = 1;
  float task_explore = 0.0f;  // epsilon of a task level (see above)
  // a skill's random goals: drawn with this sample ratio (policy::RandomGoal); negative: its own
  float goal_sample_ratio = -1.0f;
  bool skill_plays_task = false;  // a skill: whole episodes, as a task (see above)
};

// the attempts at one discrete goal of the counted skill
struct GoalTally {
  std::vector<float> goal;  // masked values, as the skill's goal space lists it
  uint64_t ended = 0, interacted = 0, reached = 0;
};

struct EvalResult {
  std::vector<double> returns;  // one per episode (a skill: per episode the env ended)
  double return_mean = 0, return_sd = 0;
  // the median and the lowest return: a few episodes that go badly (pushing: the block beyond the
  // fingertip's reach, -2 a step to the horizon) can move the mean far from the typical episode
  double return_median = 0, return_min = 0;
  uint64_t goals_ended = 0, goals_reached = 0;  // the acting skill's (task: the top skill's)
  uint64_t goals_interacted = 0;                // of the goals ended, those ended by a link interaction
  uint64_t goals_arrived = 0;  // of the goals ended, those with the target at the goal (interaction or not)
  // goals an episode end with a positive reward cut before any interaction (Breakout: the ball
  // skill's goal when the last block breaks); not attempts, so not in goals_ended
  uint64_t goals_cut_by_win = 0;
  double success = 0;   // goals_reached / goals_ended
  double hit_rate = 0;  // goals_interacted / goals_ended
  double accuracy = 0;  // goals_reached / goals_interacted (the angle, given a bounce)
  double arrived = 0;   // goals_arrived / goals_ended
  // a skill with discrete goals: one tally per goal of its space, in order (their counts sum to
  // goals_ended, goals_interacted, goals_reached); otherwise empty
  std::vector<GoalTally> by_goal;
  int64_t steps = 0;
  int64_t episodes_done =
      0;  // whole episodes (a task, a skill playing it): those the env ended as terminal (EnvSpec::done_means)
  int64_t penalty_steps = 0;  // whole episodes: steps whose reward was a penalty (EnvSpec::penalty_means)
  // wall seconds of the control steps (the hierarchy's decisions, env.Step, the detector and
  // goal bookkeeping; not the recorder), and of env.Step alone within them
  double control_seconds = 0, env_seconds = 0;
};

// one step of an evaluation, for recorders (rollout files, pictures)
struct EvalStep {
  int episode = 0;
  std::span<const float> state, action, next;
  const envs::StepResult* result = nullptr;
  std::span<const float> goal;  // a skill with discrete goals: the goal in force at this step (masked values)
};

Result<EvalResult> Evaluate(envs::Env& env, const HierarchyModels& models, int acting, const EvalOptions& options,
                            const std::function<void(const EvalStep&)>& on_step = {});

}  // namespace coins
