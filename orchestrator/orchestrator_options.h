// OrchestratorOptions: the "orchestrator" section of the config: every threshold and budget of
// the chain (paper Algorithm 1) and the orchestrator's periods. All budgets count env steps
// over all actors, so the chain's decisions do not depend on the machine's speed.
//
// Validate() refuses inconsistent values with one line naming the key (the config loader puts
// "config: orchestrator: " in front), before any process starts.
#pragma once

#include <cstdint>
#include <string>

#include "common/config/config.h"

namespace coins {

struct OrchestratorOptions {
  // seconds between ChainStatus publications (and progress checks)
  double status_period_s = 1.0;

  // coins: discover and learn the chain, then the task over its top skill (paper Algorithm 1);
  // none: no chain, the task alone over primitive actions from the first step (the vanilla
  // baseline, in the same harness, budgets and network family)
  std::string chain = "coins";

  // detection: a link is accepted when the best eligible Sc_I exceeds eps_si (the paper's
  // eps_SI, 3 to 5 in log-likelihood; detector/options.h uses the same default)
  double eps_si = 3.0;
  // env steps collected before each detect round of a source (one increment)
  int64_t detect_every_steps = 10'000;
  // env steps a source may collect in all before the chain gives up on it
  int64_t detect_budget_steps = 50'000;

  // skill convergence (paper: not improved for N_complete = 10000 steps, cutoff 0.01): the
  // goal-reaching rate, measured over windows of success_window_goals goals, has not risen by
  // more than success_tolerance for n_complete_goals of the skill's goals, after at least
  // skill_min_goals of them. Counted in goals, not env steps: a ball goal lasts a bounce (~100
  // env steps), a paddle goal a few steps, and the same count of tries judges both alike
  int64_t n_complete_goals = 3'000;
  // the same for the first skill, the one over primitive actions (level 1). Its goals are short
  // and its rate under the actors' exploration plateaus early with noisy windows: its best window
  // is mostly noise, and 3000 goals after it cost ~50k env steps. 1000 paddle goals are ~17k env
  // steps, near the paper's N_complete of 10k steps
  int64_t primitive_n_complete_goals = 1'000;
  double success_tolerance = 0.01;
  int64_t success_window_goals = 200;
  int64_t skill_min_goals = 2'000;
  // skill budget: the phase ends after this many env steps even without convergence
  int64_t skill_max_steps = 500'000;
  // actor pacing while a skill trains: env steps per learner update, after learning_starts
  // steps collected freely at the start of the phase
  double skill_steps_per_update = 2.0;
  int64_t skill_learning_starts = 2'000;

  // task convergence: the learner's eval return has not risen by more than task_tolerance
  // (return units) for task_n_complete_steps, after at least task_min_steps; or the budget
  int64_t task_n_complete_steps = 200'000;
  double task_tolerance = 2.0;
  int64_t task_min_steps = 300'000;
  int64_t task_max_steps = 1'000'000;
  double task_steps_per_update = 4.0;
  int64_t task_learning_starts = 5'000;

  // checkpoint epochs: one every checkpoint_period_s and at every phase change; an epoch whose
  // acknowledgements are not all in after checkpoint_timeout_s is reported and abandoned (the
  // next period cuts a new one)
  double checkpoint_period_s = 300.0;
  double checkpoint_timeout_s = 60.0;

  void Visit(ConfigVisitor& v);
  Status Validate() const;
};

inline void OrchestratorOptions::Visit(ConfigVisitor& v) {
  constexpr int64_t kMaxSteps = int64_t(1) << 50;
  v.Float("status_period_s", status_period_s, 0.05, 3600, "status period (s)");
  v.String("chain", chain, {"coins", "none"}, "coins: learn the chain; none: the task over primitive actions alone");
  v.Float("eps_si", eps_si, -1e6, 1e6, "Sc_I threshold of a link (eps_SI)");
  v.Int("detect_every_steps", detect_every_steps, 1, kMaxSteps, "env steps per detect increment");
  v.Int("detect_budget_steps", detect_budget_steps, 1, kMaxSteps, "env steps a source may collect for detection");
  v.Int("n_complete_goals", n_complete_goals, 1, kMaxSteps, "skill: goals without improvement to converge");
  v.Int("primitive_n_complete_goals", primitive_n_complete_goals, 1, kMaxSteps,
        "first skill (over primitive actions): goals without improvement to converge");
  v.Float("success_tolerance", success_tolerance, 0, 1, "skill: improvement of the success rate that counts");
  v.Int("success_window_goals", success_window_goals, 1, int64_t(1) << 40, "skill: goals per success window");
  v.Int("skill_min_goals", skill_min_goals, 0, kMaxSteps, "skill: goals before convergence may end it");
  v.Int("skill_max_steps", skill_max_steps, 1, kMaxSteps, "skill: env step budget");
  v.Float("skill_steps_per_update", skill_steps_per_update, 1e-3, 1e6, "skill: env steps per learner update");
  v.Int("skill_learning_starts", skill_learning_starts, 0, kMaxSteps, "skill: free env steps before pacing");
  v.Int("task_n_complete_steps", task_n_complete_steps, 1, kMaxSteps,
        "task: env steps without improvement to converge");
  v.Float("task_tolerance", task_tolerance, 0, 1e9, "task: improvement of the eval return that counts");
  v.Int("task_min_steps", task_min_steps, 0, kMaxSteps, "task: env steps before convergence may end it");
  v.Int("task_max_steps", task_max_steps, 1, kMaxSteps, "task: env step budget");
  v.Float("task_steps_per_update", task_steps_per_update, 1e-3, 1e6, "task: env steps per learner update");
  v.Int("task_learning_starts", task_learning_starts, 0, kMaxSteps, "task: free env steps before pacing");
  v.Float("checkpoint_period_s", checkpoint_period_s, 1, 1e7, "seconds between checkpoint epochs");
  v.Float("checkpoint_timeout_s", checkpoint_timeout_s, 1, 1e7, "seconds to wait for an epoch's acknowledgements");
}

inline Status OrchestratorOptions::Validate() const {
  if (detect_every_steps > detect_budget_steps)
    return Errorf("detect_every_steps ({}) must not exceed detect_budget_steps ({})", detect_every_steps,
                  detect_budget_steps);
  if (skill_learning_starts >= skill_max_steps)
    return Errorf("skill_learning_starts ({}) must be below skill_max_steps ({})", skill_learning_starts,
                  skill_max_steps);
  if (task_min_steps > task_max_steps)
    return Errorf("task_min_steps ({}) must not exceed task_max_steps ({})", task_min_steps, task_max_steps);
  if (task_learning_starts >= task_max_steps)
    return Errorf("task_learning_starts ({}) must be below task_max_steps ({})", task_learning_starts, task_max_steps);
  if (checkpoint_timeout_s > checkpoint_period_s)
    return Errorf("checkpoint_timeout_s ({}) must not exceed checkpoint_period_s ({})", checkpoint_timeout_s,
                  checkpoint_period_s);
  return Status::Ok();
}

}  // namespace coins
