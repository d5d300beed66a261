// Checkpoint epochs (orchestrator/README.md): the orchestrator cuts epoch N by sending Control
// CHECKPOINT with argument N and command_id CheckpointCommandId(N); shards acknowledge through
// ReplayStats.last_snapshot_command and the learner through LearnerStatus.checkpoint_command.
// The id is a function of the epoch so that a process resuming epoch N (`--resume-epoch N`)
// finds its own files of that epoch (a shard's snapshot records the command id). Checkpoint ids
// lie above the time-based ids `coins snapshot` uses, and grow with the epoch.
#pragma once

#include <cstdint>

namespace coins {

inline constexpr uint64_t kCheckpointCommandBase = uint64_t(1) << 62;

inline uint64_t CheckpointCommandId(uint64_t epoch) { return kCheckpointCommandBase + epoch; }
inline bool IsCheckpointCommand(uint64_t command_id) { return command_id > kCheckpointCommandBase; }
inline uint64_t CheckpointEpochOf(uint64_t command_id) {
  return IsCheckpointCommand(command_id) ? command_id - kCheckpointCommandBase : 0;
}

}  // namespace coins
