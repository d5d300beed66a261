// `coins experiment transfer|pushing --chain RUN_DIR`: a comparison of methods, many runs, one
// table, by one command. For every variant, method and seed it runs one whole run, one after
// another, or with --domains D1,D2,.. as many at once as domains are listed, each live run on a
// domain of its own (orchestrator/run_queue.h), in OUT/VARIANT/METHOD-seedS:
//   coins    `coins transfer RUN_DIR --env ENV --skill SKILL --steps S`: a new task policy over
//            the chain's frozen top skill (Ball on Breakout, Block on pushing);
//   vanilla  `coins run` with RUN_DIR's config, orchestrator.chain none: the task alone over
//            primitive actions from scratch, same state inputs (plus the relative positions of
//            single-instance factors), network family and env step budget;
//   finetune (transfer only) `coins transfer` from a vanilla run pre-trained on base Breakout
//            (--pretrain-steps, one per seed, in OUT/pretrain/): its task policy trained further on
//            the variant. It needs a network that fits every board (learner.task_pair_hidden, a
//            pair network); a variant it cannot fit is reported as not run, with the reason.
// The suites: `transfer` (the paper's Tables 2 and 3: the six Breakout variants, env
// breakout-VARIANT) and `pushing` (the paper's Table 1 pushing row: env pushing, COInS against
// vanilla SAC). A run whose directory already holds a finished summary is kept, so an interrupted
// experiment continues where it stopped. The final eval return of a run is `coins eval` of its
// final checkpoint (--eval-episodes, a fixed seed per run; pushing: greedy); its curve is the
// learner's periodic evaluations (eval.csv). Written to OUT: SUITE.json and SUITE.md (mean +- sd
// over seeds beside the paper's numbers and the return of uniform random actions on the same
// episodes' seeds (eval-episodes x seeds episodes; what "learned nothing" scores), on Breakout
// also an ideal ball controller under random angles and under a 2-bounce search (`coins env plan`:
// bounds for a task over a perfect ball skill), the env steps each method's periodic
// evaluations needed to reach vanilla's last one, and where the env has them the fraction of episodes reaching the goal
// and of steps in penalty regions), and curves-VARIANT.png.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/status.h"

namespace coins {

struct ExperimentFlags {
  std::string suite = "transfer";     // transfer | pushing
  std::string chain;                  // RUN_DIR with a learned chain
  std::vector<std::string> variants;  // default: every variant of the suite
  std::vector<std::string> methods;   // default: every method of the suite
  int64_t seeds = 3;
  int64_t steps = 100'000;
  int64_t pretrain_steps = 100'000;    // finetune: the vanilla run on base Breakout
  int64_t eval_episodes = 0;           // the final evaluation of each run (0: the suite's, 20 or 50)
  std::string out;                     // default RUN_DIR/experiment-transfer
  std::vector<std::string> overrides;  // --set for every run
  std::vector<int> domains;            // runs at once, one per DDS domain (empty: one at a time, as configured)
};

void AddExperimentCommand(CLI::App& app, int* exit_code);
Status RunExperiment(const ExperimentFlags& flags);

// one finished run's figures (from its summary.json and eval.csv)
struct RunResult {
  bool done = false;
  double final_return = 0, final_sd = 0;               // the final evaluation (summary.json's until FinalEval)
  double done_fraction = NAN, penalty_fraction = NAN;  // episodes reaching the goal, steps penalised
  double final_median = NAN;                           // the final evaluation's median episode return
  std::vector<std::pair<uint64_t, double>> curve;      // (env steps, eval return mean)
  double wall_s = 0;
};
Result<RunResult> ReadRunResult(const std::string& dir);

}  // namespace coins
