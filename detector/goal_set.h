// Goal sets (paper section 3.4.1): the unique masked post-interaction target states.
//
// Values are deduplicated greedily in order of appearance: a value joins the first goal whose
// L1 distance (in normalised units, value / half range of its feature) is below
// options.goal_dedup. Fewer than options.n_disc goals give a discrete goal space. Rare goals
// (fewer than options.goal_min_fraction of the values) are then dropped from a discrete set,
// so that a few misdetections do not add goals; when too many goals remain the space is
// continuous and described by the per-feature bounds of all values.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Dense>

#include "detector/options.h"

namespace coins::detector {

struct GoalSet {
  enum class Kind { kEmpty, kDiscrete, kContinuous };
  Kind kind = Kind::kEmpty;
  std::vector<int> features;              // the masked features of the target (indices)
  std::vector<std::vector<float>> goals;  // discrete: the goals (env units, one per feature)
  std::vector<int> counts;                // discrete: values behind each goal
  std::vector<float> low, high;           // continuous: bounds per masked feature (env units)
  int raw_unique = 0;                     // goals before dropping rare ones
};
const char* GoalKindName(GoalSet::Kind k);

// values: features.size() x N masked post-interaction values (env units); half_range: one per
// masked feature (> 0)
GoalSet BuildGoalSet(const std::vector<int>& features, const Eigen::MatrixXf& values,
                     const std::vector<float>& half_range, const DetectorOptions& options);

}  // namespace coins::detector
