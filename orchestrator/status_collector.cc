#include "orchestrator/status_collector.h"

#include <algorithm>

#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "idl/statusPubSubTypes.h"

namespace coins {

uint64_t StatusView::total_steps() const {
  // actors report their steps; shards report what they stored. A short-lived actor's last
  // report can be missed by a late watcher, the shards' counts of stored steps cannot.
  uint64_t reported = 0, stored = 0;
  for (const auto& [id, a] : actors) reported += a.sample.steps();
  for (const auto& [id, s] : shards) stored += s.sample.inserted_transitions();
  return std::max(reported, stored);
}

double StatusView::total_steps_per_s() const {
  double r = 0;
  for (const auto& [id, a] : actors) r += a.sample.steps_per_s();
  return r;
}

Result<std::unique_ptr<StatusCollector>> StatusCollector::Start(dds::Node& node) {
  std::unique_ptr<StatusCollector> c(new StatusCollector());
  auto hb = node.MakeReader<msg::ProcessHeartbeatPubSubType>(dds::kHeartbeatTopic, dds::StatusReaderQos());
  auto ac = node.MakeReader<msg::ActorStatsPubSubType>(dds::kActorStatsTopic, dds::StatusReaderQos());
  auto sh = node.MakeReader<msg::ReplayStatsPubSubType>(dds::kReplayStatsTopic, dds::StatusReaderQos());
  auto ch = node.MakeReader<msg::ChainStatusPubSubType>(dds::kChainStatusTopic, dds::LatchedReaderQos());
  for (const Status* s : {&hb.status(), &ac.status(), &sh.status(), &ch.status()})
    if (!s->ok()) return *s;
  c->heartbeats_ = *hb;
  c->actors_ = *ac;
  c->shards_ = *sh;
  c->chain_ = *ch;
  c->thread_ = std::thread([p = c.get()] { p->Loop(); });
  return c;
}

StatusCollector::~StatusCollector() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

StatusView StatusCollector::Snapshot() const {
  std::lock_guard<std::mutex> lock(mu_);
  return view_;
}

void StatusCollector::Loop() {
  while (!stop_) {
    // the status topics are slow (about 1 Hz per process): poll them every 50 ms
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    auto now = StatusView::Clock::now();
    std::lock_guard<std::mutex> lock(mu_);
    heartbeats_.TakeAll([&](const msg::ProcessHeartbeat& s, const auto&) { view_.heartbeats[s.name()] = {s, now}; });
    actors_.TakeAll([&](const msg::ActorStats& s, const auto&) { view_.actors[s.actor_id()] = {s, now}; });
    shards_.TakeAll([&](const msg::ReplayStats& s, const auto&) { view_.shards[s.shard_id()] = {s, now}; });
    chain_.TakeAll([&](const msg::ChainStatus& s, const auto&) { view_.chain = StatusView::Entry<msg::ChainStatus>{s, now}; });
  }
}

}  // namespace coins
