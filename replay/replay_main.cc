// coins-replay: one replay shard as a service. Threads: ingest (TransitionBatch from partition
// shard-K into the store, waiting for the rate limiter), sampling (SampleRequest -> SampleReply,
// PriorityUpdate), snapshots (periodic and on Control commands, beside traffic), and the main
// thread (ReplayStats, heartbeat, Control). Every wait is bounded; threads join before exit.
#include <atomic>
#include <condition_variable>
#include <deque>
#include <set>
#include <thread>

#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "common/checkpoint.h"
#include "common/dds/heartbeat.h"
#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "common/files.h"
#include "common/process.h"
#include "common/run_options.h"
#include "idl/controlPubSubTypes.h"
#include "idl/samplingPubSubTypes.h"
#include "idl/statusPubSubTypes.h"
#include "idl/transitionPubSubTypes.h"
#include "replay/replay_service.h"
#include "replay/sampling_topics.h"

namespace coins {
namespace {

using namespace std::chrono_literals;

void FillStats(const ReplayService::View& v, double insert_rate, msg::ReplayStats& s) {
  s.schema_version(msg::REPLAY_STATS_SCHEMA);
  s.shard_id(v.shard_id);
  s.size(uint64_t(v.size));
  s.capacity(uint64_t(v.capacity));
  s.inserted_transitions(v.shard.inserted_transitions);
  s.inserted_batches(v.shard.inserted_batches);
  s.duplicates(v.duplicates);
  s.gaps(v.gaps);
  s.rejected(v.shard.rejected);
  s.samples_served(v.service.samples_served);
  s.insert_rate(insert_rate);
  s.bad_requests(v.service.bad_requests);
  s.rate_limited(v.service.rate_limited);
  s.insert_waits(v.service.insert_waits);
  s.snapshots_written(v.service.snapshots_written);
  s.snapshot_failures(v.service.snapshot_failures);
  s.last_snapshot_command(v.service.last_snapshot_command);
  s.last_snapshot_s(v.service.last_snapshot_s);
  s.actors().clear();
  for (const auto& [id, a] : v.actors) {
    msg::ActorIngest ai;
    ai.actor_id(id);
    ai.batches(a.batches);
    ai.transitions(a.transitions);
    ai.payload_checksum(a.checksum);
    ai.next_seq(a.next_seq);
    if (auto it = v.stored.find(id); it != v.stored.end()) {
      ai.stored_transitions(it->second.first);
      ai.stored_checksum(it->second.second);
    }
    s.actors().push_back(ai);
  }
}

// the final stats; `v` adds what ReplayStats does not carry (sequence jumps, held batches)
nlohmann::json StatsJson(const msg::ReplayStats& s, const ReplayService::View& v, uint64_t refused_participants) {
  nlohmann::json actors = nlohmann::json::array();
  for (const auto& a : s.actors()) {
    auto it = v.actors.find(a.actor_id());
    actors.push_back({{"actor_id", a.actor_id()},
                      {"batches", a.batches()},
                      {"transitions", a.transitions()},
                      {"payload_checksum", a.payload_checksum()},
                      {"next_seq", a.next_seq()},
                      {"stored_transitions", a.stored_transitions()},
                      {"stored_checksum", a.stored_checksum()},
                      {"seq_jumps", it != v.actors.end() ? it->second.seq_jumps : 0}});
  }
  return {{"shard_id", s.shard_id()},
          {"size", s.size()},
          {"capacity", s.capacity()},
          {"inserted_transitions", s.inserted_transitions()},
          {"inserted_batches", s.inserted_batches()},
          {"duplicates", s.duplicates()},
          {"gaps", s.gaps()},
          {"rejected", s.rejected()},
          {"samples_served", s.samples_served()},
          {"bad_requests", s.bad_requests()},
          {"rate_limited", s.rate_limited()},
          {"snapshots_written", s.snapshots_written()},
          {"snapshot_failures", s.snapshot_failures()},
          {"restored_transitions", s.restored_transitions()},
          {"corrupt_snapshots", s.corrupt_snapshots()},
          {"seq_jumps", v.seq_jumps},
          {"held_batches", v.held},
          {"refused_participants", refused_participants},
          {"actors", actors}};
}

// snapshot requests (command ids; 0 = periodic) handed to the snapshot thread
class SnapshotQueue {
 public:
  void Push(uint64_t id) {
    {
      std::lock_guard lock(mu_);
      q_.push_back(id);
    }
    cv_.notify_one();
  }
  // waits up to timeout; false when nothing came
  bool Pop(uint64_t* id, std::chrono::milliseconds timeout) {
    std::unique_lock lock(mu_);
    if (!cv_.wait_for(lock, timeout, [&] { return !q_.empty(); })) return false;
    *id = q_.front();
    q_.pop_front();
    return true;
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<uint64_t> q_;
};

// joins its threads when it goes out of scope
struct Joiner {
  std::vector<std::thread> threads;
  ~Joiner() {
    RequestStop();
    for (auto& t : threads)
      if (t.joinable()) t.join();
  }
};

// the shard's DDS topics
struct Topics {
  dds::Reader<msg::TransitionBatch> batches;
  dds::Reader<msg::SampleRequest> requests;
  dds::Writer<msg::SampleReply> replies;
  dds::Reader<msg::PriorityUpdate> updates;
  dds::Reader<msg::Control> control;
  dds::Writer<msg::ReplayStats> stats;
};

Result<Topics> OpenTopics(dds::Node& node, const DdsOptions& dds, int64_t id) {
  auto batches = node.MakeReader<msg::TransitionBatchPubSubType>(dds::kTransitionTopic, dds::TransitionReaderQos(dds),
                                                                 dds::ShardPartition(id));
  auto requests = node.MakeReader<msg::SampleRequestPubSubType>(dds::kSampleRequestTopic, dds::SamplingReaderQos(64));
  auto replies = node.MakeWriter<msg::SampleReplyPubSubType>(dds::kSampleReplyTopic, dds::SamplingWriterQos(8));
  auto updates = node.MakeReader<msg::PriorityUpdatePubSubType>(dds::kPriorityUpdateTopic, dds::SamplingReaderQos(64));
  auto control = node.MakeReader<msg::ControlPubSubType>(dds::kControlTopic, dds::CommandReaderQos());
  auto stats = node.MakeWriter<msg::ReplayStatsPubSubType>(dds::kReplayStatsTopic, dds::StatusWriterQos());
  for (const Status* s : {&batches.status(), &requests.status(), &replies.status(), &updates.status(),
                          &control.status(), &stats.status()})
    if (!s->ok()) return s->WithContext("cannot open DDS topics");
  return Topics{*batches, *requests, *replies, *updates, *control, *stats};
}

// opens the shard's store, resuming a snapshot (--resume-epoch N: the one of checkpoint epoch
// N, else the newest), and logs what the resume found
Result<std::unique_ptr<ReplayService>> OpenService(int64_t id, const ReplayOptions& options, int64_t resume_epoch,
                                                   ResumeReport* resume) {
  const uint64_t resume_command = resume_epoch >= 0 ? CheckpointCommandId(uint64_t(resume_epoch)) : 0;
  auto service = ReplayService::Open(uint32_t(id), options, resume, resume_command);
  for (const auto& c : resume->corrupt) spdlog::warn("skipped snapshot: {}", c);
  if (!service.ok()) return service;
  if (resume_command != 0 && resume->snapshot.empty())
    spdlog::warn(
        "no snapshot of epoch {} in '{}' ({} of other commands): starting empty (a shard that held "
        "nothing at the cut writes none)",
        resume_epoch, options.snapshot_dir, resume->other_command.size());
  if (!resume->snapshot.empty()) {
    spdlog::info("resumed {} transitions from {} in {:.3f} s", resume->transitions, resume->snapshot, resume->seconds);
    for (const auto& c : resume->config_changes)
      spdlog::warn("config differs from the snapshot's: {} ({} wins{})", c, resume->new_config_won ? "new" : "snapshot",
                   resume->new_config_won ? "" : "; pass --new-config to use the new one");
  }
  return service;
}

// one running shard: the ingest, sampling and snapshot threads and the status loop of the
// main thread, over the service and the topics
class ShardProcess {
 public:
  ShardProcess(int64_t id, std::string name, const ReplayOptions& options, ReplayService& service, dds::Node& node,
               Topics& topics)
      : id_(id), name_(std::move(name)), options_(options), service_(service), node_(node), t_(topics) {}

