#include "detector/goal_set.h"

#include <algorithm>
#include <cmath>

namespace coins::detector {

const char* GoalKindName(GoalSet::Kind k) {
  switch (k) {
    case GoalSet::Kind::kDiscrete: return "discrete";
    case GoalSet::Kind::kContinuous: return "continuous";
    default: return "empty";
  }
}

GoalSet BuildGoalSet(const std::vector<int>& features, const Eigen::MatrixXf& values,
                     const std::vector<float>& half_range, const DetectorOptions& options) {
  GoalSet g;
  g.features = features;
  const int d = int(features.size());
  const int64_t n = values.cols();
  if (d == 0 || n == 0) return g;

  // greedy dedup at L1 < goal_dedup (normalised units); stop counting past a cap
  std::vector<Eigen::VectorXf> uniq;
  std::vector<int> counts;
  const size_t cap = size_t(std::max(options.n_disc, 1)) * 20;
  bool overflow = false;
  for (int64_t j = 0; j < n && !overflow; ++j) {
    bool found = false;
    for (size_t u = 0; u < uniq.size() && !found; ++u) {
      float l1 = 0.0f;
      for (int k = 0; k < d; ++k) l1 += std::abs(values(k, j) - uniq[u](k)) / half_range[k];
      if (l1 < options.goal_dedup) {
        ++counts[u];
        found = true;
      }
    }
    if (!found) {
      uniq.push_back(values.col(j));
      counts.push_back(1);
      overflow = uniq.size() > cap;
    }
  }
  g.raw_unique = int(uniq.size());

  // drop rare goals; discrete when few remain and they cover nearly all values
  const double min_count = std::max(1.0, double(options.goal_min_fraction) * double(n));
  std::vector<size_t> kept;
  int64_t covered = 0;
  for (size_t u = 0; u < uniq.size(); ++u) {
    if (counts[u] >= min_count) {
      kept.push_back(u);
      covered += counts[u];
    }
  }
  const bool discrete = !overflow && (g.raw_unique < options.n_disc ||
                                      (int(kept.size()) < options.n_disc && double(covered) >= 0.95 * double(n)));
  if (discrete) {
    g.kind = GoalSet::Kind::kDiscrete;
    // sort goals lexicographically for stable output
    std::sort(kept.begin(), kept.end(), [&](size_t a, size_t b) {
      for (int k = 0; k < d; ++k) {
        if (uniq[a](k) != uniq[b](k)) return uniq[a](k) < uniq[b](k);
      }
      return false;
    });
    for (size_t u : kept) {
      g.goals.emplace_back(uniq[u].data(), uniq[u].data() + d);
      g.counts.push_back(counts[u]);
    }
    return g;
  }
  g.kind = GoalSet::Kind::kContinuous;
  for (int k = 0; k < d; ++k) {
    g.low.push_back(values.row(k).minCoeff());
    g.high.push_back(values.row(k).maxCoeff());
  }
  return g;
}

}  // namespace coins::detector
