#include "learner/transfer_checkpoint.h"

#include <algorithm>

#include <nlohmann/json.hpp>

#include "common/policy/weights_msg.h"
#include "learner/checkpoint_dirs.h"
#include "learner/learner_core.h"

namespace coins {

Result<TransferSkills> WriteTransferCheckpoint(const std::string& source_run, const envs::EnvSpec& trained,
                                               const envs::EnvSpec& target, const LearnerOptions& options,
                                               const std::vector<msg::LinkSpec>& links, const std::string& out_dir) {
  auto checkpoint = FindCheckpoint(source_run, -1);
  if (!checkpoint.ok()) return checkpoint.status();
  LearnerCore core(trained, options, 0);
  COINS_RETURN_IF_ERROR(core.LoadCheckpoint(*checkpoint));
  if (links.empty())
    COINS_RETURN_IF_ERROR(core.KeepTaskFor(target).WithContext(*checkpoint));
  else
    COINS_RETURN_IF_ERROR(core.KeepSkillsFor(target, links).WithContext(*checkpoint));
  COINS_RETURN_IF_ERROR(core.SaveCheckpoint(out_dir, 0, 0));
  TransferSkills out;
  out.source_checkpoint = *checkpoint;
  for (int L = 1; L <= std::max(1, int(links.size())); ++L) {
    const PolicyTrainer* t = core.trainer(L);
    out.levels.push_back({L, t->spec().name, policy::WeightsChecksum(ToJson(t->spec()).dump(), t->ActingBlob())});
  }
  return out;
}

nlohmann::json ToJson(const TransferSkills& s) {
  nlohmann::json levels = nlohmann::json::array();
  for (const auto& l : s.levels)
    levels.push_back({{"level", l.level}, {"name", l.name}, {"acting_checksum", l.acting_checksum}});
  return {{"source_checkpoint", s.source_checkpoint}, {"skills", levels}};
}

}  // namespace coins
