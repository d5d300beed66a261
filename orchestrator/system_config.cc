#include "orchestrator/system_config.h"

namespace coins {

std::vector<ConfigSection> SystemConfig::Sections(bool with_dds) {
  std::vector<ConfigSection> s;
  if (with_dds) s.push_back(ConfigSection::Of("dds", dds));
  s.push_back(ConfigSection::Of("run", run));
  s.push_back(ConfigSection::Of("actor", actor));
  s.push_back(ConfigSection::Of("replay", replay));
  s.push_back(ConfigSection::Of("learner", learner));
  s.push_back(ConfigSection::Of("detector", learner.detector));
  s.push_back(ConfigSection::Of("orchestrator", orchestrator));
  return s;
}

chain::ChainStore OpenChainStore(const std::filesystem::path& run_dir, SystemConfig& c) {
  chain::ChainStore store(run_dir / "chain", ChainFingerprint(c.Values()));
  store.AcceptKeysAddedSince(ChainFingerprint(SystemConfig{}.Values()));
  return store;
}

}  // namespace coins