  // runs until a stop is requested, then drains, stops the threads and writes the final snapshot
  void Run(dds::Heartbeat& heartbeat, msg::ReplayStats& stats) {
    joiner_.threads.emplace_back([this] { Ingest(); });
    joiner_.threads.emplace_back([this] { ServeSamples(); });
    joiner_.threads.emplace_back([this] { TakeSnapshots(); });
    heartbeat.Publish("running");
    spdlog::info("shard {} listening on partition {}", id_, dds::ShardPartition(id_));
    StatusLoop(heartbeat, stats);
    heartbeat.Publish("stopping");
    // the ingest thread drains and closes the stream, then the rest stops
    joiner_.threads[0].join();
    service_.Close();
    for (auto& t : joiner_.threads)
      if (t.joinable()) t.join();
    // a clean stop keeps what was stored: a final snapshot when the shard has a directory
    if (!options_.snapshot_dir.empty() && options_.snapshot_on_stop) {
      auto r = service_.Snapshot(0);
      if (!r.ok())
        spdlog::warn("final snapshot failed: {}", r.status().message());
      else if (!r->path.empty())
        spdlog::info("final snapshot {}: {} transitions, {} bytes in {:.3f} s", r->path, r->transitions, r->bytes,
                     r->seconds);
    }
  }

