// coins: the command-line front of the system.
//   coins run       start a whole run on this machine
//   coins monitor   live table of a run, from any machine in the DDS domain
//   coins bench     print a benchmark's figures
//   coins env       list, roll out and render environments
#include <filesystem>
#include <iostream>

#include <unistd.h>

#include <CLI/CLI.hpp>

#if __has_include("actors/envs/env_cli.h")
#include "actors/envs/env_cli.h"
#define COINS_HAVE_ENV_CLI 1
#endif
#include "orchestrator/child_process.h"
#include "orchestrator/launcher.h"
#include "orchestrator/monitor.h"

namespace coins {
namespace {

// `coins bench NAME [ARGS...]` runs the coins-bench-NAME executable beside this one
void AddBenchCommand(CLI::App& app, int* exit_code) {
  auto name = std::make_shared<std::string>();
  auto args = std::make_shared<std::vector<std::string>>();
  CLI::App* bench = app.add_subcommand("bench", "Run a benchmark and print its figures (name value unit; --json for JSON).");
  bench->add_option("name", *name, "benchmark: transport, env, nn, ...")->required();
  bench->add_option("args", *args, "arguments passed to the benchmark (e.g. --json)");
  bench->allow_extras();
  bench->prefix_command();
  bench->callback([bench, name, args, exit_code] {
    std::string path = SelfDirectory() + "/coins-bench-" + *name;
    if (access(path.c_str(), X_OK) != 0) {
      std::string known;
      for (const auto& e : std::filesystem::directory_iterator(SelfDirectory())) {
        std::string f = e.path().filename().string();
        if (f.rfind("coins-bench-", 0) == 0) known += (known.empty() ? "" : ", ") + f.substr(12);
      }
      std::cerr << "coins bench: unknown benchmark '" << *name << "' (known: " << known << ")\n";
      *exit_code = 2;
      return;
    }
    std::vector<std::string> all = *args;
    for (const auto& extra : bench->remaining()) all.push_back(extra);
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
  coins::AddMonitorCommand(app, &exit_code);
  coins::AddBenchCommand(app, &exit_code);
#ifdef COINS_HAVE_ENV_CLI
  coins::envs::AddEnvCommands(app);
#endif
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  return exit_code;
}
