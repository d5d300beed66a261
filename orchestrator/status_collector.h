// StatusCollector: subscribes to the status topics (heartbeats, ActorStats, ReplayStats,
// ChainStatus) and keeps the newest sample of each process, with the time it arrived. A
// background thread takes the samples; Snapshot() copies the current view under a lock.
#pragma once

#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "common/dds/node.h"
#include "idl/status.h"

namespace coins {

struct StatusView {
  using Clock = std::chrono::steady_clock;
  template <typename T>
  struct Entry {
    T sample;
    Clock::time_point received;
  };
  std::map<std::string, Entry<msg::ProcessHeartbeat>> heartbeats;  // by process name
  std::map<uint32_t, Entry<msg::ActorStats>> actors;                // by actor id
  std::map<uint32_t, Entry<msg::ReplayStats>> shards;               // by shard id
  std::optional<Entry<msg::ChainStatus>> chain;

  // env steps of the run: the larger of what actors reported and what shards stored
  uint64_t total_steps() const;
  double total_steps_per_s() const;
};

class StatusCollector {
 public:
  // opens the readers on `node` (which must outlive the collector) and starts the thread
  static Result<std::unique_ptr<StatusCollector>> Start(dds::Node& node);
  ~StatusCollector();
  StatusView Snapshot() const;

 private:
  StatusCollector() = default;
  void Loop();

  dds::Reader<msg::ProcessHeartbeat> heartbeats_;
  dds::Reader<msg::ActorStats> actors_;
  dds::Reader<msg::ReplayStats> shards_;
  dds::Reader<msg::ChainStatus> chain_;
  mutable std::mutex mu_;
  StatusView view_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace coins
