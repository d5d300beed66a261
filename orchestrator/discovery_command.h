// `coins discovery-server`: runs discovery server number --index of dds.discovery_server (0 the
// primary, 1 its backup) until SIGINT/SIGTERM. The participants of a `dds.discovery: server`
// cluster find each other through it; `coins run --role discovery` starts it as a child.
#pragma once

#include <CLI/CLI.hpp>

namespace coins {

// adds the `discovery-server` subcommand; its exit code goes to *exit_code
void AddDiscoveryServerCommand(CLI::App& app, int* exit_code);

}  // namespace coins
