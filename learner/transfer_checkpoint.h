// The learner side of `coins transfer` (orchestrator/transfer.h): the checkpoint a transfer run's
// learner starts from. It holds the source run's trained skills and link detectors, checked to fit
// the target env and otherwise untouched, and nothing else (no task level, no job bookkeeping),
// so the transfer run trains a new task policy over frozen skills: the learner only ever trains
// the level of its current job, and the transfer's job is the task. From a run without a chain
// (the vanilla baseline) it holds that run's task policy instead, which the new run fine-tunes.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "common/env_spec.h"
#include "common/status.h"
#include "idl/control.h"
#include "learner/learner_options.h"

namespace coins {

struct TransferSkills {
  std::string source_checkpoint;  // the checkpoint the skills came from
  struct Level {
    int level = 0;
    std::string name;
    uint32_t acting_checksum = 0;  // of the acting weights, as PolicyWeights carries it
  };
  std::vector<Level> levels;
};

// loads the newest learner checkpoint of source_run (trained in `trained`), keeps the skills of
// `links` (LearnerCore::KeepSkillsFor), or with no links the task policy to fine-tune
// (LearnerCore::KeepTaskFor), and writes them to out_dir. Errors say what does not fit.
Result<TransferSkills> WriteTransferCheckpoint(const std::string& source_run, const envs::EnvSpec& trained,
                                               const envs::EnvSpec& target, const LearnerOptions& options,
                                               const std::vector<msg::LinkSpec>& links, const std::string& out_dir);

nlohmann::json ToJson(const TransferSkills& s);

}  // namespace coins
