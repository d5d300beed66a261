#include "detector/options.h"

namespace coins::detector {

const char* MaskRuleName(MaskRule r) {
  return r == MaskRule::kRelative ? "relative" : "absolute";
}

Status DetectorOptions::Validate() const {
  auto check_sizes = [](const std::vector<int>& h, const char* name) -> Status {
    if (h.empty()) return Errorf("{} needs at least one hidden layer", name);
    for (int v : h) {
      if (v <= 0) return Errorf("{}: layer sizes must be positive, got {}", name, v);
    }
    return Status::Ok();
  };
  COINS_RETURN_IF_ERROR(check_sizes(passive_hidden, "passive_hidden"));
  COINS_RETURN_IF_ERROR(check_sizes(active_hidden, "active_hidden"));
  if (!(lr > 0.0f)) return Errorf("lr must be positive, got {}", lr);
  if (passive_steps <= 0 || active_steps <= 0) {
    return Errorf("training steps must be positive, got {} and {}", passive_steps, active_steps);
  }
  if (passive_hard_steps < 0) return Errorf("passive_hard_steps must be >= 0, got {}", passive_hard_steps);
  if (passive_hard_lambda < 0.0f) return Errorf("passive_hard_lambda must be >= 0, got {}", passive_hard_lambda);
  if (batch <= 0) return Errorf("batch must be positive, got {}", batch);
  if (clip_norm < 0.0f) return Errorf("clip_norm must be >= 0, got {}", clip_norm);
  if (!(min_std > 0.0f)) return Errorf("min_std must be positive, got {}", min_std);
  if (!(delta_quantile > 0.0f && delta_quantile <= 1.0f)) {
    return Errorf("delta_quantile must be in (0, 1], got {}", delta_quantile);
  }
  if (lambda < 0.0f) return Errorf("lambda must be >= 0, got {}", lambda);
  if (static_instances_per_step < 0) {
    return Errorf("static_instances_per_step must be >= 0, got {}", static_instances_per_step);
  }
  if (min_interactions < 1) return Errorf("min_interactions must be >= 1, got {}", min_interactions);
  if (counterfactual_draws < 0) return Errorf("counterfactual_draws must be >= 0, got {}", counterfactual_draws);
  if (!(eps_eta > 0.0f)) return Errorf("eps_eta must be positive, got {}", eps_eta);
  if (!(eps_eta_relative > 0.0f && eps_eta_relative < 1.0f)) {
    return Errorf("eps_eta_relative must be in (0, 1), got {}", eps_eta_relative);
  }
  if (!(goal_dedup > 0.0f)) return Errorf("goal_dedup must be positive, got {}", goal_dedup);
  if (n_disc < 1) return Errorf("n_disc must be >= 1, got {}", n_disc);
  if (!(goal_min_fraction >= 0.0f && goal_min_fraction < 1.0f)) {
    return Errorf("goal_min_fraction must be in [0, 1), got {}", goal_min_fraction);
  }
  return Status::Ok();
}

DetectorOptions DefaultDetectorOptions(const std::string& env_name, bool paper_sizes,
                                       const std::string& source, const std::string& target) {
  DetectorOptions o;
  const bool pushing = env_name.rfind("pushing", 0) == 0;
  // Breakout: 10 px, not 7: with pre-move positions a bounce is up to 9.5 px away (README)
  o.close_distance = pushing ? 0.13f : 10.0f;
  if (paper_sizes) {
    // coins-method.md: the sizes of the paper's own implementation
    if (source == "Action" && target == "Paddle") o.active_hidden = {256, 256};
    if (source == "Paddle" && target == "Ball") o.active_hidden = {512, 256, 256, 128, 128};
    if (source == "Action" && target == "Gripper") o.active_hidden = {256, 256, 128, 128};
    if (source == "Gripper" && target == "Block") o.active_hidden = {512, 512, 512};
    o.passive_hidden = o.active_hidden;
  }
  return o;
}

}  // namespace coins::detector
