// `coins detect`: collect data, train the interaction detectors of one source against every
// uncontrolled target, print a table (or one JSON object with --json).
//
//   detect --env NAME --source FACTOR [--policy random|goals|FILE] --steps N [--seed S]
//          [--targets A,B] [--eval [--eval-steps M]] [--granger [--granger-window W]]
//          [--json] and model/test knobs (see --help)
//
// Bad flags and values print one line naming the flag and exit non-zero (CLI11's codes for
// parse errors, 1 for runtime errors such as an unknown env or factor).
#pragma once

#include <CLI/CLI.hpp>

namespace coins::detector {

void AddDetectCommand(CLI::App& app);

}  // namespace coins::detector
