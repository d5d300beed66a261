// Small file helpers for state that must survive a crash whole or not at all (learner
// checkpoints, the orchestrator's chain state): write to a temporary name, fsync, rename over
// the final name, fsync the directory. Errors name the path.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "common/status.h"

namespace coins {

// writes bytes to path atomically (path.tmp, fsync, rename, fsync of the directory)
Status WriteFileAtomic(const std::string& path, std::span<const uint8_t> bytes);
Status WriteFileAtomic(const std::string& path, const std::string& text);
// the whole file
Result<std::vector<uint8_t>> ReadFileBytes(const std::string& path);
Result<std::string> ReadFileText(const std::string& path);
// fsyncs a directory (after renames inside it)
Status SyncDirectory(const std::string& dir);
// moves a fully written directory `from` to `to` (replacing an existing `to`), then fsyncs the parent
Status ReplaceDirectory(const std::string& from, const std::string& to);

}  // namespace coins
