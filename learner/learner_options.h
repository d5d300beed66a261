// LearnerOptions: the "learner" section of the config. Levels of the hierarchy are found at
// run time, so their settings come in three groups by what a level's actions are, never by
// link: `primitive_*` for the first skill (primitive actions), `skill_*` for skills whose actions
// are goals of the skill below, `task_*` for the task policy over the top skill. Detection
// settings are `detect_*`; the detectors' own options are the `detector` section. Defaults follow
// shared/reference/coins-method.md unless the comment says why not.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/config/config.h"
#include "detector/options.h"

namespace coins {

// how one group of levels is trained and run
struct LevelTrainOptions {
  std::string algorithm = "dqn";  // dqn (discrete actions) | ddpg | sac (continuous actions)
  std::vector<double> hidden = {128, 128};
  double lr = 7e-4;
  int64_t batch = 64;
  int64_t n_step = 2;
  double gamma = 0.99;
  int64_t target_update = 1000;  // dqn: hard target copy every N updates
  double tau = 0.005;            // ddpg, sac: Polyak factor
  double sac_alpha = 0.2;        // sac: initial temperature (then tuned to entropy -action_dim)
  int64_t atoms = 51;            // dqn: distributional when > 1
  double v_min = -30, v_max = 0;
  bool dueling = true;
  double explore = 0.3;        // acting: dqn epsilon / ddpg noise std / sac: > 0 samples the policy
  std::string her = "future";  // hindsight: none | final | future
  double her_ratio = 0.5;
  bool prioritized = false;
  double priority_alpha = 0.2;  // only used when prioritized (replay.priority_exponent sets the shards')
  double step_reward = -1, success_reward = 0, interaction_reward = -1;
  // skills only: added to a goal's reward at a step that ends the episode (not a time limit)
  // without success: the ball skill letting the ball drop (also the rare board cleared under a
  // ball goal)
  double episode_end_reward = 0;
  double goal_epsilon = 0.024;        // continuous goals: reached within this, in normalised units
  int64_t timeout = 30;               // env steps before a goal times out
  int64_t decision_period = 0;        // env steps per action at most (0: until the child's goal ends)
  bool hold_decision = false;         // with decision_period: every action lasts exactly that long
  std::vector<double> child_offsets;  // continuous 1-d child goals as discrete offsets (dqn); empty: ddpg
  double child_ratio = 0.15;          // child goal = child value + offset * ratio * range
  // continuous goals of the level drawn at random (training, evaluation) within this fraction of
  // the goal range around the target's value (0: anywhere in the goal space)
  double goal_sample_ratio = 0;
  int64_t publish_every = 50;  // updates between weight publications
  // the weights the level acts with (published, snapshotted, evaluated): 0 the newest online
  // weights; a > 0 a running average of them, avg += a * (online - avg) after every update
  double acting_average = 0;
  // a goal of a link whose interactions are rare ends at any detected interaction ("rare": a
  // bounce decides the ball's angle, the attempt is over), or only when reached or timed out
  // ("never": a push is one of many that bring the block to its goal)
  std::string interaction_ends_goal = "rare";
  // skills only: a goal of a rare link counts as reached only at a step with a detected
  // interaction (a ball velocity is the bounce's outcome only at the bounce); false: the target
  // at the goal is enough (a block position stays where the last push left it, and the detector
  // need not catch that push's last step)
  bool reach_needs_interaction = true;
  // the task only: a pair network over the blocks (a multi-instance factor) with these
  // per-block layers instead of the `hidden` Mlp over the whole state; empty: the Mlp
  std::vector<double> pair_hidden;
  // the task only, with pair_hidden: dense layers between the pair network's max-pool and its
  // outputs (the paper's 256); empty: the pool feeds the output layer
  std::vector<double> pair_head;
  // the task only: which relative positions it sees. "link": its top link's source minus target
  // (Paddle-Ball, Gripper-Block); "all": every pair of single-instance factors (Block-Target too)
  // and, in a pair network, every single factor minus each instance (Block-Obstacle), the
  // inputs a vanilla task over primitive actions gets (it always sees every single pair)
  std::string relative = "link";

