// How `coins run` decides what to run: a fresh run from a config file and flags, or the resume
// of a stopped or crashed run from its directory (`--resume RUN_DIR`).
//
// Run directory layout: config.yaml (the effective config), logs/, chain/ (the orchestrator's
// chain.json and chain-epoch-N.json), replay/ (shard snapshots, the default
// replay.snapshot_dir), checkpoints/ (the learner's learner-epoch-N/), metrics.csv,
// metrics.jsonl, eval.csv, *.png, summary.json, final.gif.
//
// Fresh: the config file, the flags and --set overrides; replay.snapshot_dir defaults to
// RUN_DIR/replay. The previous run's chain/, replay/ (the default one) and checkpoints/ in the same
// directory are removed, so that nothing of it is resumed by mistake (said on one line).
// Resume: RUN_DIR/config.yaml, then the flags and overrides; any change of a key the chain
// depends on (config_values.h: all but the operational keys), through --config or an override,
// is refused with one line naming the key. The run continues from the newest complete epoch
// whose chain-epoch-N.json loads. Its actors count env steps on from the epoch's (split among
// them), so the chain's step bases, budgets and pacing go on where they stopped.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/status.h"
#include "orchestrator/launcher.h"
#include "orchestrator/run_roles.h"
#include "orchestrator/system_config.h"

namespace coins {

struct RunPlan {
  std::string effective;           // the effective config (YAML), written to RUN_DIR/config.yaml
  int64_t resume_epoch = -1;       // >= 0: resuming this epoch
  uint64_t resume_env_steps = 0;   // the run's env steps at that epoch: the actors count on from it
  bool resuming = false;           // --resume: the run directory's state is kept
  RunRoles roles;                  // what this host runs
  std::vector<std::string> notes;  // lines to print before the run starts
};

// fills c and plan, or returns the one-line reason the run cannot start
Status PrepareRun(const RunFlags& flags, SystemConfig& c, RunPlan* plan);
// fresh runs: removes the previous run's chain, default snapshot and checkpoint directories
// (of the roles this host runs: orchestrator chain/, learner checkpoints/, replay the snapshots)
Status ClearPreviousRun(const SystemConfig& c, const RunRoles& roles, RunPlan* plan);

}  // namespace coins
