// coins-detect: the `detect` command on its own (the `coins` executable adds the same command).
#include <CLI/CLI.hpp>

#include "learner/detect/detect_cli.h"

int main(int argc, char** argv) {
  CLI::App app{"coins interaction detector"};
  app.require_subcommand(1);
  coins::detector::AddDetectCommand(app);
  CLI11_PARSE(app, argc, argv);
  return 0;
}
