#include "common/actor_stats_json.h"

#include <fstream>

namespace coins {

nlohmann::json ActorStatsJson(const msg::ActorStats& s) {
  return {{"actor_id", s.actor_id()},
          {"env", s.env()},
          {"shard", s.shard()},
          {"steps", s.steps()},
          {"incarnation", s.incarnation()},
          {"first_step", s.first_step()},
          {"episodes", s.episodes()},
          {"batches", s.batches()},
          {"transitions_published", s.transitions_published()},
          {"payload_checksum", s.payload_checksum()},
          {"publish_retries", s.publish_retries()},
          {"weights_rejected", s.weights_rejected()},
          {"env_errors", s.env_errors()},
          {"goals_clipped", s.goals_clipped()},
          {"detector",
           {{"pair", s.detector_pair()},
            {"states", s.detector_states()},
            {"labelled", s.detector_truth()},
            {"false_positives", s.detector_fp()},
            {"missed", s.detector_fn()}}}};
}

Result<msg::ActorStats> ReadActorStatsFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) return Errorf("{}: cannot be read", path);
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (!j.is_object() || !j.contains("detector") || !j["detector"].is_object())
    return Errorf("{}: not an actor's final stats", path);
  msg::ActorStats s;
  try {
    const nlohmann::json& d = j["detector"];
    s.actor_id(j.at("actor_id").get<uint32_t>());
    s.env(j.at("env").get<std::string>());
    s.shard(j.at("shard").get<uint32_t>());
    s.steps(j.at("steps").get<uint64_t>());
    // absent from files of STATUS_SCHEMA 3 actors: 0, read as "counted from 0, no incarnation"
    s.incarnation(j.value("incarnation", uint64_t(0)));
    s.first_step(j.value("first_step", uint64_t(0)));
    s.episodes(j.at("episodes").get<uint64_t>());
    s.batches(j.at("batches").get<uint64_t>());
    s.transitions_published(j.at("transitions_published").get<uint64_t>());
    s.payload_checksum(j.at("payload_checksum").get<uint64_t>());
    s.publish_retries(j.at("publish_retries").get<uint64_t>());
    s.weights_rejected(j.at("weights_rejected").get<uint64_t>());
    s.env_errors(j.at("env_errors").get<uint64_t>());
    s.goals_clipped(j.at("goals_clipped").get<uint64_t>());
    s.detector_pair(d.at("pair").get<std::string>());
    s.detector_states(d.at("states").get<uint64_t>());
    s.detector_truth(d.at("labelled").get<uint64_t>());
    s.detector_fp(d.at("false_positives").get<uint64_t>());
    s.detector_fn(d.at("missed").get<uint64_t>());
  } catch (const nlohmann::json::exception& e) {
    return Errorf("{}: {}", path, e.what());
  }
  return s;
}

}  // namespace coins
