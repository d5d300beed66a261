// coins-replay-cli: the replay commands of `coins` as a standalone tool (replay/replay_cli.h).
#include <CLI/CLI.hpp>

#include "replay/replay_cli.h"

int main(int argc, char** argv) {
  CLI::App app("coins replay tools", "coins-replay-cli");
  app.require_subcommand(1);
  coins::AddReplayCommands(app);
  CLI11_PARSE(app, argc, argv);
  return 0;
}
