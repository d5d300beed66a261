// DetectorOptions: every knob of the interaction detector, with the defaults of
// shared/reference/coins-method.md where it gives one (and the reason where it does not).
// Visit() lists the fields once: the config file's `detector` section and the flags of
// `coins detect` are both made from it. The seed is not a config key: a run derives it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "common/config/config.h"
#include "common/status.h"

namespace coins::detector {

// how eq. 10's per-feature mean deviation d_k (normalised units, [-1, 1] per feature bound)
// becomes the control mask
enum class MaskRule {
  kRelative,  // eta_k = d_k > eps_eta_relative * max_j d_j (default; see detector/README.md)
  kAbsolute,  // eta_k = d_k > eps_eta, the literal eq. 10
};
const char* MaskRuleName(MaskRule r);

struct DetectorOptions {
  // ---- models: conditional Gaussians over the scaled change of the target ----------------
  std::vector<int> passive_hidden = {128, 128};  // paper: 256-256 .. 512x3 (see --paper-sizes)
  std::vector<int> active_hidden = {128, 128};
  float lr = 3e-3f;                  // paper 1e-4 (with far longer training)
  int passive_steps = 4000;          // Adam steps of the passive model
  int passive_hard_steps = 4000;     // passive steps after the active model's warm start
  float passive_hard_lambda = 0.0f;  // up-weight of the passive model's own misses then
  int active_steps = 10000;          // after the warm start from the passive model
  int batch = 256;
  float clip_norm = 10.0f;       // global gradient-norm clip
  float min_std = 0.01f;         // the paper's minimum std, in scaled-change units
  bool warm_start = true;        // the active model starts as the trained passive model
  bool source_action = true;     // a non-action source also sees the primitive action
  float delta_quantile = 0.99f;  // change scale per feature: this quantile of non-zero |change|

  // ---- data balancing (appendix B) ---------------------------------------------------------
  float lambda = 100.0f;  // active up-weight of close transitions with passive error
  // L1 distance of positions (env units); 0: no proximity; < 0: the env's (EnvCloseDistance)
  float close_distance = -1.0f;
  // when true, a pair without positions (source Action) up-weights nothing: w needs "close"
  bool upweight_needs_proximity = true;
  bool proximity_gate = true;         // h_ab also requires proximity (when the pair has positions)
  int static_instances_per_step = 4;  // multi-instance targets: unchanged instances sampled

  // ---- the interaction test and scores (eqs. 7-9) -----------------------------------------
  float eps_act = 2.0f;
  float eps_pas = 0.0f;
  float eps_si = 3.0f;        // paper: 3 to 5 (5 in its runs; our scales differ)
  int min_interactions = 10;  // fewer detected interactions: Sc_I = 0 (too little evidence)
  // Sc_I = 0 too unless the detections are more than chance_ratio times those with other
  // transitions' sources in place of the real ones (PairScores::chance_interactions; 0: off).
  // An active model that learned a chance association at rare target events detects as often
  // with any source: Action->Ball, 0-2 detections against 0.3-7 by chance on 10k random steps,
  // once scored 12.1 on 11 detections and beat Action->Paddle's 4.35. True links are far above
  // chance: Action->Paddle ~1860 vs ~345, Paddle->Ball ~20 vs < 1, Gripper->Block 24 vs 3.
  float chance_ratio = 2.0f;
  // counterfactual check: h also needs ll_act(s_a, s_b) - mean_k ll_act(s_a~k, s_b) > eps_cf,
  // with s_a~k the source of other transitions (0 draws turns the check off)
  int counterfactual_draws = 3;
  float eps_cf = 2.0f;  // fewer detected interactions: Sc_I = 0 (no evidence)

  // ---- mask and goal set (eq. 10, section 3.4.1) --------------------------------------------
  float eps_eta = 0.1f;           // the absolute rule's threshold (normalised units)
  float eps_eta_relative = 0.4f;  // the relative rule's fraction of the largest deviation
  MaskRule mask_rule = MaskRule::kRelative;
  float goal_dedup = 0.01f;         // L1 in normalised units below which two goals are one (README)
  int n_disc = 10;                  // fewer unique goals: a discrete goal space
  float goal_min_fraction = 0.02f;  // discrete goals seen in fewer interactions are dropped

  uint64_t seed = 1;
  void Visit(ConfigVisitor& v);
  // the ranges of Visit and the rules between fields; the error names the field
  Status Validate() const;
};

// every option as a JSON object (the Visit keys and "seed"), and back: keys Visit does not
// know, wrong types and values out of range are errors naming the key
nlohmann::json OptionsJson(const DetectorOptions& options);
Result<DetectorOptions> OptionsFromJson(const nlohmann::json& j);

// the proximity distance of an env's positions: 10 px Breakout (with pre-move positions a
// bounce is up to 9.5 px away, README), 0.13 m pushing, 7 for any other env
float EnvCloseDistance(const std::string& env_name);

// defaults for an env and pair: the proximity distance of the env (EnvCloseDistance) and, when
// paper_sizes, the paper's network sizes for the named pairs
DetectorOptions DefaultDetectorOptions(const std::string& env_name, bool paper_sizes = false,
                                       const std::string& source = "", const std::string& target = "");

}  // namespace coins::detector
