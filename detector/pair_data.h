// The inputs of one (source a, target b) pair, encoded for the passive and active models.
//
// A PairLayout is fitted once on training data and then encodes any TransitionSet the same
// way (the learner keeps it beside the models). Encoding, per sample (one transition, or one
// (transition, instance) for a multi-instance target class, whose instances share the models):
//   passive input  s_b normalised to [-1, 1] by the factor bounds          (target_features)
//   active input   [source; s_b; relative]                                 (active_input_dim)
//     source   = the primitive action (one-hot when discrete, normalised when continuous)
//                for source "Action"; else s_a normalised, plus the action when
//                options.source_action (the source's "velocity", as the paper does for
//                gripper->block)
//     relative = [(s_a - s_b) / r, (s_a' - s_b) / r] on the position features both share by
//                name (s_a' the source's next state: the paddle moves before the ball), r = the
//                proximity distance when the pair has one (so that pixels matter), else the
//                half range of b's feature
//   target         the change s_b' - s_b of the modelled features, divided by 1.5 * q and
//                  clipped to [-1, 1] (tanh range); q = options.delta_quantile quantile of
//                  the non-zero |change| of that feature in the fit data
// Modelled features are those that change somewhere in the fit data; constant ones carry no
// evidence either way and are left out of the log-likelihoods. close = the L1 distance of the
// shared positions is <= options.close_distance both in s and in s' (always 1 when the pair
// shares no position or the distance is <= 0). All matrices are features x samples.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "common/env_spec.h"
#include "common/status.h"
#include "detector/options.h"
#include "detector/transitions.h"

namespace coins::detector {

struct PairLayout {
  std::string source, target;  // factor names; source "Action" means the primitive action
  bool source_is_action = false;
  int source_factor = -1;  // index in the spec (-1 for the action)
  int target_factor = -1;
  int source_offset = 0, source_features = 0;
  int target_offset = 0, target_features = 0, instances = 1;
  bool multi_instance = false;
  bool source_action = false;  // the action is appended to a factor source
  envs::ActionSpec action;
  std::vector<float> source_low, source_high, target_low, target_high;
  std::vector<std::string> target_feature_names;
  std::vector<std::pair<int, int>> positions;  // (source feature, target feature) pairs
  std::vector<int> dims;                       // modelled target features
  std::vector<float> scale;                    // per modelled feature: 1.5 * change quantile (env units)
  float close_distance = 0.0f;

  int action_input_dim() const { return action.discrete ? action.n : action.dim; }
  int source_input_dim() const;
  int passive_input_dim() const { return target_features; }
  int relative_dim() const { return 2 * int(positions.size()); }
  int active_input_dim() const { return source_input_dim() + target_features + relative_dim(); }
  int output_dim() const { return int(dims.size()); }
  bool has_proximity() const { return !positions.empty() && close_distance > 0.0f; }
  // the divisor r of relative position p
  float relative_scale(int p) const {
    const int ib = positions[p].second;
    return has_proximity() ? close_distance : 0.5f * (target_high[ib] - target_low[ib]);
  }
  // the unit of target feature k in the mask test (eq. 10): half its range, except that the
  // position features of the target (x, y, z) share the largest of their half ranges, so that a
  // millimetre counts the same along every axis (a pushed block's height range is a fifth of its
  // x range: per-axis units made the millimetre it sinks under a pressing fingertip outweigh the
  // centimetres it slides, and the block skill was asked for heights)
  float mask_unit(int k) const;
};

// errors on unknown factor names, a multi-instance source, or source == target
Result<PairLayout> FitPairLayout(const envs::EnvSpec& spec, const TransitionSet& data, const std::string& source,
                                 const std::string& target, const DetectorOptions& options);

struct PairSamples {
  Eigen::MatrixXf passive_in;       // passive_input_dim x M
  Eigen::MatrixXf active_in;        // active_input_dim x M
  Eigen::MatrixXf target;           // output_dim x M, scaled change in [-1, 1]
  std::vector<int64_t> transition;  // M: the transition of each sample
  std::vector<int> instance;        // M: the instance of each sample
  std::vector<uint8_t> close;       // M: proximity (1 when the pair has none)
  int64_t size() const { return int64_t(transition.size()); }
};

// one transition's arrays (state and next_state of the layout's state space)
struct PairTransition {
  std::span<const float> state, action, next_state;
};
// Encodes one sample: the source block and relative positions from `src`, the target (instance)
// from `tgt` (the same transition, or another one's source for a counterfactual). Writes the
// passive input, active input and target columns; returns whether a and b are close.
bool EncodeSample(const PairLayout& layout, const PairTransition& src, const PairTransition& tgt, int instance,
                  float* passive, float* active, float* target);

// Encodes data. Multi-instance targets: every changed instance of every transition plus
// options.static_instances_per_step unchanged ones drawn with seed (all_instances: every one).
PairSamples EncodePairs(const PairLayout& layout, const TransitionSet& data, const DetectorOptions& options,
                        bool all_instances, uint64_t seed);

}  // namespace coins::detector