  void Visit(ConfigVisitor& v, const std::string& p);
  Status Validate(const std::string& p) const;

 private:
  void VisitTaskInputs(ConfigVisitor& v, const std::string& p);  // the task's network inputs
};

struct LearnerOptions {
  // seconds between status publications
  double status_period_s = 0.25;  // also the actors' pacing signal (updates)
  LevelTrainOptions primitive = Primitive();
  LevelTrainOptions skill = Skill();
  LevelTrainOptions task = Task();
  // detection rounds: samples drawn from replay per target (at most), the held-out fraction
  // scored, and a cap on sampled floats (multi-instance targets carry many features)
  int64_t detect_max_samples = 200000;
  int64_t detect_max_floats = 20000000;
  double detect_holdout = 0.2;
  // detector training: the config's own `detector` section (detector/options.h), bound beside
  // this one, not a key of it
  detector::DetectorOptions detector;
  // a skill trained on interactions retrains its link's detector from replay this often (env
  // steps; 0: never), as the reference retrained the paddle-ball model during ball training
  int64_t detector_retrain_steps = 20000;
  // evaluation every eval_every_steps env steps: greedy task episodes, or greedy skill goals
  int64_t eval_every_steps = 20000;
  int64_t eval_episodes = 20;
  int64_t eval_goals = 100;
  // a skill's evaluation also lets it play this many whole task episodes on random goals (the
  // chain's return before a task policy, as the paper scores its Breakout skill; 0: off)
  int64_t eval_skill_episodes = 20;
  int64_t eval_max_steps = 20000;  // env steps at most per evaluation episode
  // the task level's epsilon in evaluations (skills are evaluated greedily): breaks the cycles
  // a greedy task policy can fall into in a deterministic env (actors/evaluate.h)
  double eval_task_explore = 0.05;
  // a task evaluation that beats the kept best is confirmed on this many new episodes (other env
  // seeds) before its weights are kept, and the best is compared by the confirming mean: the
  // highest of many short, noisy evaluations is mostly luck (pushing: a 20-episode mean of -10.8
  // kept at 25k env steps played -25.4 over 100 more). 0: kept by the periodic evaluation alone
  int64_t eval_confirm_episodes = 0;
  // the task's final policy is the weights of its best evaluation (false: its newest weights; no
  // best is kept). On pushing the newest weights after 300k env steps returned more than the kept
  // ones in 11 of 15 runs over 200 episodes each (-45.9 against -51.3): a task whose evaluations
  // are noisy and improve slowly is better judged by its end than by its luckiest evaluation
  bool keep_best_task = true;
  // while the task trains, the skill directly under it takes this many updates per task update
  // (from its own stream's rows: the goals the task asks for, relabelled as in its own phase) and
  // its new weights are published as they come; 0: a learned skill stays as its phase left it,
  // the paper's chain. A kept best task keeps the weights of the skills it was evaluated with.
  int64_t skill_updates_in_task = 0;
  // the weights a skill keeps when its training ends (learner/skill_selection.h): the best of
  // its newest select_snapshots snapshots (one every select_snapshot_every_steps env steps of its
  // training) and its final weights, each evaluated on select_goals goals; select_snapshots 0
  // keeps the final weights
  int64_t select_snapshots = 8;
  int64_t select_snapshot_every_steps = 50000;
  int64_t select_goals = 20000;
  // checkpoints go to RUN_DIR/checkpoints
  int64_t checkpoint_keep = 3;
  // a replay shard that does not answer is waited for (sampling goes on from the others, or
  // pauses when none answers) this long before the learner's job fails naming it: a shard's
  // restart or a node drain must not end the chain
  double shard_wait_s = 300;

  static LevelTrainOptions Primitive();
  static LevelTrainOptions Skill();
  static LevelTrainOptions Task();
  void Visit(ConfigVisitor& v);
  Status Validate() const;
};

}  // namespace coins
