// StatusCollector: subscribes to the status topics (heartbeats, ActorStats, ReplayStats,
// ChainStatus, LearnerStatus, InteractionScores) and keeps the newest sample of each process,
// with the time it arrived. A background thread takes the samples; Snapshot() copies the current
// view under a lock. Every InteractionScores message is also queued (bounded) for TakeScores():
// each detect round's answer matters, not only the newest.
#pragma once

#include <atomic>
#include <chrono>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "common/dds/node.h"
#include "common/env_steps.h"
#include "idl/status.h"

namespace coins {

// the acting link's detector against the simulator's labels, summed over the actors that count
// it (each actor's counts start at its own start: a restarted actor's earlier ones are gone)
struct DetectorCounts {
  std::string pair;  // "Paddle->Ball"; "" when no actor counts one
  uint64_t states = 0, labelled = 0, false_positives = 0, missed = 0;
  double fp_per_state() const { return states ? double(false_positives) / double(states) : 0.0; }
  double miss_rate() const { return labelled ? double(missed) / double(labelled) : 0.0; }
};

struct StatusView {
  using Clock = std::chrono::steady_clock;
  template <typename T>
  struct Entry {
    T sample;
    Clock::time_point received;
  };
  std::map<std::string, Entry<msg::ProcessHeartbeat>> heartbeats;  // by process name
  std::map<uint32_t, Entry<msg::ActorStats>> actors;               // by actor id
  EnvStepCount env_steps;                                          // over actor restarts
  std::map<uint32_t, Entry<msg::ReplayStats>> shards;              // by shard id
  std::optional<Entry<msg::ChainStatus>> chain;
  std::optional<Entry<msg::LearnerStatus>> learner;
  uint64_t learner_reports = 0;                         // LearnerStatus samples so far
  std::optional<Entry<msg::InteractionScores>> scores;  // the newest

  // env steps of the run: the actors' reports over their restarts (the shards' stored counts
  // only before any actor reported)
  uint64_t total_steps() const;
  double total_steps_per_s() const;
  // the actors' detector counts of the newest pair any of them reports
  DetectorCounts detector() const;
};

class StatusCollector {
 public:
  // opens the readers on `node` (which must outlive the collector) and starts the thread
  static Result<std::unique_ptr<StatusCollector>> Start(dds::Node& node);
  ~StatusCollector();
  StatusView Snapshot() const;
  // the InteractionScores received since the last call, oldest first (at most kMaxQueuedScores;
  // older ones are dropped when nobody takes them)
  std::vector<msg::InteractionScores> TakeScores();
  static constexpr size_t kMaxQueuedScores = 64;
  // an actor's report that came another way than DDS (its final stats file), taken as if received
  void Report(const msg::ActorStats& s);

 private:
  StatusCollector() = default;
  void Loop();
  void Apply(const msg::ActorStats& s, StatusView::Clock::time_point now);  // under mu_

  dds::Reader<msg::ProcessHeartbeat> heartbeats_;
  dds::Reader<msg::ActorStats> actors_;
  dds::Reader<msg::ReplayStats> shards_;
  dds::Reader<msg::ChainStatus> chain_;
  dds::Reader<msg::LearnerStatus> learner_;
  dds::Reader<msg::InteractionScores> scores_;
  mutable std::mutex mu_;
  StatusView view_;
  std::deque<msg::InteractionScores> queued_scores_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace coins
