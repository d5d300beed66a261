// PolicyWeights messages (idl/weights.idl): how the learner makes them and how every receiver
// checks them before use. The checksum is the CRC-32 of the spec text followed by the blob.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "common/status.h"
#include "idl/weights.h"

namespace coins::policy {

uint32_t WeightsChecksum(const std::string& spec, std::span<const uint8_t> blob);

msg::PolicyWeights MakeWeights(const std::string& name, uint64_t version, uint64_t learner_step,
                               const std::string& spec, std::vector<uint8_t> blob);

// schema, checksum and a version newer than `current` (0: none held); the error names the
// weights and what is wrong
Status CheckWeights(const msg::PolicyWeights& w, uint64_t current_version);

}  // namespace coins::policy
