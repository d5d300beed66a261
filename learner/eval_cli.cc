#include "learner/eval_cli.h"

#include <cstdio>
#include <filesystem>
#include <iostream>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "actors/envs/env.h"
#include "actors/envs/render.h"
#include "actors/envs/rollout_format.h"
#include "actors/evaluate.h"
#include "common/cli_checks.h"
#include "common/config/config.h"
#include "common/run_options.h"
#include "learner/checkpoint_dirs.h"
#include "learner/learner_core.h"

namespace coins {

namespace {

namespace fs = std::filesystem;

// what an evaluation takes from RUN_DIR/config.yaml
struct RunConfig {
  std::string env;
  double eval_task_explore = 0;  // the task's epsilon in the run's periodic evaluations
};

Result<RunConfig> ReadRunConfig(const std::string& run_dir) {
  RunOptions run;
  LearnerOptions learner;
  ConfigLoader loader({ConfigSection::Of("run", run), ConfigSection::Of("learner", learner)});
  if (Status s = loader.LoadFile((fs::path(run_dir) / "config.yaml").string()); !s.ok()) return s;
  return RunConfig{run.env, learner.eval_task_explore};
}

int FindLevel(const LearnerCore& core, const std::string& skill, std::string* names) {
  for (int L = 1; L <= 8; ++L) {
    PolicyTrainer* t = core.trainer(L);
    if (!t) break;
    *names += (names->empty() ? "" : ", ") + t->spec().name;
    if (skill.empty() ? t->spec().is_task() : (t->spec().name == skill || t->spec().name == "skill/" + skill)) return L;
  }
  return -1;
}

// what an evaluation records: rollout lines (--out, written to a temporary file renamed over it
// at the end) and GIF frames (--gif)
class EvalRecorder {
 public:
  EvalRecorder(const EvalFlags& f, envs::Env& env) : f_(f), env_(env) {}
  Status Open() {
    if (!f_.out.empty()) {
      out_.reset(std::fopen((f_.out + ".tmp").c_str(), "w"));
      if (!out_) return Errorf("--out {}: cannot open for writing", f_.out);
    }
    if (!f_.gif.empty()) {
      auto r = envs::MakeRenderer(env_, 4, 320, 240);
      if (!r.ok()) return r.status().WithContext("--gif");
      renderer_ = std::move(*r);
    }
    return Status::Ok();
  }
  void OnStep(const EvalStep& s) {
    if (out_) {
      line_.clear();
      envs::AppendRolloutLine(env_.spec(), t_, s.episode, s.state, s.action, s.next, *s.result, &line_);
      if (std::fwrite(line_.data(), 1, line_.size(), out_.get()) != line_.size())
        error_ = Errorf("--out {}: write failed", f_.out);
    }
    if (renderer_ && t_ < f_.gif_steps) {
      auto img = renderer_->Render(env_);
      if (img.ok()) frames_.push_back(std::move(*img));
    }
    ++t_;
  }
  // the first write error, else renames the rollout into place and writes the GIF
  Status Finish() {
    COINS_RETURN_IF_ERROR(error_);
    if (out_) {
      if (std::fflush(out_.get()) != 0) return Errorf("--out {}: write failed", f_.out);
      out_.reset();
      std::rename((f_.out + ".tmp").c_str(), f_.out.c_str());
    }
    if (renderer_) COINS_RETURN_IF_ERROR(envs::WriteGif(f_.gif, frames_, 3));
    return Status::Ok();
  }

