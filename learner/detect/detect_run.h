// RunDetect: the work behind `coins detect`, callable without the command line.
//
// Collects data from the env with the chosen policy, trains the passive and active models of
// source -> b for every uncontrolled target b (every factor but the action, the source, Done
// and Reward, unless targets are given), scores them on the collected data and, with eval,
// measures detections against the simulator's labels on a fresh data set (another seed).
// With granger, the linear Granger test runs on the same data for the same pairs; with
// screen_alpha it runs first and decides which targets get neural models ("screened": true).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/status.h"
#include "detector/options.h"

namespace coins::detector {

struct DetectRequest {
  std::string env;
  std::string source;
  std::string policy = "random";
  int64_t steps = 20000;
  uint64_t seed = 1;
  std::vector<std::string> targets;  // empty: every uncontrolled target
  bool eval = false;
  int64_t eval_steps = 0;  // 0: same as steps
  bool granger = false;
  // > 0: run the linear Granger test first and skip the neural models of targets whose p-value
  // is >= screen_alpha (a fast screen; it can drop true links, see README)
  double screen_alpha = 0.0;
  int granger_window = 1;
  // the last holdout fraction of the data is not trained on; scores, masks and goal sets are
  // computed on it (0: train and score on all the data, as the paper does)
  double holdout = 0.2;
  DetectorOptions options;
  bool paper_sizes = false;  // the paper's network sizes for the pairs it names
  Status Validate() const;
};

// the report: {"env", "source", "steps", "policy", "collect_seconds", "targets": [...],
// "granger": [...] (with granger)}; every target has "target", "score", "mg_score",
// "interactions", "mask", "mask_diff", "features", "goal_set", "goal_kind", "pass",
// "train_seconds", "score_seconds", and with eval "fp_per_state", "fn_per_interaction" (null
// when the env does not label the pair), "true_interactions", "false_positives",
// "false_negatives", "eval_states"
Result<nlohmann::json> RunDetect(const DetectRequest& request);

// the human-readable table of a report
std::string FormatDetectTable(const nlohmann::json& report);

}  // namespace coins::detector
