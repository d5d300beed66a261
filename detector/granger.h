// The classical (linear) Granger test of paper eqs. 1-2, as a fast first screen and as the
// baseline the neural test is compared with.
//
// For source a and each target b: the passive (restricted) model regresses s_b^{t+1} on
// [1, s_b^t, ..., s_b^{t-w+1}]; the active (unrestricted) model adds s_a^t, ..., s_a^{t-w+1}
// (the primitive action, one-hot when discrete, for source "Action"). Features are normalised
// to [-1, 1] by their bounds; constant columns and never-changing target features are dropped.
// Windows never cross episode starts. Multi-instance targets are pooled over instances (the
// changed instances of each transition plus static_instances_per_step unchanged ones).
//
// All regressions of all targets are solved at once as one sparse least-squares problem with
// SuiteSparseQR: a block-diagonal design (one restricted and one unrestricted block per
// target, rows = samples) against a dense right-hand side (one column per target feature,
// zero-padded). Per target feature k an F-test compares the residual sums of squares:
//   F_k = ((RSS_r - RSS_u) / q) / (RSS_u / (n - p_u)),  q = p_u - p_r,
// with p-value from the F(q, n - p_u) distribution; the pair's p-value is the smallest over
// features times the number of features (Bonferroni), and a causes b when it is below alpha.
#pragma once

#include <string>
#include <vector>

#include "common/env_spec.h"
#include "common/status.h"
#include "detector/transitions.h"

namespace coins::detector {

struct GrangerOptions {
  int window = 1;       // w: the history window
  double alpha = 1e-3;  // significance level of the pair test
  int static_instances_per_step = 4;
  uint64_t seed = 1;
  Status Validate() const;
};

struct GrangerResult {
  std::string source, target;
  int64_t samples = 0;
  int df1 = 0, df2 = 0;           // q and n - p_u
  double f_stat = 0.0;            // the largest F over target features
  double p_value = 1.0;           // Bonferroni-corrected smallest p-value
  bool causes = false;            // p_value < alpha
  std::string feature;            // the feature with the largest F
  std::vector<double> feature_f;  // per modelled target feature
  std::vector<std::string> feature_names;
};

// errors on unknown factors or a multi-instance source; SuiteSparse failures are errors
Result<std::vector<GrangerResult>> LinearGrangerTest(const envs::EnvSpec& spec, const TransitionSet& data,
                                                     const std::string& source, const std::vector<std::string>& targets,
                                                     const GrangerOptions& options);

// upper tail of the F(d1, d2) distribution at f (the p-value of an F statistic)
double FDistributionUpperTail(double f, double d1, double d2);

}  // namespace coins::detector