 private:
  // stores one batch; the rate limiter may hold it (a stop releases the limiter). A batch the
  // shard rejects, holds or drops is logged with the writer that sent it.
  void Store(const msg::TransitionBatch& b, const dds::fdds::SampleInfo& info) {
    std::string why;
    auto r = service_.Insert(b, 100ms, &why);
    while (r == ReplayService::InsertResult::kTimedOut) {
      if (StopRequested()) service_.ReleaseInserts();
      r = service_.Insert(b, 100ms, &why);
    }
    last_batch_ = std::chrono::steady_clock::now();
    if (!why.empty() && notes_logged_++ < 50) {
      const std::string sender = dds::PublisherOf(info);
      if (r == ReplayService::InsertResult::kRejected)
        spdlog::warn("rejected: {} (writer {})", why, sender);
      else
        spdlog::warn("{} (writer {})", why, sender);
    }
  }

  // ingest: the rate limiter may hold a batch; the DDS history then backs up to the actors.
  // A batch taken from the reader has been acknowledged to its actor, so it is always stored:
  // a stop releases the limiter, which lets a waiting insert through.
  void Ingest() {
    msg::TransitionBatch scratch;
    last_batch_ = std::chrono::steady_clock::now();
    auto take = [&] {
      return t_.batches.TakeAll(scratch, [&](const msg::TransitionBatch& b, const auto& info) { Store(b, info); });
    };
    while (!StopRequested())
      if (t_.batches.Wait(50ms)) take();
    // a clean stop: actors stopped together with the shard publish their last batches and wait
    // for them to be acknowledged before they leave. Store without rate limiting until no writer
    // is matched, or none has sent anything for kQuiet (they are done), or stop_drain_s passed;
    // then unmatch the writers still there, so that nothing is acknowledged after the last take
    constexpr auto kQuiet = 500ms;
    service_.ReleaseInserts();
    const auto drain_start = std::chrono::steady_clock::now();
    const auto drain_end = drain_start + std::chrono::duration<double>(options_.stop_drain_s);
    last_batch_ = std::max(last_batch_, drain_start);
    while (t_.batches.matched() > 0 && std::chrono::steady_clock::now() < drain_end &&
           std::chrono::steady_clock::now() - last_batch_ < kQuiet)
      if (t_.batches.Wait(20ms)) take();
    if (int writers = t_.batches.matched(); writers > 0) {
      spdlog::info("closing the transition stream with {} writer(s) still matched", writers);
      if (Status st = node_.DetachReaders(dds::ShardPartition(id_)); !st.ok()) spdlog::warn("{}", st.message());
      std::this_thread::sleep_for(20ms);
    }
    while (take() > 0) {
    }
    ingest_done_ = true;
  }

