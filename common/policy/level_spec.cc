#include "common/policy/level_spec.h"

#include <cmath>

#include <nlohmann/json.hpp>

namespace coins::policy {

namespace {

template <typename Enum, size_t N>
Result<Enum> EnumByName(const char* what, const std::string& name, const Enum (&all)[N], const char* (*to_name)(Enum)) {
  for (Enum e : all)
    if (name == to_name(e)) return e;
  return Errorf("unknown {} '{}'", what, name);
}

constexpr GoalKind kGoalKinds[] = {GoalKind::kNone, GoalKind::kDiscrete, GoalKind::kContinuous};
constexpr ActionKind kActionKinds[] = {ActionKind::kPrimitiveDiscrete, ActionKind::kPrimitiveContinuous,
                                       ActionKind::kChildDiscrete, ActionKind::kChildContinuous,
                                       ActionKind::kChildOffsets};

bool AllFiniteValues(const std::vector<float>& v) {
  for (float x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

}  // namespace

const char* GoalKindName(GoalKind k) {
  switch (k) {
    case GoalKind::kNone: return "none";
    case GoalKind::kDiscrete: return "discrete";
    case GoalKind::kContinuous: return "continuous";
  }
  return "?";
}

const char* ActionKindName(ActionKind k) {
  switch (k) {
    case ActionKind::kPrimitiveDiscrete: return "primitive-discrete";
    case ActionKind::kPrimitiveContinuous: return "primitive-continuous";
    case ActionKind::kChildDiscrete: return "child-discrete";
    case ActionKind::kChildContinuous: return "child-continuous";
    case ActionKind::kChildOffsets: return "child-offsets";
  }
  return "?";
}

void GoalSpace::Achieved(const float* state, float* out) const {
  for (size_t i = 0; i < masked.size(); ++i) out[i] = state[offset + masked[i]];
}

bool GoalSpace::Reached(const float* achieved, const float* goal) const {
  float d = 0.0f;
  for (size_t i = 0; i < masked.size(); ++i) {
    const float e = std::abs(achieved[i] - goal[i]);
    d = norm == GoalNorm::kL1 ? d + e : std::max(d, e);
  }
  return d <= epsilon;
}

bool LevelSpec::discrete_actions() const {
  return action_kind == ActionKind::kPrimitiveDiscrete || action_kind == ActionKind::kChildDiscrete ||
         action_kind == ActionKind::kChildOffsets;
}

int LevelSpec::network_outputs() const {
  if (algorithm == "ddpg") return action_dim;
  if (algorithm == "sac") return 2 * action_dim;  // mean and log-std of each action
  const int k = atoms > 1 ? atoms : 1;
  return (dueling ? 1 + num_actions : num_actions) * k;
}

Status LevelSpec::Validate() const {
  auto bad = [&](const std::string& what) { return Errorf("level {} ({}): {}", level, name, what); };
  if (name.empty() || level < 1) return bad("needs a name and a level >= 1");
  if (obs_index.size() != obs_low.size() || obs_index.size() != obs_high.size())
    return bad("obs_index, obs_low and obs_high differ in size");
  for (size_t i = 0; i < obs_index.size(); ++i)
    if (obs_index[i] < 0 || !(obs_high[i] > obs_low[i]))
      return bad(fmt::format("observation feature {} is invalid", i));
  if (relative.size() != relative_scale.size()) return bad("relative and relative_scale differ in size");
  for (size_t k = 0; k < relative.size(); ++k) {
    const auto [a, b] = relative[k];
    if (a < 0 || b < 0 || a >= int(obs_index.size()) || b >= int(obs_index.size()) || !(relative_scale[k] > 0))
      return bad(fmt::format("relative pair {} is invalid", k));
  }
  if (goal.kind != GoalKind::kNone) {
    if (goal.mask.size() != size_t(goal.features) || goal.masked.empty())
      return bad("goal mask is empty or the wrong size");
    if (goal.scale_low.size() != goal.masked.size() || goal.scale_high.size() != goal.masked.size())
      return bad("goal scale bounds do not match the mask");
    if (goal.kind == GoalKind::kDiscrete && goal.goals.empty()) return bad("discrete goal space without goals");
    for (const auto& g : goal.goals)
      if (g.size() != goal.masked.size() || !AllFiniteValues(g))
        return bad("a discrete goal has the wrong size or a NaN");
    if (goal.kind == GoalKind::kContinuous &&
        (goal.low.size() != goal.masked.size() || goal.high.size() != goal.masked.size()))
      return bad("continuous goal bounds do not match the mask");
    if (!(goal.epsilon >= 0) || !std::isfinite(goal.epsilon)) return bad("goal epsilon must be finite and >= 0");
    if (!(goal.sample_ratio >= 0) || !std::isfinite(goal.sample_ratio))
      return bad("goal sample_ratio must be finite and >= 0");
  }
  if (discrete_actions() && num_actions < 2) return bad("a discrete level needs at least 2 actions");
  if (action_kind == ActionKind::kChildOffsets && child_offsets.size() != size_t(num_actions))
    return bad("child_offsets must have num_actions entries");
  if (action_dim < 1) return bad("action_dim must be >= 1");
  if (timeout < 1 || decision_period < 0) return bad("timeout must be >= 1 and decision_period >= 0");
  if (hold_decision && decision_period < 1) return bad("hold_decision needs a decision_period of at least 1");
  if (algorithm != "dqn" && algorithm != "ddpg" && algorithm != "sac")
    return bad("algorithm must be dqn, ddpg or sac, not '" + algorithm + "'");
  if (algorithm == "dqn" && !discrete_actions()) return bad("dqn needs discrete actions");
  if (algorithm != "dqn" && discrete_actions()) return bad(algorithm + " needs continuous actions");
  if (hidden.empty()) return bad("hidden needs at least one layer");
  for (int h : hidden)
    if (h <= 0) return bad("hidden sizes must be positive");
  if (pair.enabled() && algorithm != "dqn" && algorithm != "sac")
    return bad("a pair network needs algorithm dqn or sac");
  if (pair.enabled())
    if (Status st = nn::QNetOptions{obs_dim(), hidden, 1, activation, activation, pair}.Validate(); !st.ok())
      return bad(st.message());
  if (atoms > 1 && !(v_max > v_min)) return bad("v_max must exceed v_min");
  return Status::Ok();
}

nlohmann::json ToJson(const LevelSpec& s) {
  using nlohmann::json;
  json goal = {{"factor", s.goal.factor},
               {"offset", s.goal.offset},
               {"features", s.goal.features},
               {"mask", s.goal.mask},
               {"masked", s.goal.masked},
               {"scale_low", s.goal.scale_low},
               {"scale_high", s.goal.scale_high},
               {"kind", GoalKindName(s.goal.kind)},
               {"goals", s.goal.goals},
               {"low", s.goal.low},
               {"high", s.goal.high},
               {"epsilon", s.goal.epsilon},
               {"sample_ratio", s.goal.sample_ratio},
               {"norm", s.goal.norm == GoalNorm::kL1 ? "l1" : "linf"}};
  json rel = json::array();
  for (const auto& [a, b] : s.relative) rel.push_back({a, b});
  json j = {{"name", s.name},
            {"level", s.level},
            {"source", s.source},
            {"goal", goal},
            {"obs_index", s.obs_index},
            {"obs_low", s.obs_low},
            {"obs_high", s.obs_high},
            {"relative", rel},
            {"relative_scale", s.relative_scale},
            {"action_kind", ActionKindName(s.action_kind)},
            {"num_actions", s.num_actions},
            {"action_dim", s.action_dim},
            {"action_low", s.action_low},
            {"action_high", s.action_high},
            {"child_ratio", s.child_ratio},
            {"child_offsets", s.child_offsets},
            {"timeout", s.timeout},
            {"decision_period", s.decision_period},
            {"hold_decision", s.hold_decision},
            {"terminate_on_interaction", s.terminate_on_interaction},
            {"require_interaction", s.require_interaction},
            {"detector", s.detector},
            {"algorithm", s.algorithm},
            {"hidden", s.hidden},
            {"activation", nn::ActivationName(s.activation)},
            {"dueling", s.dueling},
            {"atoms", s.atoms},
            {"v_min", s.v_min},
            {"v_max", s.v_max},
            {"explore", s.explore}};
  if (s.pair.enabled())
    j["pair"] = {{"factor", s.pair_factor},
                 {"offset", s.pair.offset},
                 {"instances", s.pair.instances},
                 {"instance_dim", s.pair.instance_dim},
                 {"presence", s.pair.presence}};
  if (!s.pair.relative.empty()) {  // [observation row, instance row, scale, shift] per feature
    nlohmann::json& rel = j["pair"]["relative"] = nlohmann::json::array();
    for (const nn::RelativeFeature& r : s.pair.relative) rel.push_back({r.source, r.instance, r.scale, r.shift});
  }
  if (!s.pair.head.empty()) j["pair"]["head"] = s.pair.head;
  return j;
}

namespace {

// reads every field; nlohmann throws on a missing key or a wrong type, which the caller turns
// into a Status (third-party throw, wrapped where called)
LevelSpec ReadSpec(const nlohmann::json& j) {
  LevelSpec s;
  const auto& g = j.at("goal");
  s.goal.factor = g.at("factor").get<std::string>();
  s.goal.offset = g.at("offset").get<int>();
  s.goal.features = g.at("features").get<int>();
  s.goal.mask = g.at("mask").get<std::vector<float>>();
  s.goal.masked = g.at("masked").get<std::vector<int>>();
  s.goal.scale_low = g.at("scale_low").get<std::vector<float>>();
  s.goal.scale_high = g.at("scale_high").get<std::vector<float>>();
  s.goal.goals = g.at("goals").get<std::vector<std::vector<float>>>();
  s.goal.low = g.at("low").get<std::vector<float>>();
  s.goal.high = g.at("high").get<std::vector<float>>();
  s.goal.epsilon = g.at("epsilon").get<float>();
  s.goal.sample_ratio = g.value("sample_ratio", 0.0f);  // absent in weights written before it existed
  s.goal.norm = g.at("norm").get<std::string>() == "l1" ? GoalNorm::kL1 : GoalNorm::kLinf;
  s.name = j.at("name").get<std::string>();
  s.level = j.at("level").get<int>();
  s.source = j.at("source").get<std::string>();
  s.obs_index = j.at("obs_index").get<std::vector<int>>();
  s.obs_low = j.at("obs_low").get<std::vector<float>>();
  s.obs_high = j.at("obs_high").get<std::vector<float>>();
  for (const auto& p : j.at("relative")) s.relative.emplace_back(p.at(0).get<int>(), p.at(1).get<int>());
  s.relative_scale = j.at("relative_scale").get<std::vector<float>>();
  s.num_actions = j.at("num_actions").get<int>();
  s.action_dim = j.at("action_dim").get<int>();
  s.action_low = j.at("action_low").get<std::vector<float>>();
  s.action_high = j.at("action_high").get<std::vector<float>>();
  s.child_ratio = j.at("child_ratio").get<float>();
  s.child_offsets = j.at("child_offsets").get<std::vector<float>>();
  s.timeout = j.at("timeout").get<int>();
  s.decision_period = j.at("decision_period").get<int>();
  s.hold_decision = j.value("hold_decision", false);  // absent from specs written before the key
  s.terminate_on_interaction = j.at("terminate_on_interaction").get<bool>();
  s.require_interaction = j.at("require_interaction").get<bool>();
  s.detector = j.at("detector").get<std::string>();
  s.algorithm = j.at("algorithm").get<std::string>();
  s.hidden = j.at("hidden").get<std::vector<int>>();
  s.dueling = j.at("dueling").get<bool>();
  s.atoms = j.at("atoms").get<int>();
  s.v_min = j.at("v_min").get<float>();
  s.v_max = j.at("v_max").get<float>();
  s.explore = j.at("explore").get<float>();
  if (j.contains("pair")) {
    const auto& p = j.at("pair");
    s.pair_factor = p.at("factor").get<std::string>();
    s.pair.offset = p.at("offset").get<int>();
    s.pair.instances = p.at("instances").get<int>();
    s.pair.instance_dim = p.at("instance_dim").get<int>();
    s.pair.presence = p.at("presence").get<int>();
    if (p.contains("relative"))  // absent in weights written before pair relative features existed
      for (const auto& r : p.at("relative"))
        s.pair.relative.push_back({r.at(0).get<int>(), r.at(1).get<int>(), r.at(2).get<float>(), r.at(3).get<float>()});
    if (p.contains("head")) s.pair.head = p.at("head").get<std::vector<int>>();  // absent: no head layers
  }
  return s;
}

}  // namespace

Result<LevelSpec> LevelSpecFromJson(const nlohmann::json& j) {
  LevelSpec s;
  std::string goal_kind, action_kind, activation;
  try {
    s = ReadSpec(j);
    goal_kind = j.at("goal").at("kind").get<std::string>();
    action_kind = j.at("action_kind").get<std::string>();
    activation = j.at("activation").get<std::string>();
  } catch (const nlohmann::json::exception& e) {
    return Errorf("level spec: {}", e.what());
  }
  auto gk = EnumByName("goal kind", goal_kind, kGoalKinds, GoalKindName);
  if (!gk.ok()) return gk.status().WithContext("level spec");
  auto ak = EnumByName("action kind", action_kind, kActionKinds, ActionKindName);
  if (!ak.ok()) return ak.status().WithContext("level spec");
  auto act = nn::ParseActivation(activation);
  if (!act.ok()) return act.status().WithContext("level spec");
  s.goal.kind = *gk;
  s.action_kind = *ak;
  s.activation = *act;
  COINS_RETURN_IF_ERROR(s.Validate());
  return s;
}

Result<LevelSpec> ParseLevelSpec(const std::string& text) {
  nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return Errorf("level spec: not valid JSON");
  return LevelSpecFromJson(j);
}

Status CheckLevelFits(const LevelSpec& spec, const envs::EnvSpec& trained, const envs::EnvSpec& target) {
  std::vector<int> used = spec.obs_index;
  for (int k = 0; k < spec.goal.features; ++k) used.push_back(spec.goal.offset + k);
  for (int i : used) {
    const std::string was = trained.feature_name(i), is = target.feature_name(i);
    if (was != is)
      return Errorf("{} observes {} in {}, but state feature {} is {} in {}", spec.name, was, trained.name, i, is,
                    target.name);
  }
  return Status::Ok();
}

Result<GoalSpace> MakeGoalSpace(const envs::EnvSpec& spec, const std::string& factor, const std::vector<float>& mask) {
  const int f = spec.factor_index(factor);
  if (f < 0) return Errorf("env '{}' has no factor '{}'", spec.name, factor);
  const envs::FactorSpec& fs = spec.factors[size_t(f)];
  if (mask.size() != size_t(fs.features))
    return Errorf("mask of {} entries for factor '{}' with {} features", mask.size(), factor, fs.features);
  GoalSpace g;
  g.factor = factor;
  g.offset = spec.factor_offset(f);
  g.features = fs.features;
  g.mask = mask;
  for (int k = 0; k < fs.features; ++k)
    if (mask[size_t(k)] != 0.0f) {
      g.masked.push_back(k);
      g.scale_low.push_back(fs.low[size_t(k)]);
      g.scale_high.push_back(fs.high[size_t(k)]);
    }
  if (g.masked.empty()) return Errorf("the mask of factor '{}' selects no feature", factor);
  return g;
}

}  // namespace coins::policy
