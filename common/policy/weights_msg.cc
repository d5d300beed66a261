#include "common/policy/weights_msg.h"

#include "common/nn/serialize.h"

namespace coins::policy {

uint32_t WeightsChecksum(const std::string& spec, std::span<const uint8_t> blob) {
  std::vector<uint8_t> all(spec.begin(), spec.end());
  all.insert(all.end(), blob.begin(), blob.end());
  return nn::Crc32(all);
}

msg::PolicyWeights MakeWeights(const std::string& name, uint64_t version, uint64_t learner_step,
                               const std::string& spec, std::vector<uint8_t> blob) {
  msg::PolicyWeights w;
  w.schema_version(msg::POLICY_WEIGHTS_SCHEMA);
  w.name(name);
  w.version(version);
  w.learner_step(learner_step);
  w.checksum(WeightsChecksum(spec, blob));
  w.spec(spec);
  w.blob(std::move(blob));
  return w;
}

Status CheckWeights(const msg::PolicyWeights& w, uint64_t current_version) {
  if (w.schema_version() != msg::POLICY_WEIGHTS_SCHEMA)
    return Errorf("weights '{}' v{}: schema {} (expected {})", w.name(), w.version(), w.schema_version(),
                  msg::POLICY_WEIGHTS_SCHEMA);
  if (WeightsChecksum(w.spec(), w.blob()) != w.checksum())
    return Errorf("weights '{}' v{}: checksum mismatch", w.name(), w.version());
  if (w.version() <= current_version)
    return Errorf("weights '{}' v{}: not newer than v{} held", w.name(), w.version(), current_version);
  return Status::Ok();
}

}  // namespace coins::policy
