// A config's flat view ("section.key" -> value text) and the comparisons built on it: whether a
// persisted chain state or a resumed run belongs to this config, and which key differs. Plain
// C++ (no DDS), shared by the chain store, the orchestrator and `coins run --resume`.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "common/config/config.h"

namespace coins {

// "section.key" -> the value as text, for every field of the sections
using ConfigValues = std::map<std::string, std::string>;
ConfigValues FlattenConfig(const std::vector<ConfigSection>& sections);

// keys that may change between a run and its resume without changing what the chain means:
// dds.*, run.dir/steps/actors/max_restarts, *.status_period_s, checkpoint periods, snapshot
// placement and retention, per-actor step counts, how long the learner waits for a shard
bool IsOperationalKey(const std::string& key);
// the values a chain state depends on: every key that is not operational
ConfigValues ChainFingerprint(const ConfigValues& all);
// a short stable hash of the values (16 hex digits)
std::string HashConfig(const ConfigValues& values);
// the first key whose value differs, as "KEY is A here, B in WHERE" (or "" when none differs);
// a key missing on one side counts as differing
std::string FirstDifference(const ConfigValues& here, const ConfigValues& there, const std::string& where);

}  // namespace coins