  // sampling service: samples are served until the stream is closed (a learner may still be running)
  void ServeSamples() {
    msg::SampleRequest req;
    msg::SampleReply reply;
    msg::PriorityUpdate up;
    while (!ingest_done_) {
      t_.requests.Wait(20ms);
      t_.requests.TakeAll(req, [&](const msg::SampleRequest& q, const auto&) {
        if (q.shard_id() >= 0 && q.shard_id() != id_) return;
        service_.Sample(q, &reply, 10s);
        if (!t_.replies.Write(reply)) spdlog::warn("sample reply {} not sent (writer timed out)", q.correlation_id());
      });
      t_.updates.TakeAll(up, [&](const msg::PriorityUpdate& u, const auto&) {
        if (u.shard_id() == uint32_t(id_)) service_.Update(u.kind(), u.key(), u.value());
      });
    }
  }

  // snapshots: one at a time, beside traffic
  void TakeSnapshots() {
    LowerThreadPriority();
    const auto period = std::chrono::duration<double>(options_.snapshot_period_s);
    auto next = std::chrono::steady_clock::now() + period;
    while (!StopRequested()) {
      uint64_t command = 0;
      bool asked = snapshots_.Pop(&command, 100ms);
      bool due = options_.snapshot_period_s > 0 && std::chrono::steady_clock::now() >= next;
      if (!asked && !due) continue;
      if (due) next = std::chrono::steady_clock::now() + period;
      auto r = service_.Snapshot(command);
      if (r.ok() && r->path.empty())
        spdlog::info("snapshot skipped: nothing stored yet (command {})", command);
      else if (r.ok())
        spdlog::info("snapshot {}: {} transitions, {} bytes in {:.3f} s (command {})", r->path, r->transitions,
                     r->bytes, r->seconds, command);
      else
        spdlog::warn("snapshot failed: {}", r.status().message());
    }
  }

  // the main thread: Control commands, and ReplayStats with the heartbeat every status period
  void StatusLoop(dds::Heartbeat& heartbeat, msg::ReplayStats& stats) {
    auto period = std::chrono::duration<double>(options_.status_period_s);
    auto last = std::chrono::steady_clock::now();
    uint64_t last_inserted = service_.Stats(false).shard.inserted_transitions;
    std::set<uint64_t> commands_seen;
    msg::Control cmd;
    while (!StopRequested()) {
      t_.control.Wait(50ms);
      t_.control.TakeAll(cmd, [&](const msg::Control& c, const auto&) {
        bool mine = c.target() == "all" || c.target() == "replay" || c.target() == name_;
        if (!mine || !commands_seen.insert(c.command_id()).second) return;
        // a checkpoint epoch's snapshot is a snapshot stamped with the epoch's command id
        if (c.command() == msg::CONTROL_SNAPSHOT || c.command() == msg::CONTROL_CHECKPOINT)
          snapshots_.Push(c.command_id());
        if (c.command() == msg::CONTROL_STOP) RequestStop();
      });
      auto now = std::chrono::steady_clock::now();
      if (now - last >= period) {
        double dt = std::chrono::duration<double>(now - last).count();
        auto v = service_.Stats(false);
        FillStats(v, (v.shard.inserted_transitions - last_inserted) / dt, stats);
        t_.stats.Write(stats);
        heartbeat.Publish("running");
        last = now;
        last_inserted = v.shard.inserted_transitions;
      }
    }
  }

