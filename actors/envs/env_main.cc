// coins-env: the `env` commands on their own (the `coins` executable adds the same commands).
#include <CLI/CLI.hpp>

#include "actors/envs/env_cli.h"

int main(int argc, char** argv) {
  CLI::App app{"coins environments"};
  app.require_subcommand(1);
  coins::envs::AddEnvCommands(app);
  CLI11_PARSE(app, argc, argv);
  return 0;
}
