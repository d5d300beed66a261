// coins-replay: one replay shard as a service. Threads: ingest (TransitionBatch from partition
// shard-K into the store, waiting for the rate limiter), sampling (SampleRequest -> SampleReply,
// PriorityUpdate), snapshots (periodic and on Control commands, beside traffic), and the main
// thread (ReplayStats, heartbeat, Control). Every wait is bounded; threads join before exit.
#include <atomic>
#include <condition_variable>
#include <deque>
#include <fstream>
#include <set>
#include <thread>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "common/checkpoint.h"
#include "common/dds/heartbeat.h"
#include "common/dds/qos.h"
#include "common/dds/topics.h"
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
void WriteStatsJson(const std::string& path, const msg::ReplayStats& s, const ReplayService::View& v) {
  nlohmann::json actors = nlohmann::json::array();
  for (const auto& a : s.actors()) {
    auto it = v.actors.find(a.actor_id());
    actors.push_back({{"actor_id", a.actor_id()}, {"batches", a.batches()}, {"transitions", a.transitions()},
                      {"payload_checksum", a.payload_checksum()}, {"next_seq", a.next_seq()},
                      {"stored_transitions", a.stored_transitions()}, {"stored_checksum", a.stored_checksum()},
                      {"seq_jumps", it != v.actors.end() ? it->second.seq_jumps : 0}});
  }
  nlohmann::json j = {{"shard_id", s.shard_id()}, {"size", s.size()}, {"capacity", s.capacity()},
                      {"inserted_transitions", s.inserted_transitions()}, {"inserted_batches", s.inserted_batches()},
                      {"duplicates", s.duplicates()}, {"gaps", s.gaps()}, {"rejected", s.rejected()},
                      {"samples_served", s.samples_served()}, {"bad_requests", s.bad_requests()},
                      {"rate_limited", s.rate_limited()}, {"snapshots_written", s.snapshots_written()},
                      {"snapshot_failures", s.snapshot_failures()},
                      {"restored_transitions", s.restored_transitions()}, {"corrupt_snapshots", s.corrupt_snapshots()},
                      {"seq_jumps", v.seq_jumps}, {"held_batches", v.held}, {"actors", actors}};
  std::string tmp = path + ".tmp";
  std::ofstream(tmp) << j.dump() << "\n";
  std::rename(tmp.c_str(), path.c_str());
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
  main.app().add_option("--resume-epoch", resume_epoch,
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
  // --resume-epoch N: the snapshot of checkpoint epoch N (coins run --resume)
  const uint64_t resume_command = resume_epoch >= 0 ? CheckpointCommandId(uint64_t(resume_epoch)) : 0;
  auto service_or = ReplayService::Open(uint32_t(id), options, &resume, resume_command);
  for (const auto& c : resume.corrupt) spdlog::warn("skipped snapshot: {}", c);
  if (!service_or.ok()) {
    spdlog::error("{}", service_or.status().message());
    return 1;
  }
  ReplayService& service = **service_or;
  if (resume_command != 0 && resume.snapshot.empty())
    spdlog::warn("no snapshot of epoch {} in '{}' ({} of other commands): starting empty (a shard that held "
                 "nothing at the cut writes none)", resume_epoch, options.snapshot_dir, resume.other_command.size());
  if (!resume.snapshot.empty()) {
    spdlog::info("resumed {} transitions from {} in {:.3f} s", resume.transitions, resume.snapshot, resume.seconds);
    for (const auto& c : resume.config_changes)
      spdlog::warn("config differs from the snapshot's: {} ({} wins{})", c, resume.new_config_won ? "new" : "snapshot",
                   resume.new_config_won ? "" : "; pass --new-config to use the new one");
  }

  auto node = dds::Node::Create(main.dds(), main.name());
  if (!node.ok()) {
    spdlog::error("{}", node.status().message());
    return 1;
  }
  auto reader = (*node)->MakeReader<msg::TransitionBatchPubSubType>(
      dds::kTransitionTopic, dds::TransitionReaderQos(main.dds()), dds::ShardPartition(id));
  auto requests = (*node)->MakeReader<msg::SampleRequestPubSubType>(dds::kSampleRequestTopic, dds::SamplingReaderQos(64));
  auto replies = (*node)->MakeWriter<msg::SampleReplyPubSubType>(dds::kSampleReplyTopic, dds::SamplingWriterQos(8));
  auto updates = (*node)->MakeReader<msg::PriorityUpdatePubSubType>(dds::kPriorityUpdateTopic, dds::SamplingReaderQos(64));
  auto control = (*node)->MakeReader<msg::ControlPubSubType>(dds::kControlTopic, dds::CommandReaderQos());
  auto stats_writer = (*node)->MakeWriter<msg::ReplayStatsPubSubType>(dds::kReplayStatsTopic, dds::StatusWriterQos());
  auto heartbeat = dds::Heartbeat::Create(**node, main.name(), "replay");
  for (const Status* s : {&reader.status(), &requests.status(), &replies.status(), &updates.status(), &control.status(),
                          &stats_writer.status(), &heartbeat.status()})
    if (!s->ok()) {
      spdlog::error("cannot open DDS topics: {}", s->message());
      return 1;
    }

  uint64_t notes_logged = 0;
  SnapshotQueue snapshots;
  Joiner joiner;
  std::atomic<bool> ingest_done{false};

  // ingest: the rate limiter may hold a batch; the DDS history then backs up to the actors.
  // A batch taken from the reader has been acknowledged to its actor, so it is always stored:
  // a stop releases the limiter, which lets a waiting insert through.
  joiner.threads.emplace_back([&] {
    msg::TransitionBatch scratch;
    auto last_batch = std::chrono::steady_clock::now();
    auto store = [&](const msg::TransitionBatch& b, const auto&) {
      std::string why;
      auto r = service.Insert(b, 100ms, &why);
      while (r == ReplayService::InsertResult::kTimedOut) {
        if (StopRequested()) service.ReleaseInserts();
        r = service.Insert(b, 100ms, &why);
      }
      last_batch = std::chrono::steady_clock::now();
      if (!why.empty() && notes_logged++ < 50) {
        if (r == ReplayService::InsertResult::kRejected) spdlog::warn("rejected: {}", why);
        else spdlog::warn("{}", why);
      }
    };
    auto take = [&] { return reader->TakeAll(scratch, store); };
    while (!StopRequested())
      if (reader->Wait(50ms)) take();
    // a clean stop: actors stopped together with the shard publish their last batches and wait
    // for them to be acknowledged before they leave. Store without rate limiting until no writer
    // is matched, or none has sent anything for kQuiet (they are done), or stop_drain_s passed;
    // then unmatch the writers still there, so that nothing is acknowledged after the last take
    constexpr auto kQuiet = 500ms;
    service.ReleaseInserts();
    const auto drain_start = std::chrono::steady_clock::now();
    const auto drain_end = drain_start + std::chrono::duration<double>(options.stop_drain_s);
    last_batch = std::max(last_batch, drain_start);
    while (reader->matched() > 0 && std::chrono::steady_clock::now() < drain_end &&
           std::chrono::steady_clock::now() - last_batch < kQuiet)
      if (reader->Wait(20ms)) take();
    if (int writers = reader->matched(); writers > 0) {
      spdlog::info("closing the transition stream with {} writer(s) still matched", writers);
      if (Status st = (*node)->DetachReaders(dds::ShardPartition(id)); !st.ok()) spdlog::warn("{}", st.message());
      std::this_thread::sleep_for(20ms);
    }
    while (take() > 0) {
    }
    ingest_done = true;
  });

  // sampling service
  joiner.threads.emplace_back([&] {
    msg::SampleRequest req;
    msg::SampleReply reply;
    msg::PriorityUpdate up;
    // samples are served until the stream is closed (a learner may still be running)
    while (!ingest_done) {
      requests->Wait(20ms);
      requests->TakeAll(req, [&](const msg::SampleRequest& q, const auto&) {
        if (q.shard_id() >= 0 && q.shard_id() != id) return;
        service.Sample(q, &reply, 10s);
        if (!replies->Write(reply)) spdlog::warn("sample reply {} not sent (writer timed out)", q.correlation_id());
      });
      updates->TakeAll(up, [&](const msg::PriorityUpdate& u, const auto&) {
        if (u.shard_id() == uint32_t(id)) service.Update(u.kind(), u.key(), u.value());
      });
    }
  });

  // snapshots: one at a time, beside traffic
  joiner.threads.emplace_back([&] {
    LowerThreadPriority();
    const auto period = std::chrono::duration<double>(options.snapshot_period_s);
    auto next = std::chrono::steady_clock::now() + period;
    while (!StopRequested()) {
      uint64_t command = 0;
      bool asked = snapshots.Pop(&command, 100ms);
      bool due = options.snapshot_period_s > 0 && std::chrono::steady_clock::now() >= next;
      if (!asked && !due) continue;
      if (due) next = std::chrono::steady_clock::now() + period;
      auto r = service.Snapshot(command);
      if (r.ok() && r->path.empty())
        spdlog::info("snapshot skipped: nothing stored yet (command {})", command);
      else if (r.ok())
        spdlog::info("snapshot {}: {} transitions, {} bytes in {:.3f} s (command {})", r->path, r->transitions, r->bytes,
                     r->seconds, command);
      else
        spdlog::warn("snapshot failed: {}", r.status().message());
    }
  });

  msg::ReplayStats stats;
  stats.restored_transitions(resume.transitions);
  stats.corrupt_snapshots(resume.corrupt.size());
  auto period = std::chrono::duration<double>(options.status_period_s);
  auto last = std::chrono::steady_clock::now();
  uint64_t last_inserted = service.Stats(false).shard.inserted_transitions;
  std::set<uint64_t> commands_seen;
  heartbeat->Publish("running");
  spdlog::info("shard {} listening on partition {}", id, dds::ShardPartition(id));
  msg::Control cmd;
  while (!StopRequested()) {
    control->Wait(50ms);
    control->TakeAll(cmd, [&](const msg::Control& c, const auto&) {
      bool mine = c.target() == "all" || c.target() == "replay" || c.target() == main.name();
      if (!mine || !commands_seen.insert(c.command_id()).second) return;
      // a checkpoint epoch's snapshot is a snapshot stamped with the epoch's command id
      if (c.command() == msg::CONTROL_SNAPSHOT || c.command() == msg::CONTROL_CHECKPOINT) snapshots.Push(c.command_id());
      if (c.command() == msg::CONTROL_STOP) RequestStop();
    });
    auto now = std::chrono::steady_clock::now();
    if (now - last >= period) {
      double dt = std::chrono::duration<double>(now - last).count();
      auto v = service.Stats(false);
      FillStats(v, (v.shard.inserted_transitions - last_inserted) / dt, stats);
      stats_writer->Write(stats);
      heartbeat->Publish("running");
      last = now;
      last_inserted = v.shard.inserted_transitions;
    }
  }

  heartbeat->Publish("stopping");
  // the ingest thread drains and closes the stream, then the rest stops
  joiner.threads[0].join();
  service.Close();
  for (auto& t : joiner.threads)
    if (t.joinable()) t.join();
  // a clean stop keeps what was stored: a final snapshot when the shard has a directory
  if (!options.snapshot_dir.empty() && options.snapshot_on_stop) {
    auto r = service.Snapshot(0);
    if (!r.ok()) spdlog::warn("final snapshot failed: {}", r.status().message());
    else if (!r->path.empty())
      spdlog::info("final snapshot {}: {} transitions, {} bytes in {:.3f} s", r->path, r->transitions, r->bytes,
                   r->seconds);
  }
  auto final_view = service.Stats(true);
  FillStats(final_view, 0.0, stats);
  stats_writer->Write(stats);
  stats_writer->WaitAcked(500ms);
  if (!stats_out.empty()) WriteStatsJson(stats_out, stats, final_view);
  spdlog::info("stopped: {} transitions in {} batches stored, {} duplicates, {} gaps, {} sequence jumps ({} held "
               "unconfirmed), {} rejected, {} samples served",
               stats.inserted_transitions(), stats.inserted_batches(), stats.duplicates(), stats.gaps(),
               final_view.seq_jumps, final_view.held, stats.rejected(), stats.samples_served());
  for (const auto& [actor, a] : final_view.actors)
    spdlog::info("actor {}: {} transitions in {} batches stored (next seq {})", actor, a.transitions, a.batches,
                 a.next_seq);
  return 0;
}

}  // namespace
}  // namespace coins

int main(int argc, char** argv) { return coins::ReplayMain(argc, argv); }
