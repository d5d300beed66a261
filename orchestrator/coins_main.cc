// coins: the command-line front of the system.
//   coins run       start a whole run on this machine
//   coins transfer  a new task policy over a run's learned skills, on another env
//   coins experiment transfer   COInS transfer against vanilla on the Breakout variants, as tables
//   coins experiment pushing    COInS against vanilla SAC on robot pushing, as a table
//   coins monitor   live table of a run, from any machine in the DDS domain
//   coins discovery-server   a DDS discovery server of a cluster
//   coins security init      the certificates and permissions of a secured run
//   coins bench     print a benchmark's figures
//   coins env       list, roll out and render environments
//   coins detect    find interactions between factors from env data
//   coins replay    inspect replay snapshots; coins snapshot asks shards for one now
#include <filesystem>
#include <iostream>

#include <unistd.h>

#include <CLI/CLI.hpp>

#include "actors/envs/env_cli.h"
#include "learner/detect/detect_cli.h"
#include "learner/eval_cli.h"
#include "orchestrator/child_process.h"
#include "orchestrator/discovery_command.h"
#include "orchestrator/experiment_command.h"
#include "orchestrator/launcher.h"
#include "orchestrator/monitor.h"
#include "orchestrator/security_command.h"
#include "orchestrator/transfer.h"
#include "replay/replay_cli.h"

namespace coins {
namespace {

// `coins bench NAME [ARGS...]` runs the coins-bench-NAME executable beside this one
void AddBenchCommand(CLI::App& app, int* exit_code) {
  auto name = std::make_shared<std::string>();
  CLI::App* bench =
      app.add_subcommand("bench", "Run a benchmark and print its figures (name value unit; --json for JSON).");
  bench->add_option("name", *name, "benchmark: transport, env, nn, ...")->required();
  bench->footer("Arguments after the name go to the benchmark, e.g. `coins bench transport --json`.");
  bench->prefix_command();
  bench->callback([bench, name, exit_code] {
    std::string path = SelfDirectory() + "/coins-bench-" + *name;
    if (access(path.c_str(), X_OK) != 0) {
      std::string known;
      for (const auto& e : std::filesystem::directory_iterator(SelfDirectory())) {
        std::string f = e.path().filename().string();
        if (f.rfind("coins-bench-", 0) == 0) known += (known.empty() ? "" : ", ") + f.substr(12);
      }
      if (known.empty())
        std::cerr << "coins bench: no benchmarks beside " << SelfDirectory()
                  << " (this build has none: configure with -DCOINS_BUILD_BENCH=ON)\n";
      else
        std::cerr << "coins bench: unknown benchmark '" << *name << "' (known: " << known << ")\n";
      *exit_code = 2;
      return;
    }
    std::vector<std::string> all = bench->remaining();
    std::vector<char*> argv = {path.data()};
    for (auto& a : all) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv(path.c_str(), argv.data());
    std::cerr << "coins bench: cannot run " << path << "\n";
    *exit_code = 1;
  });
}

}  // namespace
}  // namespace coins

int main(int argc, char** argv) {
  CLI::App app("coins: Chain of Interaction Skills over Fast DDS", "coins");
  app.require_subcommand(1);
  int exit_code = 0;
  coins::AddRunCommand(app, &exit_code);
  coins::AddTransferCommand(app, &exit_code);
  coins::AddExperimentCommand(app, &exit_code);
  coins::AddMonitorCommand(app, &exit_code);
  coins::AddDiscoveryServerCommand(app, &exit_code);
  coins::AddSecurityCommand(app, &exit_code);
  coins::AddBenchCommand(app, &exit_code);
  coins::envs::AddEnvCommands(app);
  coins::detector::AddDetectCommand(app);
  coins::AddReplayCommands(app);
  coins::AddEvalCommand(app, &exit_code);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  return exit_code;
}
