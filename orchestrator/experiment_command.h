// `coins experiment transfer --chain RUN_DIR`: the transfer table (the paper's Tables 2 and 3) by
// one command. For every variant, method and seed it runs one whole run, one after another (each
// run uses the machine's cores), in OUT/VARIANT/METHOD-seedS:
//   coins    `coins transfer RUN_DIR --env breakout-VARIANT --steps S`: a new task policy over the
//            chain's frozen ball skill;
//   vanilla  `coins run` with RUN_DIR's config, orchestrator.chain none: the task alone over
//            primitive actions from scratch, same state inputs (plus the relative paddle-ball
//            features), network family and env step budget;
//   finetune `coins transfer` from a vanilla run pre-trained on base Breakout (--pretrain-steps,
//            one per seed, in OUT/pretrain/): its task policy trained further on the variant. It
//            needs a network that fits every board (learner.task_pair_hidden, a pair network);
//            a variant it cannot fit is reported as not run, with the reason.
// A run whose directory already holds a finished summary is kept, so an interrupted experiment
// continues where it stopped. The final eval return of a run is `coins eval` of its final
// checkpoint (--eval-episodes, a fixed seed per run); its curve is the learner's periodic
// evaluations (eval.csv). Written to OUT:
// transfer.json and transfer.md (mean +- sd over seeds beside the paper's numbers, and the env
// steps each method needed to reach vanilla's final return), and curves-VARIANT.png.
#pragma once

#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/status.h"

namespace coins {

struct ExperimentFlags {
  std::string chain;  // RUN_DIR with a learned chain
  std::vector<std::string> variants = {"single", "hard", "big", "neg", "center", "prox"};
  std::vector<std::string> methods = {"coins", "vanilla", "finetune"};
  int64_t seeds = 3;
  int64_t steps = 100'000;
  int64_t pretrain_steps = 100'000;    // finetune: the vanilla run on base Breakout
  int64_t eval_episodes = 20;          // the final evaluation of each run
  std::string out;                     // default RUN_DIR/experiment-transfer
  std::vector<std::string> overrides;  // --set for every run
};

void AddExperimentCommand(CLI::App& app, int* exit_code);
Status RunTransferExperiment(const ExperimentFlags& flags);

// one finished run's figures (from its summary.json and eval.csv)
struct RunResult {
  bool done = false;
  double final_return = 0, final_sd = 0;           // the final evaluation (summary.json's until FinalEval)
  std::vector<std::pair<uint64_t, double>> curve;  // (env steps, eval return mean)
  double wall_s = 0;
};
Result<RunResult> ReadRunResult(const std::string& dir);

}  // namespace coins
