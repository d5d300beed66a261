#include "detector/options.h"

#include <nlohmann/json.hpp>

namespace coins::detector {

namespace {
constexpr int64_t kMaxSteps = 100'000'000;
constexpr int64_t kMaxLayer = 8192;  // 8192 x 8192 is already 64 M weights a layer
constexpr double kBig = 1e9;
constexpr double kTiny = 1e-9;  // the lower bound of a value that must be positive
}  // namespace

const char* MaskRuleName(MaskRule r) { return r == MaskRule::kRelative ? "relative" : "absolute"; }

void DetectorOptions::Visit(ConfigVisitor& v) {
  // models
  VisitIntList(v, "passive_hidden", passive_hidden, 1, kMaxLayer, "passive model hidden layer sizes");
  VisitIntList(v, "active_hidden", active_hidden, 1, kMaxLayer, "active model hidden layer sizes");
  VisitFloat(v, "lr", lr, kTiny, 10, "Adam learning rate");
  VisitInt(v, "passive_steps", passive_steps, 1, kMaxSteps, "Adam steps of the passive model");
  VisitInt(v, "passive_hard_steps", passive_hard_steps, 0, kMaxSteps, "passive steps after the active warm start");
  VisitFloat(v, "passive_hard_lambda", passive_hard_lambda, 0, kBig, "up-weight of the passive model's own misses");
  VisitInt(v, "active_steps", active_steps, 1, kMaxSteps, "Adam steps of the active model");
  VisitInt(v, "batch", batch, 1, 1 << 20, "samples per Adam step");
  VisitFloat(v, "clip_norm", clip_norm, 0, kBig, "global gradient-norm clip (0: none)");
  VisitFloat(v, "min_std", min_std, kTiny, kBig, "minimum std (scaled-change units)");
  v.Bool("warm_start", warm_start, "the active model starts as the trained passive model");
  v.Bool("source_action", source_action, "a non-action source also sees the primitive action");
  VisitFloat(v, "delta_quantile", delta_quantile, kTiny, 1, "change scale: quantile of non-zero |change|");
  // data balancing
  VisitFloat(v, "lambda", lambda, 0, kBig, "active up-weight of close transitions with passive error");
  VisitFloat(v, "close_distance", close_distance, -1, kBig, "proximity L1 distance (0: none, -1: the env's)");
  v.Bool("upweight_needs_proximity", upweight_needs_proximity, "pairs without positions up-weight nothing");
  v.Bool("proximity_gate", proximity_gate, "the interaction test also requires proximity");
  VisitInt(v, "static_instances_per_step", static_instances_per_step, 0, 1 << 20,
           "unchanged instances sampled per step (multi-instance targets)");
  // the interaction test and scores
  VisitFloat(v, "eps_act", eps_act, -kBig, kBig, "active log-likelihood threshold");
  VisitFloat(v, "eps_pas", eps_pas, -kBig, kBig, "passive log-likelihood threshold");
  VisitFloat(v, "eps_si", eps_si, -kBig, kBig, "Sc_I threshold reported as pass");
  VisitInt(v, "min_interactions", min_interactions, 1, int64_t(kBig), "fewer detections: Sc_I = 0");
  VisitFloat(v, "chance_ratio", chance_ratio, 0, kBig,
             "detections must be more than this many times those by chance (0: off), else Sc_I = 0");
  VisitInt(v, "counterfactual_draws", counterfactual_draws, 0, 1000, "counterfactual source draws (0: off)");
  VisitFloat(v, "eps_cf", eps_cf, -kBig, kBig, "counterfactual log-likelihood margin");
  // mask and goal set
  VisitFloat(v, "eps_eta", eps_eta, kTiny, kBig, "absolute mask threshold (normalised units)");
  VisitFloat(v, "eps_eta_relative", eps_eta_relative, kTiny, 1 - 1e-6, "relative mask fraction of the largest");
  std::string rule = MaskRuleName(mask_rule);
  v.String("mask_rule", rule, {"relative", "absolute"}, "mask rule (absolute: eq. 10 literally)");
  mask_rule = rule == "absolute" ? MaskRule::kAbsolute : MaskRule::kRelative;
  VisitFloat(v, "goal_dedup", goal_dedup, kTiny, kBig, "L1 below which two goals are one (normalised)");
  VisitInt(v, "n_disc", n_disc, 1, 1 << 20, "fewer unique goals: a discrete goal space");
  VisitFloat(v, "goal_min_fraction", goal_min_fraction, 0, 1 - 1e-6, "discrete goals rarer than this are dropped");
}

Status DetectorOptions::Validate() const {
  DetectorOptions copy = *this;
  COINS_RETURN_IF_ERROR(CheckConfigRanges(copy));
  if (passive_hidden.empty()) return Errorf("passive_hidden needs at least one hidden layer");
  if (active_hidden.empty()) return Errorf("active_hidden needs at least one hidden layer");
  return Status::Ok();
}

nlohmann::json OptionsJson(const DetectorOptions& options) {
  DetectorOptions copy = options;
  nlohmann::json j = nlohmann::json::parse(ConfigJson(ConfigSection::Of("detector", copy)));
  j["seed"] = options.seed;
  return j;
}

Result<DetectorOptions> OptionsFromJson(const nlohmann::json& j) {
  if (!j.is_object()) return Errorf("detector options: not a JSON object");
  DetectorOptions o;
  nlohmann::json fields = j;
  if (auto seed = fields.find("seed"); seed != fields.end()) {
    if (!seed->is_number_unsigned()) return Errorf("detector options: seed is not an unsigned integer");
    o.seed = seed->get<uint64_t>();
    fields.erase(seed);
  }
  // JSON is YAML: the config reader checks every key, type and range
  ConfigLoader loader({ConfigSection::Of("detector", o)});
  COINS_RETURN_IF_ERROR(loader.LoadText(nlohmann::json{{"detector", fields}}.dump(), "detector options"));
  COINS_RETURN_IF_ERROR(o.Validate());
  return o;
}

float EnvCloseDistance(const std::string& env_name) {
  if (env_name.rfind("pushing", 0) == 0) return 0.13f;
  if (env_name.rfind("breakout", 0) == 0) return 10.0f;
  return 7.0f;
}

DetectorOptions DefaultDetectorOptions(const std::string& env_name, bool paper_sizes, const std::string& source,
                                       const std::string& target) {
  DetectorOptions o;
  o.close_distance = EnvCloseDistance(env_name);
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
