// SystemConfig: every section of a coins config (dds, run, actor, replay, learner, detector,
// orchestrator) in one struct, as `coins run` and the orchestrator load it. The detector section
// is the learner's LearnerOptions::detector.
#pragma once

#include <filesystem>
#include <vector>

#include "actors/actor_options.h"
#include "common/config/config.h"
#include "common/dds/dds_options.h"
#include "common/run_options.h"
#include "learner/learner_options.h"
#include "orchestrator/chain_store.h"
#include "orchestrator/config_values.h"
#include "orchestrator/orchestrator_options.h"
#include "replay/replay_options.h"

namespace coins {

struct SystemConfig {
  DdsOptions dds;
  RunOptions run;
  ActorOptions actor;
  ReplayOptions replay;
  LearnerOptions learner;
  OrchestratorOptions orchestrator;

  // the sections bound to this struct's fields (the struct outlives them)
  std::vector<ConfigSection> Sections(bool with_dds = true);
  ConfigLoader Loader() { return ConfigLoader(Sections()); }
  ConfigValues Values() { return FlattenConfig(Sections()); }
};

// the chain store of a run directory for config c, reading files written before newer keys
chain::ChainStore OpenChainStore(const std::filesystem::path& run_dir, SystemConfig& c);

}  // namespace coins
