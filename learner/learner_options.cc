#include "learner/learner_options.h"

#include <cmath>

namespace coins {

void LevelTrainOptions::Visit(ConfigVisitor& v, const std::string& p) {
  v.String(p + "algorithm", algorithm, {"dqn", "ddpg", "sac"}, "dqn (discrete actions) | ddpg | sac (continuous)");
  v.FloatList(p + "hidden", hidden, "hidden layer sizes");
  v.Float(p + "lr", lr, 1e-7, 1, "learning rate");
  v.Int(p + "batch", batch, 1, 4096, "samples per update");
  v.Int(p + "n_step", n_step, 1, 100, "n-step returns");
  v.Float(p + "gamma", gamma, 0, 1, "discount");
  v.Int(p + "target_update", target_update, 1, 1 << 24, "dqn: updates between target copies");
  v.Float(p + "tau", tau, 1e-6, 1, "ddpg, sac: Polyak factor");
  v.Float(p + "sac_alpha", sac_alpha, 1e-6, 100, "sac: initial temperature (tuned to entropy -action_dim)");
  v.Int(p + "atoms", atoms, 1, 1001, "dqn: distributional atoms (1: expected values)");
  v.Float(p + "v_min", v_min, -1e6, 1e6, "dqn: lowest return of the support");
  v.Float(p + "v_max", v_max, -1e6, 1e6, "dqn: highest return of the support");
  v.Bool(p + "dueling", dueling, "dqn: dueling heads");
  v.Float(p + "explore", explore, 0, 1, "acting: dqn epsilon / ddpg noise std / sac: > 0 samples");
  v.String(p + "her", her, {"none", "final", "future"}, "hindsight strategy");
  v.Float(p + "her_ratio", her_ratio, 0, 1, "fraction of samples relabelled");
  v.Bool(p + "prioritized", prioritized, "prioritised sampling");
  v.Float(p + "priority_alpha", priority_alpha, 0, 10, "priority exponent");
  v.Float(p + "step_reward", step_reward, -1e6, 1e6, "reward of a step without success");
  v.Float(p + "success_reward", success_reward, -1e6, 1e6, "reward of the step reaching the goal");
  v.Float(p + "interaction_reward", interaction_reward, -1e6, 1e6, "reward of a link interaction without success");
  if (p != "task_")
    v.Float(p + "episode_end_reward", episode_end_reward, -1e6, 1e6,
            "added at a step ending the episode without success (a ball let drop)");
  v.Float(p + "goal_epsilon", goal_epsilon, 0, 2, "continuous goals: reached within (normalised units)");
  v.Int(p + "timeout", timeout, 1, 1 << 20, "env steps before a goal times out");
  v.Int(p + "decision_period", decision_period, 0, 1 << 20, "env steps per action at most (0: child's goal)");
  v.Bool(p + "hold_decision", hold_decision, "with decision_period: every action lasts exactly that many env steps");
  v.FloatList(p + "child_offsets", child_offsets, "continuous 1-d child goals as discrete offsets (dqn)");
  v.Float(p + "child_ratio", child_ratio, 1e-6, 10, "child goal offsets scale, fraction of the range");
  if (p != "task_")
    v.Float(p + "goal_sample_ratio", goal_sample_ratio, 0, 10,
            "random continuous goals within this fraction of the range around the target (0: anywhere)");
  v.Int(p + "publish_every", publish_every, 1, 1 << 24, "updates between weight publications");
  v.Float(p + "acting_average", acting_average, 0, 1,
          "acting weights: a running average of the online weights with this Polyak factor per update (0: the newest)");
  v.String(p + "interaction_ends_goal", interaction_ends_goal, {"rare", "never"},
           "rare: a rare link's interaction ends its goal (a bounce) | never: reached or timed out (a push)");
  if (p != "task_")
    v.Bool(p + "reach_needs_interaction", reach_needs_interaction,
           "a rare link's goal is reached only at a detected interaction (a bounce); false: the target at the goal");
  if (p == "task_") VisitTaskInputs(v, p);
}

void LevelTrainOptions::VisitTaskInputs(ConfigVisitor& v, const std::string& p) {
  v.FloatList(p + "pair_hidden", pair_hidden,
              "per-instance layers of a pair network over the first multi-instance factor, the blocks or the "
              "obstacle regions ([]: the Mlp)");
  v.FloatList(p + "pair_head", pair_head,
              "with pair_hidden: dense layers between the pair network's max-pool and its outputs ([]: none)");
  v.String(p + "relative", relative, {"link", "all"},
           "link: the top link's source minus its target | all: every pair of single factors and, in a pair "
           "network, every single factor minus each instance");
}

Status LevelTrainOptions::Validate(const std::string& p) const {
  if (hidden.empty()) return Errorf("{}hidden needs at least one layer", p);
  if (atoms > 1 && !(v_max > v_min)) return Errorf("{}v_max {} must exceed {}v_min {}", p, v_max, p, v_min);
  for (double o : child_offsets)
    if (!(o >= -1 && o <= 1)) return Errorf("{}child_offsets: {} is not in [-1, 1]", p, o);
  if (p == "primitive_" && decision_period > 1)
    return Errorf("{}decision_period {}: primitive actions are chosen every env step (0 or 1)", p, decision_period);
  if (hold_decision && (p == "primitive_" || decision_period < 1))
    return Errorf(
        "{}hold_decision holds an action for {}decision_period env steps: it needs a level above the "
        "primitive actions with a decision_period of at least 1 ({}decision_period is {})",
        p, p, p, decision_period);
  if (child_offsets.size() == 1) return Errorf("{}child_offsets needs at least 2 entries (or none)", p);
  for (const auto& [key, sizes] :
       {std::pair{"hidden", &hidden}, std::pair{"pair_hidden", &pair_hidden}, std::pair{"pair_head", &pair_head}})
    for (double h : *sizes)
      if (!(h >= 1 && h <= 65536 && h == std::floor(h))) return Errorf("{}{}: {} is not a layer size", p, key, h);
  if (!pair_head.empty() && pair_hidden.empty())
    return Errorf("{}pair_head adds layers to a pair network: it needs {}pair_hidden", p, p);
  return Status::Ok();
}

LevelTrainOptions LearnerOptions::Primitive() { return LevelTrainOptions{}; }

LevelTrainOptions LearnerOptions::Skill() {
  LevelTrainOptions o;
  o.hidden = {128, 128, 128};
  o.lr = 5e-4;
  o.batch = 128;
  o.n_step = 5;
  o.target_update = 500;
  o.v_min = -1;
  o.v_max = 1.5;
  o.explore = 0.1;
  o.her = "final";
  o.her_ratio = 0.3;
  o.step_reward = -0.01;
  o.success_reward = 1;
  o.interaction_reward = 0.3;
  o.timeout = 300;
  o.decision_period = 3;
  // with ratio 0.15 of Breakout's paddle range (68 px), 2, 4 and 6 px either way: the paddle
  // moves 2 px a step, 6 px in a decision period of 3, and a bounce's angle is set by 2 px zones
  o.child_offsets = {-0.6, -0.4, -0.2, 0, 0.2, 0.4, 0.6};
  return o;
}

LevelTrainOptions LearnerOptions::Task() {
  LevelTrainOptions o;
  o.hidden = {128, 128, 128};
  o.lr = 3e-4;
  o.batch = 128;
  o.n_step = 5;
  o.target_update = 500;
  o.v_min = -20;
  o.v_max = 40;
  o.explore = 0.1;
  o.her = "none";
  o.her_ratio = 0;
  o.step_reward = 0;
  o.timeout = 1000;
  return o;
}

void LearnerOptions::Visit(ConfigVisitor& v) {
  v.Float("status_period_s", status_period_s, 0.05, 3600, "status period (s)");
  primitive.Visit(v, "primitive_");
  skill.Visit(v, "skill_");
  task.Visit(v, "task_");
  v.Int("detect_max_samples", detect_max_samples, 100, int64_t(1) << 30, "samples per detect target at most");
  v.Int("detect_max_floats", detect_max_floats, 1000, int64_t(1) << 34, "sampled floats per detect target at most");
  v.Float("detect_holdout", detect_holdout, 0.01, 0.9, "held-out fraction scored");
  v.Int("detector_retrain_steps", detector_retrain_steps, 0, int64_t(1) << 40, "env steps between detector retrains");
  v.Int("eval_every_steps", eval_every_steps, 1, int64_t(1) << 40, "env steps between evaluations");
  v.Int("eval_episodes", eval_episodes, 1, 100000, "task episodes per evaluation");
  v.Int("eval_goals", eval_goals, 1, 1000000, "skill goals per evaluation");
  v.Int("eval_skill_episodes", eval_skill_episodes, 0, 100000,
        "task episodes a skill plays on random goals per evaluation (0: none)");
  v.Int("eval_max_steps", eval_max_steps, 1, int64_t(1) << 30, "env steps per evaluation episode at most");
  v.Float("eval_task_explore", eval_task_explore, 0, 1,
          "task epsilon in evaluations (a sac task samples its policy when > 0)");
  v.Int("eval_confirm_episodes", eval_confirm_episodes, 0, 100000,
        "new episodes that confirm a task evaluation beating the best before its weights are kept (0: none)");
  v.Bool("keep_best_task", keep_best_task,
         "the task's final policy is its best-evaluated weights (false: its newest weights)");
  v.Int("skill_updates_in_task", skill_updates_in_task, 0, 16,
        "updates of the skill under the task per task update while the task trains (0: the skill stays as learned)");
  v.Int("select_snapshots", select_snapshots, 0, 64,
        "snapshots of a training skill among which its final weights are chosen (0: keep the last)");
  v.Int("select_snapshot_every_steps", select_snapshot_every_steps, 1, int64_t(1) << 40,
        "env steps between a training skill's snapshots");
  v.Int("select_goals", select_goals, 1, 10000000, "goals each candidate of a skill's choice is evaluated on");
  v.Int("checkpoint_keep", checkpoint_keep, 1, 1000, "learner checkpoints kept");
  v.Float("shard_wait_s", shard_wait_s, 1, 1e7, "seconds a silent replay shard is waited for before the job fails");
}

Status LearnerOptions::Validate() const {
  COINS_RETURN_IF_ERROR(primitive.Validate("primitive_"));
  COINS_RETURN_IF_ERROR(skill.Validate("skill_"));
  COINS_RETURN_IF_ERROR(task.Validate("task_"));
  return Status::Ok();
}

}  // namespace coins
