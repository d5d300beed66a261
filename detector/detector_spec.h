// DetectorSpec: what a receiver of a detector's weights needs besides the blob: the fitted
// PairLayout (over the pair's compact state, detector/pair_space.h), the gather indices from the
// full state, and the options of the interaction test. Travels as JSON in PolicyWeights.spec
// (name "detector/<source>-><target>"), and sits beside the blob in learner checkpoints.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "common/status.h"
#include "detector/options.h"
#include "detector/pair_data.h"

namespace coins::detector {

struct DetectorSpec {
  PairLayout layout;
  DetectorOptions options;
  std::vector<int> gather;  // compact feature i = full state[gather[i]]
  int full_state_dim = 0;
};

nlohmann::json ToJson(const DetectorSpec& spec);
Result<DetectorSpec> DetectorSpecFromJson(const nlohmann::json& j);
Result<DetectorSpec> ParseDetectorSpec(const std::string& text);

// "detector/Paddle->Ball"
std::string DetectorWeightsName(const std::string& source, const std::string& target);

}  // namespace coins::detector
