// `coins run`: starts a whole run on one machine as child processes (replay shards, learner,
// orchestrator, actors), shows live progress from the DDS status topics (the chain too), restarts
// a child that crashes (run.max_restarts per child, supervisor.h), and stops every child cleanly
// on Ctrl-C, when the chain is done (exit 0), when the step budget is reached, or when a child
// cannot be kept running (saying which and why). At the end it prints a summary and writes
// metrics, learning curves and the final GIF into the run directory (run_report.h).
// `coins run --resume RUN_DIR` continues a stopped or crashed run (run_setup.h).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "common/status.h"

namespace coins {

struct RunFlags {
  std::string config;
  int64_t actors = -1;  // -1: from the config
  int64_t shards = -1;
  int64_t steps = -1;
  std::string env;
  std::string dir;
  std::string resume;  // --resume RUN_DIR: continue that run from its newest complete epoch
  std::vector<std::string> overrides;
  bool quiet = false;  // no progress lines
  // this host's share of the run (orchestrator/run_roles.h); empty: everything
  std::string roles, actor_ids, shard_ids;
  std::string command = "coins run";  // names the command in errors
};

// the flags every command that starts a run takes: --actors, --shards, --dir, --resume, --set, --quiet
void AddRunFlags(CLI::App* cmd, RunFlags* flags);
// adds the `run` subcommand to the coins CLI; its exit code goes to *exit_code
void AddRunCommand(CLI::App& app, int* exit_code);
struct SystemConfig;
// what a fresh run writes into its directory before any process starts (`coins transfer`: the
// chain and learner checkpoint it starts from); an error stops the run with exit code 2
using RunSeed = std::function<Status(const SystemConfig&)>;

// runs; returns the process exit code
int RunLocal(const RunFlags& flags, const RunSeed& seed = {});

}  // namespace coins
