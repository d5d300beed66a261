#include "orchestrator/status_collector.h"

#include <algorithm>

#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "idl/statusPubSubTypes.h"

namespace coins {

uint64_t StatusView::total_steps() const {
  // the actors' reports. Shards store a transition per level stream (several per env step once
  // skills act), so their counts stand in only before any actor reported (a late watcher)
  if (!env_steps.empty()) return env_steps.total();
  uint64_t stored = 0;
  for (const auto& [id, s] : shards) stored += s.sample.inserted_transitions();
  return stored;
}

double StatusView::total_steps_per_s() const {
  double r = 0;
  for (const auto& [id, a] : actors) r += a.sample.steps_per_s();
  return r;
}

DetectorCounts StatusView::detector() const {
  DetectorCounts d;
  uint64_t newest_seq = 0;
  for (const auto& [id, a] : actors)
    if (!a.sample.detector_pair().empty() && a.sample.command_seq() >= newest_seq) {
      newest_seq = a.sample.command_seq();
      d.pair = a.sample.detector_pair();
    }
  for (const auto& [id, a] : actors) {
    if (d.pair.empty() || a.sample.detector_pair() != d.pair) continue;
    d.states += a.sample.detector_states();
    d.labelled += a.sample.detector_truth();
    d.false_positives += a.sample.detector_fp();
    d.missed += a.sample.detector_fn();
  }
  return d;
}

Result<std::unique_ptr<StatusCollector>> StatusCollector::Start(dds::Node& node) {
  std::unique_ptr<StatusCollector> c(new StatusCollector());
  auto hb = node.MakeReader<msg::ProcessHeartbeatPubSubType>(dds::kHeartbeatTopic, dds::StatusReaderQos());
  auto ac = node.MakeReader<msg::ActorStatsPubSubType>(dds::kActorStatsTopic, dds::StatusReaderQos());
  auto sh = node.MakeReader<msg::ReplayStatsPubSubType>(dds::kReplayStatsTopic, dds::StatusReaderQos());
  auto ch = node.MakeReader<msg::ChainStatusPubSubType>(dds::kChainStatusTopic, dds::LatchedReaderQos());
  auto le = node.MakeReader<msg::LearnerStatusPubSubType>(dds::kLearnerStatusTopic, dds::StatusReaderQos());
  auto sc = node.MakeReader<msg::InteractionScoresPubSubType>(dds::kScoresTopic, dds::StatusReaderQos());
  for (const Status* s : {&hb.status(), &ac.status(), &sh.status(), &ch.status(), &le.status(), &sc.status()})
    if (!s->ok()) return *s;
  c->heartbeats_ = *hb;
  c->actors_ = *ac;
  c->shards_ = *sh;
  c->chain_ = *ch;
  c->learner_ = *le;
  c->scores_ = *sc;
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

std::vector<msg::InteractionScores> StatusCollector::TakeScores() {
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<msg::InteractionScores> out(queued_scores_.begin(), queued_scores_.end());
  queued_scores_.clear();
  return out;
}

void StatusCollector::Apply(const msg::ActorStats& s, StatusView::Clock::time_point now) {
  view_.actors[s.actor_id()] = {s, now};
  view_.env_steps.Report(s.actor_id(), s.steps(), s.incarnation(), s.first_step());
}

void StatusCollector::Report(const msg::ActorStats& s) {
  std::lock_guard<std::mutex> lock(mu_);
  Apply(s, StatusView::Clock::now());
}

void StatusCollector::Loop() {
  while (!stop_) {
    // the status topics are slow (about 1 Hz per process): poll them every 50 ms
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    auto now = StatusView::Clock::now();
    std::lock_guard<std::mutex> lock(mu_);
    heartbeats_.TakeAll([&](const msg::ProcessHeartbeat& s, const auto&) { view_.heartbeats[s.name()] = {s, now}; });
    actors_.TakeAll([&](const msg::ActorStats& s, const auto&) { Apply(s, now); });
    shards_.TakeAll([&](const msg::ReplayStats& s, const auto&) { view_.shards[s.shard_id()] = {s, now}; });
    chain_.TakeAll([&](const msg::ChainStatus& s, const auto&) {
      view_.chain = StatusView::Entry<msg::ChainStatus>{s, now};
    });
    learner_.TakeAll([&](const msg::LearnerStatus& s, const auto&) {
      view_.learner = StatusView::Entry<msg::LearnerStatus>{s, now};
      view_.learner_reports++;
    });
    scores_.TakeAll([&](const msg::InteractionScores& s, const auto&) {
      view_.scores = StatusView::Entry<msg::InteractionScores>{s, now};
      queued_scores_.push_back(s);
      if (queued_scores_.size() > kMaxQueuedScores) queued_scores_.pop_front();
    });
  }
}

}  // namespace coins
