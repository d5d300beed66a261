#include "detector/detector_spec.h"

#include <nlohmann/json.hpp>

namespace coins::detector {

namespace {

nlohmann::json LayoutJson(const PairLayout& L) {
  nlohmann::json pos = nlohmann::json::array();
  for (const auto& [a, b] : L.positions) pos.push_back({a, b});
  return {{"source", L.source},
          {"target", L.target},
          {"source_is_action", L.source_is_action},
          {"source_factor", L.source_factor},
          {"target_factor", L.target_factor},
          {"source_offset", L.source_offset},
          {"source_features", L.source_features},
          {"target_offset", L.target_offset},
          {"target_features", L.target_features},
          {"instances", L.instances},
          {"multi_instance", L.multi_instance},
          {"source_action", L.source_action},
          {"action",
           {{"discrete", L.action.discrete},
            {"n", L.action.n},
            {"dim", L.action.dim},
            {"low", L.action.low},
            {"high", L.action.high}}},
          {"source_low", L.source_low},
          {"source_high", L.source_high},
          {"target_low", L.target_low},
          {"target_high", L.target_high},
          {"target_feature_names", L.target_feature_names},
          {"positions", pos},
          {"dims", L.dims},
          {"scale", L.scale},
          {"close_distance", L.close_distance}};
}

PairLayout ReadLayout(const nlohmann::json& j) {
  PairLayout L;
  L.source = j.at("source").get<std::string>();
  L.target = j.at("target").get<std::string>();
  L.source_is_action = j.at("source_is_action").get<bool>();
  L.source_factor = j.at("source_factor").get<int>();
  L.target_factor = j.at("target_factor").get<int>();
  L.source_offset = j.at("source_offset").get<int>();
  L.source_features = j.at("source_features").get<int>();
  L.target_offset = j.at("target_offset").get<int>();
  L.target_features = j.at("target_features").get<int>();
  L.instances = j.at("instances").get<int>();
  L.multi_instance = j.at("multi_instance").get<bool>();
  L.source_action = j.at("source_action").get<bool>();
  const auto& a = j.at("action");
  L.action.discrete = a.at("discrete").get<bool>();
  L.action.n = a.at("n").get<int>();
  L.action.dim = a.at("dim").get<int>();
  L.action.low = a.at("low").get<std::vector<float>>();
  L.action.high = a.at("high").get<std::vector<float>>();
  L.source_low = j.at("source_low").get<std::vector<float>>();
  L.source_high = j.at("source_high").get<std::vector<float>>();
  L.target_low = j.at("target_low").get<std::vector<float>>();
  L.target_high = j.at("target_high").get<std::vector<float>>();
  L.target_feature_names = j.at("target_feature_names").get<std::vector<std::string>>();
  for (const auto& p : j.at("positions")) L.positions.emplace_back(p.at(0).get<int>(), p.at(1).get<int>());
  L.dims = j.at("dims").get<std::vector<int>>();
  L.scale = j.at("scale").get<std::vector<float>>();
  L.close_distance = j.at("close_distance").get<float>();
  return L;
}

}  // namespace

nlohmann::json ToJson(const DetectorSpec& s) {
  return {{"kind", "detector"},
          {"layout", LayoutJson(s.layout)},
          {"options", OptionsJson(s.options)},
          {"gather", s.gather},
          {"full_state_dim", s.full_state_dim}};
}

Result<DetectorSpec> DetectorSpecFromJson(const nlohmann::json& j) {
  DetectorSpec s;
  try {
    if (j.at("kind").get<std::string>() != "detector") return Errorf("detector spec: kind is not 'detector'");
    s.layout = ReadLayout(j.at("layout"));
    Result<DetectorOptions> options = OptionsFromJson(j.at("options"));
    if (!options.ok()) return options.status().WithContext("detector spec");
    s.options = *options;
    s.gather = j.at("gather").get<std::vector<int>>();
    s.full_state_dim = j.at("full_state_dim").get<int>();
  } catch (const nlohmann::json::exception& e) {
    return Errorf("detector spec: {}", e.what());
  }
  COINS_RETURN_IF_ERROR(s.options.Validate().WithContext("detector spec"));
  for (int g : s.gather)
    if (g < 0 || g >= s.full_state_dim) return Errorf("detector spec: gather index {} outside the state", g);
  const PairLayout& L = s.layout;
  const int compact = int(s.gather.size());
  if (L.target_offset + L.instances * L.target_features > compact ||
      (!L.source_is_action && L.source_offset + L.source_features > compact) || L.dims.size() != L.scale.size())
    return Errorf("detector spec {}->{}: layout does not fit its {} gathered features", L.source, L.target, compact);
  return s;
}

Result<DetectorSpec> ParseDetectorSpec(const std::string& text) {
  nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return Errorf("detector spec: not valid JSON");
  return DetectorSpecFromJson(j);
}

std::string DetectorWeightsName(const std::string& source, const std::string& target) {
  return "detector/" + source + "->" + target;
}

}  // namespace coins::detector
