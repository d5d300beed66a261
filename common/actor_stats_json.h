// The final ActorStats of an actor as a JSON file (`coins-actor --stats-out FILE`): written by the
// actor as it exits, read back by `coins run` for an actor whose final report did not reach it
// over DDS (a short run can end before every watcher has matched the actor's writer).
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "common/status.h"
#include "idl/status.h"

namespace coins {

// the counters of `s` that a final report carries (ids, steps, episodes, batches, transitions,
// checksum, retries, rejections, env errors, clipped goals, the detector's counts)
nlohmann::json ActorStatsJson(const msg::ActorStats& s);
// reads a file ActorStatsJson wrote; an error names the file and what is missing or malformed
Result<msg::ActorStats> ReadActorStatsFile(const std::string& path);

}  // namespace coins
