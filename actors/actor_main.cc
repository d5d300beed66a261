// coins-actor: runs environments with the current policy and streams their transitions to
// replay shard (actor id mod run.shards) over DDS.
#include <fstream>
#include <optional>
#include <thread>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "actors/actor.h"
#include "common/dds/heartbeat.h"
#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "common/process.h"
#include "common/run_options.h"
#include "idl/statusPubSubTypes.h"
#include "idl/transitionPubSubTypes.h"

namespace coins {
namespace {

void WriteStatsJson(const std::string& path, const msg::ActorStats& s) {
  nlohmann::json j = {{"actor_id", s.actor_id()},
                      {"env", s.env()},
                      {"shard", s.shard()},
                      {"steps", s.steps()},
                      {"episodes", s.episodes()},
                      {"batches", s.batches()},
                      {"transitions_published", s.transitions_published()},
                      {"payload_checksum", s.payload_checksum()},
                      {"publish_retries", s.publish_retries()}};
  std::string tmp = path + ".tmp";
  std::ofstream(tmp) << j.dump() << "\n";
  std::rename(tmp.c_str(), path.c_str());
}

}  // namespace

int ActorMain(int argc, char** argv) {
  ProcessMain main("coins-actor", "Runs environments and streams their transitions to a replay shard over DDS.");
  RunOptions run;
  ActorOptions options;
  int64_t id = 0;
  std::string stats_out;
  main.AddSection(ConfigSection::Of("run", run));
  main.AddSection(ConfigSection::Of("actor", options));
  main.app().add_option("--id", id, "actor id (publishes to shard id mod run.shards)")->check(CLI::Range(0, 1 << 20));
  main.app().add_option("--stats-out", stats_out, "write the final ActorStats as JSON to this file");
  if (int rc = main.Parse(argc, argv); rc >= 0) return rc;
  if (main.name() == "coins-actor") main.name() = "actor-" + std::to_string(id);

  int64_t shard = id % run.shards;
  uint64_t steps = options.steps ? options.steps : (run.steps ? (run.steps + run.actors - 1) / run.actors : 0);

  auto node = dds::Node::Create(main.dds(), main.name());
  if (!node.ok()) {
    spdlog::error("{}", node.status().message());
    return 1;
  }
  auto stats_writer = (*node)->MakeWriter<msg::ActorStatsPubSubType>(dds::kActorStatsTopic, dds::StatusWriterQos());
  auto heartbeat = dds::Heartbeat::Create(**node, main.name(), "actor");
  // after a stop request the actor stops stepping but still publishes its partial batches;
  // the sink gives up waiting for the shard only once flush_timeout_s has passed. The sink has
  // a participant of its own, which it replaces when the stream stalls (actors/batch_sink.h).
  std::optional<std::chrono::steady_clock::time_point> stop_seen;
  auto flush_timeout = std::chrono::duration<double>(options.flush_timeout_s);
  auto sink_or = DdsBatchSink::Create(main.dds(), main.name() + ".transitions", shard, [&] {
    if (!StopRequested()) return false;
    if (!stop_seen) stop_seen = std::chrono::steady_clock::now();
    return std::chrono::steady_clock::now() - *stop_seen > flush_timeout;
  });
  if (!sink_or.ok() || !stats_writer.ok() || !heartbeat.ok()) {
    spdlog::error("cannot open DDS topics: {}{}{}", sink_or.status().message(), stats_writer.status().message(),
                  heartbeat.status().message());
    return 1;
  }
  DdsBatchSink& sink = **sink_or;
  auto actor = Actor::Create(run.env, options, static_cast<uint32_t>(id), static_cast<uint64_t>(run.seed), &sink);
  if (!actor.ok()) {
    spdlog::error("{}", actor.status().message());
    return 2;
  }
  spdlog::info("env {} (state {} floats), {} envs, publishing to shard {}, steps {}", run.env,
               (*actor)->spec().state_dim(), options.envs, shard, steps ? std::to_string(steps) : "unbounded");
  heartbeat->Publish("running");

  // status: ActorStats with the step rate over the last period
  msg::ActorStats stats;
  stats.schema_version(msg::STATUS_SCHEMA);
  stats.actor_id(static_cast<uint32_t>(id));
  stats.env(run.env);
  stats.shard(static_cast<uint32_t>(shard));
  auto last_time = std::chrono::steady_clock::now();
  uint64_t last_steps = 0;
  auto fill_stats = [&](const ActorCounters& c) {
    auto now = std::chrono::steady_clock::now();
    double dt = std::chrono::duration<double>(now - last_time).count();
    stats.steps_per_s(dt > 0 ? (c.steps - last_steps) / dt : 0.0);
    last_time = now;
    last_steps = c.steps;
    stats.steps(c.steps);
    stats.episodes(c.episodes);
    stats.batches(c.batches);
    stats.transitions_published(c.transitions_published);
    stats.payload_checksum(c.payload_checksum);
    stats.publish_retries(sink.retries());
    stats.mean_episode_return(c.returns_counted ? c.return_sum / c.returns_counted : 0.0);
  };
  auto period = std::chrono::milliseconds(static_cast<int64_t>(options.status_period_s * 1000));
  (*actor)->Run(steps, [] { return StopRequested(); },
                [&](const ActorCounters& c) {
                  fill_stats(c);
                  stats_writer->Write(stats);
                  heartbeat->Publish("running");
                },
                period);

  heartbeat->Publish("stopping");
  bool acked = sink.Flush(std::chrono::milliseconds(static_cast<int64_t>(options.flush_timeout_s * 1000)));
  if (!acked) spdlog::warn("not every batch was acknowledged within {} s", options.flush_timeout_s);
  fill_stats((*actor)->counters());
  // a short run can end before anyone watching (coins run, monitor) has discovered this actor:
  // give them a moment to match so the final stats are seen
  for (int i = 0; i < 100 && stats_writer->matched() == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  stats_writer->Write(stats);
  stats_writer->WaitAcked(std::chrono::seconds(2));
  if (!stats_out.empty()) WriteStatsJson(stats_out, stats);
  spdlog::info("done: {} steps, {} episodes, {} batches, {} transitions published", stats.steps(), stats.episodes(),
               stats.batches(), stats.transitions_published());
  return 0;
}

}  // namespace coins

int main(int argc, char** argv) { return coins::ActorMain(argc, argv); }
