// Where a run keeps its learner checkpoints: RUN_DIR/checkpoints/learner-epoch-N/, complete when
// it holds state.json (learner_core.h writes the directory whole under a temporary name). One
// place for the names, used by coins-learner, `coins eval` and `coins transfer`.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/status.h"

namespace coins {

std::string CheckpointDir(const std::string& run_dir, uint64_t epoch);
// the epochs of the complete checkpoints, ascending (names that are not learner-epoch-N are ignored)
std::vector<int64_t> CheckpointEpochs(const std::string& run_dir);
// -1 when there is none
int64_t NewestCheckpointEpoch(const std::string& run_dir);
// the directory of `epoch` (-1: the newest); errors name the run directory and what is missing
Result<std::string> FindCheckpoint(const std::string& run_dir, int64_t epoch);
// removes all but the newest `keep` checkpoints
void PruneCheckpoints(const std::string& run_dir, int64_t keep);

}  // namespace coins
