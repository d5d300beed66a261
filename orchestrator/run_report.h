// What `coins run` shows and writes about the chain: the chain part of the progress line, the
// metrics rows (RUN_DIR/metrics.csv and metrics.jsonl, one row a second; eval.csv, one row per
// task evaluation; skill_eval.csv, one row per evaluation of a skill on random goals playing the
// task), the learning-curve PNGs (gnuplot), the summary (printed and summary.json) with
// the best evaluation and when each reported return was first reached, and the final GIF
// through `coins eval` when that subcommand exists. A resumed run appends to the metrics files
// of the run it continues, its wall clock going on from their last row.
#pragma once

#include <cstdint>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/status.h"
#include "orchestrator/status_collector.h"

namespace coins {

// "chain training-skill | Action->Paddle 6.20 0.91* | eval 12.3+-4.1 | skill plays 40.2+-9.9 | lag 1.0 |
// epoch 3 | restarts 0" (* marks the link in training; eval: the task policy's newest evaluation;
// skill plays: the skill in training on random goals playing the task); "chain (no status yet)" before the orchestrator
// reports
std::string ChainProgress(const StatusView& v, int64_t restarts);

struct MetricsRow {
  double wall_s = 0;
  uint64_t env_steps = 0;
  std::string phase;
  double steps_per_s = 0, updates_per_s = 0, lag_median = 0;
  uint64_t eval_env_steps = 0;
  double eval_mean = 0, eval_sd = 0;
  uint64_t epoch = 0;
  int64_t restarts = 0;
  struct Link {
    std::string name, state;
    double success = 0;
  };
  std::vector<Link> links;  // level i + 1 = links[i]
  DetectorCounts detector;
  // the learner's newest greedy evaluation of the level it trains (skills: goals reached, goals
  // ended by an interaction, and of those the reached ones; 0 before the first)
  uint64_t greedy_env_steps = 0;
  double greedy_success = 0, greedy_hit_rate = 0, greedy_angle_accuracy = 0;
  // of the same evaluation: the skill on random goals playing whole task episodes (0 episodes: none)
  double play_mean = 0, play_sd = 0;
  uint32_t play_episodes = 0;
};
MetricsRow MakeRow(const StatusView& v, double wall_s, double steps_per_s, int64_t restarts);

// one evaluation of the task's return as the run saw it: wall_s is the run's wall clock when it was first reported
struct EvalPoint {
  uint64_t env_steps = 0;
  double mean = 0, sd = 0, wall_s = 0;
};
// one data row of eval.csv ("env_steps,eval_return_mean,eval_return_sd[,wall_s]"; files of older
// runs have no wall_s, read as 0); nullopt for a header, a row cut short or a non-finite value
std::optional<EvalPoint> ParseEvalRow(const std::string& row);

class RunMetrics {
 public:
  static constexpr int kMaxLevels = 8;
  // opens dir/metrics.csv, metrics.jsonl, eval.csv and skill_eval.csv: truncated for a new run; with resume,
  // appended to, the evaluations and the wall clock read back from them (a row cut by a crash is
  // dropped; a file with another header is kept as NAME.before-resume and started anew)
  static Result<RunMetrics> Open(const std::string& dir, bool resume = false);
  // writes one row (its wall_s taken on from the resumed run's last row)
  void Append(const MetricsRow& row);
  // every evaluation so far, the resumed run's included, in order: of the task policy, and of the
  // skill in training on random goals playing the task
  const std::vector<EvalPoint>& evals() const { return evals_; }
  const std::vector<EvalPoint>& skill_evals() const { return skill_evals_; }
  // the wall time the resumed run had spent (0 for a new run)
  double wall_offset() const { return wall_offset_; }
  // flushes; writes skill_success.png and eval_return.png (both series) with gnuplot (bounded: 30 s); returns
  // the files written, or an error line (gnuplot missing or failing) that does not fail the run
  Result<std::vector<std::string>> Plot();

 private:
  std::string dir_;
  std::ofstream csv_, jsonl_, eval_, skill_eval_;
  double wall_offset_ = 0;                      // the resumed run's last wall_s
  std::vector<EvalPoint> evals_, skill_evals_;  // in order of env steps
  int levels_ = 0;
  std::vector<std::string> names_;  // the newest link name per level
};

// the detector counts as JSON (pair, states, labelled, false_positives, missed, fp_per_state,
// miss_rate); null when no actor counts a detector
nlohmann::json DetectorJson(const DetectorCounts& d);

// the summary of a finished run: links (accepted / learned steps, Sc_I, masks, goal sets, skill
// success), the newest eval return, wall time, env steps
nlohmann::json RunSummary(const StatusView& v, double wall_s, int64_t restarts);
// the best evaluation ("best": env_steps, mean, sd, wall_s) and, for each return in `targets`, the
// first evaluation whose mean reached it ("reached": [{return, env_steps, mean, wall_s}], env_steps
// null when none did); null without evaluations. Goes into the summary as "evals"
nlohmann::json EvalMilestones(const std::vector<EvalPoint>& evals, const std::vector<double>& targets);
// what the newest learner checkpoint of the run records about the weights it keeps, for the
// summary: "skill_choices" (learner/skill_selection.h) and "kept_task" (the task's kept weights:
// level, env_steps, return_mean, return_sd, episodes); each absent when the checkpoint has none.
// The launcher sets "kept_task" to {"newest": true} when the task keeps no best (its newest
// weights are the final policy)
nlohmann::json KeptWeightsOf(const std::string& run_dir);
std::string FormatSummary(const nlohmann::json& summary);

// the newest complete epoch cut after the chain was done (its chain-epoch-N.json holds phase
// done) or, with budget_steps > 0, at or after that many env steps: the learner's checkpoint of
// that epoch holds the final policy; nullopt when none yet
std::optional<uint64_t> FinalEpoch(const std::string& run_dir, uint64_t budget_steps = 0);

// HOOK (final GIF): when `coins eval` exists (the `eval` subcommand of the coins binary at
// coins_path), runs `coins eval RUN_DIR --gif RUN_DIR/final.gif` (bounded: 10 min) and returns
// the line to print; otherwise says that the GIF is skipped. One episode (--episodes 1): the
// final eval return is the learner's, from the run
std::string WriteFinalGif(const std::string& coins_path, const std::string& run_dir);

}  // namespace coins
