// `coins monitor`: joins the DDS domain from any machine and shows a live table of the run:
// processes alive, actors with steps/s, shards with size and insert rate, chain status.
#pragma once

#include <CLI/CLI.hpp>

namespace coins {

// adds the `monitor` subcommand; its exit code goes to *exit_code
void AddMonitorCommand(CLI::App& app, int* exit_code);

}  // namespace coins
