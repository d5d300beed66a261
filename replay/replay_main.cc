// coins-replay: one replay shard. Takes TransitionBatches from partition shard-K, stores them,
// and publishes ReplayStats.
#include <fstream>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "common/dds/heartbeat.h"
#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "common/process.h"
#include "common/run_options.h"
#include "idl/statusPubSubTypes.h"
#include "idl/transitionPubSubTypes.h"
#include "replay/shard.h"

namespace coins {
namespace {

void FillStats(const Shard& shard, double insert_rate, msg::ReplayStats& s) {
  s.size(shard.store().transitions());
  s.capacity(shard.store().capacity());
  s.inserted_transitions(shard.inserted_transitions());
  s.inserted_batches(shard.inserted_batches());
  s.duplicates(shard.ledger().duplicates());
  s.gaps(shard.ledger().gaps());
  s.rejected(shard.rejected());
  s.insert_rate(insert_rate);
  s.actors().clear();
  for (const auto& [id, a] : shard.ledger().actors()) {
    msg::ActorIngest ai;
    ai.actor_id(id);
    ai.batches(a.batches);
    ai.transitions(a.transitions);
    ai.payload_checksum(a.checksum);
    ai.next_seq(a.next_seq);
    s.actors().push_back(ai);
  }
}

void WriteStatsJson(const std::string& path, const msg::ReplayStats& s) {
  nlohmann::json actors = nlohmann::json::array();
  for (const auto& a : s.actors())
    actors.push_back({{"actor_id", a.actor_id()}, {"batches", a.batches()}, {"transitions", a.transitions()},
                      {"payload_checksum", a.payload_checksum()}, {"next_seq", a.next_seq()}});
  nlohmann::json j = {{"shard_id", s.shard_id()},       {"size", s.size()},
                      {"capacity", s.capacity()},       {"inserted_transitions", s.inserted_transitions()},
                      {"inserted_batches", s.inserted_batches()}, {"duplicates", s.duplicates()},
                      {"gaps", s.gaps()},               {"rejected", s.rejected()},
                      {"actors", actors}};
  std::string tmp = path + ".tmp";
  std::ofstream(tmp) << j.dump() << "\n";
  std::rename(tmp.c_str(), path.c_str());
}

int ReplayMain(int argc, char** argv) {
  ProcessMain main("coins-replay", "Runs one replay shard: stores transition batches and serves samples.");
  RunOptions run;
  ReplayOptions options;
  int64_t id = 0;
  std::string stats_out;
  main.AddSection(ConfigSection::Of("run", run));
  main.AddSection(ConfigSection::Of("replay", options));
  main.app().add_option("--id", id, "shard id, in [0, run.shards)")->check(CLI::Range(0, 1 << 20));
  main.app().add_option("--stats-out", stats_out, "write the final ReplayStats as JSON to this file");
  if (int rc = main.Parse(argc, argv); rc >= 0) return rc;
  if (id >= run.shards) {
    std::cerr << "coins-replay: --id " << id << " is not below run.shards (" << run.shards << ")\n";
    return 2;
  }
  if (main.name() == "coins-replay") main.name() = "replay-" + std::to_string(id);

  auto node = dds::Node::Create(main.dds(), main.name());
  if (!node.ok()) {
    spdlog::error("{}", node.status().message());
    return 1;
  }
  auto reader = (*node)->MakeReader<msg::TransitionBatchPubSubType>(
      dds::kTransitionTopic, dds::TransitionReaderQos(main.dds()), dds::ShardPartition(id));
  auto stats_writer = (*node)->MakeWriter<msg::ReplayStatsPubSubType>(dds::kReplayStatsTopic, dds::StatusWriterQos());
  auto heartbeat = dds::Heartbeat::Create(**node, main.name(), "replay");
  if (!reader.ok() || !stats_writer.ok() || !heartbeat.ok()) {
    spdlog::error("cannot open DDS topics: {}{}{}", reader.status().message(), stats_writer.status().message(),
                  heartbeat.status().message());
    return 1;
  }

  Shard shard(static_cast<uint32_t>(id), options);
  msg::ReplayStats stats;
  stats.schema_version(msg::STATUS_SCHEMA);
  stats.shard_id(static_cast<uint32_t>(id));
  auto period = std::chrono::duration<double>(options.status_period_s);
  auto last = std::chrono::steady_clock::now();
  uint64_t last_inserted = 0;
  uint64_t rejected_logged = 0;
  heartbeat->Publish("running");
  spdlog::info("shard {} listening on partition {}", id, dds::ShardPartition(id));

  // one preallocated sample that every take deserialises into
  msg::TransitionBatch scratch;
  auto take = [&] {
    return reader->TakeAll(scratch, [&](const msg::TransitionBatch& b, const auto&) {
      std::string why;
      if (shard.Receive(b, &why) == Shard::Outcome::kRejected && rejected_logged++ < 20)
        spdlog::warn("rejected: {}", why);
    });
  };
  while (!StopRequested()) {
    if (reader->Wait(std::chrono::milliseconds(50))) take();
    auto now = std::chrono::steady_clock::now();
    if (now - last >= period) {
      double dt = std::chrono::duration<double>(now - last).count();
      FillStats(shard, (shard.inserted_transitions() - last_inserted) / dt, stats);
      stats_writer->Write(stats);
      heartbeat->Publish("running");
      last = now;
      last_inserted = shard.inserted_transitions();
    }
  }

  // store what was already delivered before leaving
  while (take() > 0) {
  }
  heartbeat->Publish("stopping");
  FillStats(shard, 0.0, stats);
  stats_writer->Write(stats);
  stats_writer->WaitAcked(std::chrono::milliseconds(500));
  if (!stats_out.empty()) WriteStatsJson(stats_out, stats);
  spdlog::info("stopped: {} transitions in {} batches stored, {} duplicates, {} gaps, {} rejected",
               shard.inserted_transitions(), shard.inserted_batches(), stats.duplicates(), stats.gaps(),
               stats.rejected());
  return 0;
}

}  // namespace
}  // namespace coins

int main(int argc, char** argv) { return coins::ReplayMain(argc, argv); }