 private:
  const EvalFlags& f_;
  envs::Env& env_;
  std::unique_ptr<FILE, int (*)(FILE*)> out_{nullptr, &std::fclose};
  std::unique_ptr<envs::FrameRenderer> renderer_;
  std::vector<envs::Image> frames_;
  int64_t t_ = 0;
  std::string line_;
  Status error_;
};

// the result as one JSON line (--json) or as text
// which weights of the task acted: "best" (with the evaluation that chose them) or "newest"
nlohmann::json TaskWeights(const LearnerCore& core, bool best) {
  const auto& b = core.best_task();
  if (!best || !b) return {{"weights", "newest"}};
  return {{"weights", "best"}, {"env_steps", b->env_steps}, {"return_mean", b->return_mean}, {"episodes", b->episodes}};
}

double Fraction(uint64_t part, uint64_t whole) { return whole ? double(part) / double(whole) : 0.0; }

// per discrete goal of the counted skill: attempts, success, and for an interaction skill the
// hit rate and the accuracy given a hit (the ball: by requested angle)
nlohmann::json ByGoalJson(const std::vector<GoalTally>& by_goal, bool interaction) {
  nlohmann::json list = nlohmann::json::array();
  for (const GoalTally& t : by_goal) {
    nlohmann::json e = {{"goal", t.goal}, {"goals", t.ended}, {"success", Fraction(t.reached, t.ended)}};
    e["hit_rate"] = interaction ? nlohmann::json(Fraction(t.interacted, t.ended)) : nlohmann::json(nullptr);
    e["accuracy"] = interaction ? nlohmann::json(Fraction(t.reached, t.interacted)) : nlohmann::json(nullptr);
    list.push_back(e);
  }
  return list;
}

void PrintByGoal(const std::vector<GoalTally>& by_goal, const policy::LevelSpec& skill) {
  for (const GoalTally& t : by_goal) {
    std::string line = fmt::format("    goal [{}]: {} goals, {:.1f}% reached", fmt::join(t.goal, ", "), t.ended,
                                   100.0 * Fraction(t.reached, t.ended));
    if (skill.require_interaction)
      line += fmt::format(", {:.1f}% with an interaction, {:.1f}% of them at the goal",
                          100.0 * Fraction(t.interacted, t.ended), 100.0 * Fraction(t.reached, t.interacted));
    std::cout << line << "\n";
  }
}

void PrintEval(const EvalFlags& f, const std::string& checkpoint, const envs::EnvSpec& es, int level,
               const policy::LevelSpec& spec, const policy::LevelSpec& skill, const EvalResult& r,
               const nlohmann::json& task_weights) {
  nlohmann::json j = {{"run_dir", f.run_dir},
                      {"checkpoint", checkpoint},
                      {"env", es.name},
                      {"level", level},
                      {"policy", spec.name},
                      {"episodes", r.returns.size()},
                      {"return_mean", r.return_mean},
                      {"return_sd", r.return_sd},
                      {"return_median", r.return_median},
                      {"return_min", r.return_min},
                      {"returns", r.returns},
                      {"goals", r.goals_ended},
                      {"goals_cut_by_win", r.goals_cut_by_win},
                      {"success", r.success},
                      {"steps", r.steps},
                      {"steps_per_s", r.control_seconds > 0 ? r.steps / r.control_seconds : 0.0},
                      {"env_steps_per_s", r.env_seconds > 0 ? r.steps / r.env_seconds : 0.0},
                      {"explore", spec.is_task() ? f.explore : 0.0},
                      {"play_task", f.play_task}};
  const bool continuous_skill = !spec.is_task() && spec.goal.kind == policy::GoalKind::kContinuous;
  const double ratio = f.goal_sample_ratio >= 0 ? f.goal_sample_ratio : spec.goal.sample_ratio;
  j["goal_sample_ratio"] = continuous_skill ? nlohmann::json(ratio) : nlohmann::json(nullptr);
  if (spec.is_task()) j["task_weights"] = task_weights;
  j["angle_accuracy"] = skill.require_interaction ? nlohmann::json(r.accuracy) : nlohmann::json(nullptr);
  j["hit_rate"] = skill.require_interaction ? nlohmann::json(r.hit_rate) : nlohmann::json(nullptr);
  // a reach that needs a detected interaction: how often the target was there at all
  j["arrived"] = skill.require_interaction ? nlohmann::json(r.arrived) : nlohmann::json(nullptr);
  j["by_goal"] = ByGoalJson(r.by_goal, skill.require_interaction);
  const bool task = spec.is_task();
  j["done_fraction"] = task && !es.done_means.empty() && !r.returns.empty()
                           ? nlohmann::json(double(r.episodes_done) / double(r.returns.size()))
                           : nlohmann::json(nullptr);
  j["penalty_fraction"] = task && !es.penalty_means.empty() && r.steps > 0
                              ? nlohmann::json(double(r.penalty_steps) / double(r.steps))
                              : nlohmann::json(nullptr);
  if (f.json) {
    std::cout << j.dump() << "\n";
    return;
  }
  std::cout << fmt::format("{} on {} ({}):", spec.name, es.name, checkpoint) << "\n";
  if (spec.is_task()) {
    // --explore is an epsilon for a dqn task; a sac task given any explore samples its policy
    const std::string how = spec.algorithm == "dqn" ? fmt::format("task epsilon {}", f.explore)
                            : f.explore > 0         ? std::string("the task samples its policy")
                                                    : std::string("greedy");
    std::cout << fmt::format("  return {:.2f} +- {:.2f} over {} episodes ({}); median {:.2f}, lowest {:.2f}",
                             r.return_mean, r.return_sd, r.returns.size(), how, r.return_median, r.return_min)
              << "\n";
    std::cout << (task_weights["weights"] == "best"
                      ? fmt::format("  the task's best-evaluated weights (return {:.2f} at {} env steps; --last: "
                                    "the newest)",
                                    task_weights["return_mean"].get<double>(),
                                    task_weights["env_steps"].get<uint64_t>())
                      : std::string("  the task's newest weights"))
              << "\n";
  } else if (f.play_task)
    std::cout << fmt::format("  return {:.2f} +- {:.2f} over {} whole episodes (the skill's goals at random)",
                             r.return_mean, r.return_sd, r.returns.size())
              << "\n";
  else if (!r.returns.empty())
    std::cout << fmt::format(
                     "  return {:.2f} +- {:.2f} over the {} episodes the env ended (the skill's goals at random)",
                     r.return_mean, r.return_sd, r.returns.size())
              << "\n";
  if (task && !es.done_means.empty())
    std::cout << fmt::format("  {} in {} of {} episodes ({:.1f}%)", es.done_means, r.episodes_done, r.returns.size(),
                             100.0 * j["done_fraction"].get<double>())
              << "\n";
  if (task && !es.penalty_means.empty())
    std::cout << fmt::format("  {}: {:.1f}% of {} env steps", es.penalty_means,
                             100.0 * j["penalty_fraction"].get<double>(), r.steps)
              << "\n";
  if (!skill.is_task())  // a task over primitive actions has no goals below it
    std::cout << fmt::format("  {} goals: {:.1f}% reached ({} of {}), {} env steps{}", skill.name, 100.0 * r.success,
                             r.goals_reached, r.goals_ended, r.steps,
                             r.goals_cut_by_win
                                 ? fmt::format(" ({} more cut by a won episode end, not counted)", r.goals_cut_by_win)
                                 : std::string())
              << "\n";
  if (continuous_skill)
    std::cout << (ratio > 0 ? fmt::format("  random goals within {} of the goal range around the {}{}", ratio,
                                          spec.goal.factor, f.goal_sample_ratio >= 0 ? " (--goal-sample-ratio)" : "")
                            : fmt::format("  random goals anywhere in the goal space"))
              << "\n";
  if (skill.require_interaction)
    std::cout << fmt::format("  interactions: {:.1f}% of goals (hit rate), {:.1f}% of them at the goal (accuracy)",
                             100.0 * r.hit_rate, 100.0 * r.accuracy)
              << "\n"
              << fmt::format("  the {} at the goal when it ended in {:.1f}% of goals, a detected interaction or not",
                             skill.goal.factor, 100.0 * r.arrived)
              << "\n";
  PrintByGoal(r.by_goal, skill);
  if (r.control_seconds > 0 && r.env_seconds > 0)
    std::cout << fmt::format(
                     "  speed: {:.0f} control steps/s with every level acting (one thread), the env's step "
                     "alone {:.0f}/s",
                     j["steps_per_s"].get<double>(), j["env_steps_per_s"].get<double>())
              << "\n";
}

}  // namespace

Status RunEval(const EvalFlags& f) {
  if (f.goal_sample_ratio >= 0 && f.skill.empty()) return Errorf("--goal-sample-ratio needs --skill");
  if (f.play_task && f.skill.empty()) return Errorf("--play-task needs --skill");
  auto ckpt = FindCheckpoint(f.run_dir, f.epoch);
  if (!ckpt.ok()) return ckpt.status();
  auto run_config = ReadRunConfig(f.run_dir);
  if (!run_config.ok()) return run_config.status();
  auto trained = envs::MakeEnv(run_config->env);
  if (!trained.ok()) return trained.status().WithContext(f.run_dir);
  auto env = envs::MakeEnv(f.env.empty() ? run_config->env : f.env);
  if (!env.ok()) return env.status().WithContext("--env");
  LearnerCore core((*trained)->spec(), LearnerOptions{}, f.seed);
  COINS_RETURN_IF_ERROR(core.LoadCheckpoint(*ckpt));
  std::string names;
  const int level = FindLevel(core, f.skill, &names);
  if (level < 0)
    return f.skill.empty()
               ? Errorf("{}: no task policy in {} (levels: {}); give --skill NAME", f.run_dir, *ckpt,
                        names.empty() ? "none" : names)
               : Errorf("--skill {}: not in {} (levels: {})", f.skill, *ckpt, names.empty() ? "none" : names);
  for (int L = 1; L <= level; ++L)
    COINS_RETURN_IF_ERROR(CheckLevelFits(core.trainer(L)->spec(), (*trained)->spec(), (*env)->spec()));
  const bool best = f.skill.empty() && !f.last;
  auto models = core.Models(level, best);
  if (!models.ok()) return models.status();

  EvalRecorder recorder(f, **env);
  COINS_RETURN_IF_ERROR(recorder.Open());
  EvalFlags flags = f;
  if (flags.explore < 0) flags.explore = run_config->eval_task_explore;
  EvalOptions eo{f.episodes, f.max_steps, f.seed, float(flags.explore), float(f.goal_sample_ratio), f.play_task};
  auto r = Evaluate(**env, **models, level, eo, [&](const EvalStep& s) { recorder.OnStep(s); });
  if (!r.ok()) return r.status();
  COINS_RETURN_IF_ERROR(recorder.Finish());

  const policy::LevelSpec& spec = core.trainer(level)->spec();
  const policy::LevelSpec& skill = spec.is_task() && level > 1 ? core.trainer(level - 1)->spec() : spec;
  PrintEval(flags, *ckpt, (*env)->spec(), level, spec, skill, *r, TaskWeights(core, best));
  return Status::Ok();
}

void AddEvalCommand(CLI::App& app, int* exit_code) {
  auto f = std::make_shared<EvalFlags>();
  CLI::App* cmd = app.add_subcommand("eval", "Run a run's greedy task policy (or a skill) and report its return.");
  cmd->add_option("run_dir", f->run_dir, "run directory (with checkpoints/)")->required();
  cmd->add_option("--env", f->env, "environment to evaluate in (default: the run's)");
  cmd->add_option("--skill", f->skill, "evaluate this skill (e.g. Ball) with random goals instead of the task");
  cmd->add_option("--episodes", f->episodes, "episodes (task, --play-task) or goals (skill)")
      ->check(CLI::Range(1, 100000));
  cmd->add_option("--seed", f->seed, "first episode's seed");
  cmd->add_option("--max-steps", f->max_steps, "env steps per episode at most")
      ->check(CLI::Range(int64_t(1), int64_t(1) << 30));
  cmd->add_option("--explore", f->explore,
                  "the task level's epsilon (skills act greedily); 0: greedy (default: the run's "
                  "learner.eval_task_explore)")
      ->check(cli::Finite(0.0, 1.0));
  cmd->add_option("--goal-sample-ratio", f->goal_sample_ratio,
                  "--skill with continuous goals: draw them within this fraction of the goal range around the target "
                  "(0: anywhere; default: as the skill trained)")
      ->check(CLI::Range(0.0, 10.0));
  cmd->add_option("--epoch", f->epoch, "checkpoint epoch (default: the newest)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--out", f->out, "write the rollout as JSON lines (the `coins env rollout` format)");
  cmd->add_option("--gif", f->gif, "write the first --gif-steps steps as a GIF");
  cmd->add_option("--gif-steps", f->gif_steps, "frames in the GIF")->check(CLI::Range(1, 3000));
  cmd->add_flag("--play-task", f->play_task,
                "--skill: play --episodes whole task episodes on random goals (the run's skill evaluations)");
  cmd->add_flag("--json", f->json, "print one JSON object");
  cmd->add_flag("--last", f->last,
                "the task's newest weights instead of those its best periodic evaluation scored with");
  cmd->callback([f, exit_code] {
    if (Status s = RunEval(*f); !s.ok()) {
      std::cerr << "coins eval: " << s.message() << "\n";
      *exit_code = 2;
    }
  });
}

}  // namespace coins
