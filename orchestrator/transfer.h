// `coins transfer RUN_DIR --env VARIANT`: the skills a run learned, put to work on another task.
//
// A new run (default directory RUN_DIR/transfer/VARIANT) with RUN_DIR's config and the variant's
// env starts in the task phase over the chain's links up to the skill of --skill (default Ball):
//   - its orchestrator starts from a chain in phase task with those links (chain.h TransferState);
//   - its learner starts from a checkpoint that holds only those skills and their link detectors
//     (learner/transfer_checkpoint.h); it trains nothing but the task, so the skills stay frozen
//     (their weights are bit-identical in every later checkpoint);
//   - actors run the frozen skills and the new task policy on the variant.
// Everything else is `coins run`: live progress, checkpoint epochs, crash restarts,
// `coins transfer --resume DIR`, metrics and curves, `coins eval DIR`. --steps S trains the task
// for exactly S env steps (orchestrator.task_min_steps = task_max_steps = S). RUN/transfer.json
// records the source run, the skills and their weights' checksums.
//
// From a run without a chain (orchestrator.chain none, the vanilla baseline) the transfer is a
// fine-tuning: the new run continues training that run's task policy on the new env (it needs a
// network that fits both, e.g. the pair network over the blocks, learner.task_pair_hidden; inputs
// the new env adds, like breakout-prox's Target, start with zero weights: input_remap.h).
//
// Refused before anything starts, with one line: a RUN_DIR that is not a run or whose chain has
// no learned --skill skill, an unknown env, an env whose factors do not match the chain's.
#pragma once

#include <string>

#include <CLI/CLI.hpp>

#include "orchestrator/launcher.h"

namespace coins {

struct TransferFlags {
  std::string source;          // RUN_DIR of the learned chain
  std::string env;             // the env to transfer to
  std::string skill = "Ball";  // the top skill the task acts through
  int64_t steps = -1;          // task env steps (-1: the config's task budget)
  RunFlags run;                // --dir, --set, --quiet, --resume, --actors, --shards
};

void AddTransferCommand(CLI::App& app, int* exit_code);
int RunTransfer(const TransferFlags& flags);

}  // namespace coins
