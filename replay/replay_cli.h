// Replay commands of the `coins` CLI:
//   coins replay inspect SNAPSHOT [--json]   a snapshot's header, counts and integrity (exit 1
//                                            when it is corrupt or truncated)
//   coins snapshot [--config F] [--domain D] [--target replay] [--shards K] [--timeout S]
//                                            asks running shards for a snapshot now (Control
//                                            topic) and waits until K shards report it done
// Errors print one line and end with CLI::RuntimeError(code), which CLI11's App::exit turns
// into the exit code.
#pragma once

#include <CLI/CLI.hpp>

namespace coins {

void AddReplayCommands(CLI::App& app);

}  // namespace coins
