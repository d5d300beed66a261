#include "replay/replay_cli.h"

#include <chrono>
#include <iostream>
#include <map>
#include <random>

#include <spdlog/spdlog.h>

#include "common/cli_checks.h"
#include "common/dds/node.h"
#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "common/process.h"
#include "common/run_options.h"
#include "idl/controlPubSubTypes.h"
#include "idl/statusPubSubTypes.h"
#include "replay/snapshot.h"

namespace coins {
namespace {

void RunInspect(const std::string& path, bool json) {
  SnapshotImage img;
  Status s = InspectSnapshot(path, &img);
  nlohmann::json sections = nlohmann::json::array();
  for (const auto& sec : img.sections) sections.push_back({{"tag", sec.tag}, {"bytes", sec.length}, {"ok", sec.ok}});
  uint64_t actors = img.ledger.is_array() ? img.ledger.size() : 0;
  if (json) {
    nlohmann::json j = {{"path", path},     {"format", img.format}, {"valid", s.ok()},      {"error", s.message()},
                        {"meta", img.meta}, {"config", img.config}, {"ledger", img.ledger}, {"sections", sections}};
    std::cout << j.dump() << std::endl;
  } else {
    std::cout << "snapshot   " << path << "\n";
    std::cout << "format     " << img.format << "\n";
    const auto& m = img.meta;
    if (m.is_object()) {
      std::cout << fmt::format("shard      {}\ncreated    {:.3f} (unix s), command {}\n", m.value("shard_id", 0u),
                               m.value("created_unix", 0.0), m.value("command_id", uint64_t(0)));
      std::cout << fmt::format("layout     {:08x}, state {} action {} goal {}\n", m.value("layout_hash", 0u),
                               m.value("state_dim", 0u), m.value("action_dim", 0u), m.value("goal_dim", 0u));
      std::cout << fmt::format("counts     {} chunks, {} transitions, {} rows, {} data bytes, {} actors\n",
                               m.value("chunks", uint64_t(0)), m.value("transitions", uint64_t(0)),
                               m.value("rows", uint64_t(0)), img.data.size(), actors);
      std::cout << fmt::format("ingest     {} transitions in {} batches, {} duplicates, {} gaps, {} rejected\n",
                               m.value("inserted_transitions", uint64_t(0)), m.value("inserted_batches", uint64_t(0)),
                               m.value("duplicates", uint64_t(0)), m.value("gaps", uint64_t(0)),
                               m.value("rejected", uint64_t(0)));
      std::cout << fmt::format("rate       {} inserted, {} sampled\n", m.value("rate_inserted", uint64_t(0)),
                               m.value("rate_sampled", uint64_t(0)));
    }
    if (!img.config.is_null()) std::cout << "config     " << img.config.dump() << "\n";
    for (const auto& sec : img.sections)
      std::cout << fmt::format("section    {} {:>12} bytes  {}\n", sec.tag, sec.length, sec.ok ? "ok" : "CORRUPT");
    std::cout << "integrity  " << (s.ok() ? "ok" : s.message()) << "\n";
  }
  if (!s.ok()) throw CLI::RuntimeError(1);
}

struct SnapshotFlags {
  std::string config;
  int domain = -1;
  std::string target = "replay";
  int shards = -1;
  double timeout = 30;
};

void RunSnapshot(const SnapshotFlags& f) {
  const std::string cmd = "snapshot";
  DdsOptions dds;
  RunOptions run;
  ConfigLoader loader({ConfigSection::Of("dds", dds), ConfigSection::Of("run", run)});
  Status s = f.config.empty() ? Status::Ok() : loader.LoadFile(f.config);
  if (s.ok() && f.domain >= 0) s = loader.ApplyOverride(fmt::format("dds.domain={}", f.domain));
  if (!s.ok()) cli::Fail(cmd, s.message(), 2);
  const int64_t want = f.shards > 0 ? f.shards : (f.target == "replay" || f.target == "all" ? run.shards : 1);
  SetupLogging("coins-snapshot", "warn");
  if (dds.identity.empty()) dds.identity = "operator";
  auto node = dds::Node::Join(dds, "coins-snapshot");
  if (!node.ok()) cli::Fail(cmd, node.status().message(), 1);
  auto writer = (*node)->MakeWriter<msg::ControlPubSubType>(dds::kControlTopic, dds::CommandWriterQos());
  auto stats = (*node)->MakeReader<msg::ReplayStatsPubSubType>(dds::kReplayStatsTopic, dds::StatusReaderQos());
  if (!writer.ok() || !stats.ok()) cli::Fail(cmd, "cannot open DDS topics", 1);

  // a command id no earlier command used: time-based with random low bits
  uint64_t id = (uint64_t(std::chrono::system_clock::now().time_since_epoch().count()) & ~uint64_t(0xffff)) |
                (std::random_device{}() & 0xffff);
  msg::Control c;
  c.schema_version(msg::CONTROL_SCHEMA);
  c.command_id(id);
  c.target(f.target);
  c.command(msg::CONTROL_SNAPSHOT);
  auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(f.timeout);
  std::map<uint32_t, double> done;
  std::map<uint32_t, bool> seen;
  auto last_send = std::chrono::steady_clock::time_point{};
  msg::ReplayStats st;
  while (std::chrono::steady_clock::now() < end && int64_t(done.size()) < want) {
    // (re)send while shards may still be joining; shards act on a command id once
    if (writer->matched() > 0 && std::chrono::steady_clock::now() - last_send > std::chrono::milliseconds(500)) {
      writer->Write(c);
      last_send = std::chrono::steady_clock::now();
    }
    stats->Wait(std::chrono::milliseconds(100));
    stats->TakeAll(st, [&](const msg::ReplayStats& r, const auto&) {
      seen[r.shard_id()] = true;
      if (r.last_snapshot_command() >= id && !done.count(r.shard_id())) {
        done[r.shard_id()] = r.last_snapshot_s();
        std::cout << fmt::format("replay-{}: snapshot written in {:.3f} s ({} transitions held)\n", r.shard_id(),
                                 r.last_snapshot_s(), r.size());
      }
    });
  }
  if (int64_t(done.size()) < want)
    cli::Fail(cmd,
              fmt::format("{} of {} shards reported the snapshot within {} s ({} shards seen)", done.size(), want,
                          f.timeout, seen.size()),
              1);
}

}  // namespace

void AddReplayCommands(CLI::App& app) {
  CLI::App* replay = app.add_subcommand("replay", "Replay service tools.");
  replay->require_subcommand(1);
  auto path = std::make_shared<std::string>();
  auto json = std::make_shared<bool>(false);
  CLI::App* inspect = replay->add_subcommand("inspect", "Print a snapshot's header, counts and integrity.");
  inspect->add_option("snapshot", *path, "snapshot file")->required();
  inspect->add_flag("--json", *json, "print one JSON object");
  inspect->callback([path, json] { RunInspect(*path, *json); });

  auto f = std::make_shared<SnapshotFlags>();
  CLI::App* snap = app.add_subcommand("snapshot", "Ask running replay shards for a snapshot now and wait for it.");
  snap->add_option("--config", f->config, "YAML config file (its dds and run sections are used)")
      ->check(CLI::ExistingFile);
  snap->add_option("--domain", f->domain, "DDS domain id (overrides the config)")->check(CLI::Range(0, 232));
  snap->add_option("--target", f->target, "'replay' (every shard), 'all', or one shard's name ('replay-0')");
  snap->add_option("--shards", f->shards, "shards to wait for (default: run.shards, or 1 for one name)")
      ->check(cli::Integer(1, 256));
  snap->add_option("--timeout", f->timeout, "seconds to wait")->check(cli::Finite(0, 1e6, true));
  snap->callback([f] { RunSnapshot(*f); });
}

}  // namespace coins
