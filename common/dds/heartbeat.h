// Heartbeat: the ProcessHeartbeat every coins process publishes once per status period, so
// that `coins monitor` and the launcher see who is alive.
#pragma once

#include <chrono>
#include <string>

#include "common/dds/node.h"
#include "idl/status.h"

namespace coins::dds {

class Heartbeat {
 public:
  // creates the writer; the node outlives the heartbeat
  static Result<Heartbeat> Create(Node& node, const std::string& name, const std::string& role);
  void Publish(const std::string& state);

 private:
  Heartbeat(Writer<msg::ProcessHeartbeat> writer, msg::ProcessHeartbeat sample)
      : writer_(writer), sample_(std::move(sample)) {}
  Writer<msg::ProcessHeartbeat> writer_;
  msg::ProcessHeartbeat sample_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace coins::dds
