// A test's own DDS reader of the weights a run's learner publishes, and the checkpointed
// checksums they must match after a restart.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "common/dds/node.h"
#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "idl/weightsPubSubTypes.h"
#include "tests/process_harness.h"

namespace coins::testing {

// the acting checksum of the level-`level` trainer in a checkpoint's state.json, when the
// checkpoint has training in it
inline std::optional<uint32_t> LevelChecksum(const nlohmann::json& state, int level) {
  if (!state.is_object() || state.value("total_updates", 0) == 0 || !state["trainers"].is_array()) return std::nullopt;
  for (const auto& t : state["trainers"])
    if (t.value("level", 0) == level) return t["acting_checksum"].get<uint32_t>();
  return std::nullopt;
}

class WeightsWatch {
 public:
  // joins `domain` before the run starts, so that it hears every publication
  static Result<WeightsWatch> Create(int domain) {
    DdsOptions dds;
    dds.domain = domain;
    auto node = dds::Node::Create(dds, "weights-watch");
    if (!node.ok()) return node.status();
    auto reader = (*node)->MakeReader<msg::PolicyWeightsPubSubType>(dds::kWeightsTopic, dds::CommandReaderQos());
    if (!reader.ok()) return reader.status();
    WeightsWatch w;
    w.node_ = std::move(*node);
    w.reader_ = *reader;
    return w;
  }

  // forgets everything heard so far (e.g. what a killed learner sent)
  void Drain() {
    reader_.TakeAll([](const msg::PolicyWeights&, const auto&) {});
  }
  // the checksum of the first weights named `name` heard from now on, within `limit`
  std::optional<uint32_t> NextChecksum(const std::string& name, std::chrono::milliseconds limit) {
    std::optional<uint32_t> first;
    WaitUntil(
        [&] {
          reader_.TakeAll([&](const msg::PolicyWeights& w, const auto&) {
            if (!first && w.name() == name) first = w.checksum();
          });
          return first.has_value();
        },
        limit);
    return first;
  }

 private:
  std::unique_ptr<dds::Node> node_;
  dds::Reader<msg::PolicyWeights> reader_;  // owned by node_
};

}  // namespace coins::testing