  const int64_t id_;
  const std::string name_;
  const ReplayOptions& options_;
  ReplayService& service_;
  dds::Node& node_;
  Topics& t_;
  SnapshotQueue snapshots_;
  std::atomic<bool> ingest_done_{false};
  uint64_t notes_logged_ = 0;                         // ingest thread only
  std::chrono::steady_clock::time_point last_batch_;  // ingest thread only
  Joiner joiner_;                                     // last: joins before the rest goes
};

// the final ReplayStats: published, written to --stats-out, and logged
void ReportFinalStats(ReplayService& service, Topics& t, const dds::Node& node, msg::ReplayStats& stats,
                      const std::string& stats_out) {
  auto final_view = service.Stats(true);
  FillStats(final_view, 0.0, stats);
  t.stats.Write(stats);
  t.stats.WaitAcked(500ms);
  if (!stats_out.empty()) {
    if (Status s = WriteFileAtomic(stats_out, StatsJson(stats, final_view, node.refused_participants()).dump() + "\n");
        !s.ok())
      spdlog::warn("{}", s.message());
  }
  spdlog::info(
      "stopped: {} transitions in {} batches stored, {} duplicates, {} gaps, {} sequence jumps ({} held "
      "unconfirmed), {} rejected, {} samples served",
      stats.inserted_transitions(), stats.inserted_batches(), stats.duplicates(), stats.gaps(), final_view.seq_jumps,
      final_view.held, stats.rejected(), stats.samples_served());
  if (!node.options().security.empty())
    spdlog::info("dds security: {} participants refused", node.refused_participants());
  for (const auto& [actor, a] : final_view.actors)
    spdlog::info("actor {}: {} transitions in {} batches stored (next seq {})", actor, a.transitions, a.batches,
                 a.next_seq);
}

int ReplayMain(int argc, char** argv) {
  ProcessMain main("coins-replay", "Runs one replay shard: stores transition batches and serves samples.");
  RunOptions run;
  ReplayOptions options;
  int64_t id = 0;
  std::string stats_out;
  bool new_config = false;
  int64_t resume_epoch = -1;
  main.AddSection(ConfigSection::Of("run", run));
  main.AddSection(ConfigSection::Of("replay", options));
  main.app().add_option("--id", id, "shard id, in [0, run.shards)")->check(CLI::Range(0, 1 << 20));
  main.app().add_option("--stats-out", stats_out, "write the final ReplayStats as JSON to this file");
  main.app()
      .add_option("--resume-epoch", resume_epoch,
                  "resume the snapshot of checkpoint epoch N (coins run --resume); default: the newest snapshot")
      ->check(CLI::NonNegativeNumber);
  main.app().add_flag("--new-config", new_config,
                      "on resume, this config wins over the snapshot's (same as replay.prefer_new_config=true)");
  if (int rc = main.Parse(argc, argv); rc >= 0) return rc;
  if (id >= run.shards) {
    std::cerr << "coins-replay: --id " << id << " is not below run.shards (" << run.shards << ")\n";
    return 2;
  }
  if (new_config) options.prefer_new_config = true;
  if (main.name() == "coins-replay") main.name() = "replay-" + std::to_string(id);

  // resume before joining DDS: a shard that is not ready does not take data
  ResumeReport resume;
  auto service = OpenService(id, options, resume_epoch, &resume);
  if (!service.ok()) return ExitWithError(service.status(), 1);
  auto dds = main.OpenNode("replay");
  if (!dds.ok()) return ExitWithError(dds.status(), 1);
  auto topics = OpenTopics(*dds->node, main.dds(), id);
  if (!topics.ok()) return ExitWithError(topics.status(), 1);

  msg::ReplayStats stats;
  stats.restored_transitions(resume.transitions);
  stats.corrupt_snapshots(resume.corrupt.size());
  ShardProcess(id, main.name(), options, **service, *dds->node, *topics).Run(dds->heartbeat, stats);
  ReportFinalStats(**service, *topics, *dds->node, stats, stats_out);
  return 0;
}

}  // namespace
}  // namespace coins

int main(int argc, char** argv) { return coins::ReplayMain(argc, argv); }
