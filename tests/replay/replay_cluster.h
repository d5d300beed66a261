// Helpers for the replay service's system tests: real coins-replay and coins-actor processes
// on a private DDS domain, a test-side DDS node with a ReplayClient and a StatusCollector.
#pragma once

#include <signal.h>

#include <utility>

#include <gtest/gtest.h>

#include "common/dds/node.h"
#include "learner/replay_client/replay_client.h"
#include "orchestrator/status_collector.h"
#include "tests/process_harness.h"

namespace coins::testing {

struct ReplayCluster {
  ReplayCluster(std::filesystem::path dir_, int domain_) : dir(std::move(dir_)), domain(domain_) {}

  std::filesystem::path dir;
  int domain;
  int shards_n = 2, actors_n = 2;
  std::vector<ChildProcess> shards, actors;
  std::unique_ptr<dds::Node> node;
  std::unique_ptr<StatusCollector> collector;

  std::vector<std::string> Common(const std::string& binary, const std::string& name, int id) {
    return {Bin(binary),
            "--name",
            name,
            "--id",
            std::to_string(id),
            "--quiet-config",
            "--set",
            "dds.domain=" + std::to_string(domain),
            "--set",
            "run.shards=" + std::to_string(shards_n),
            "--set",
            "run.actors=" + std::to_string(actors_n),
            "--set",
            "replay.capacity=400000",
            "--set",
            "replay.capacity_mb=64",
            "--set",
            "replay.status_period_s=0.2",
            "--set",
            "actor.status_period_s=0.2",
            "--stats-out",
            (dir / (name + ".json")).string()};
  }
  // starts shard k (extra: more flags); replaces a dead one in place
  void StartShard(int k, std::vector<std::string> extra = {}) {
    std::string name = "replay-" + std::to_string(k);
    auto argv = Common("coins-replay", name, k);
    argv.insert(argv.end(), extra.begin(), extra.end());
    auto c = ChildProcess::Spawn(name, argv, (dir / (name + ".log")).string());
    ASSERT_TRUE(c.ok()) << c.status().message();
    if (size_t(k) < shards.size())
      shards[size_t(k)] = std::move(*c);
    else
      shards.push_back(std::move(*c));
  }
  void StartShards(std::vector<std::string> extra = {}) {
    for (int k = 0; k < shards_n; ++k) StartShard(k, extra);
  }
  // steps 0: run until stopped
  void StartActors(int64_t steps) {
    for (int i = 0; i < actors_n; ++i) {
      std::string name = "actor-" + std::to_string(i);
      auto argv = Common("coins-actor", name, i);
      // no orchestrator here: random actions, no chain pacing
      argv.insert(argv.end(),
                  {"--set", "actor.follow_chain=false", "--set", "actor.steps=" + std::to_string(steps), "--set",
                   "actor.batch_rows=64", "--set", "actor.envs=2", "--set", "run.seed=" + std::to_string(11 + i)});
      if (steps == 0) argv.insert(argv.end(), {"--set", "run.steps=0"});
      auto c = ChildProcess::Spawn(name, argv, (dir / (name + ".log")).string());
      ASSERT_TRUE(c.ok()) << c.status().message();
      actors.push_back(std::move(*c));
    }
  }
  void Join() {
    DdsOptions dds;
    dds.domain = domain;
    auto n = dds::Node::Create(dds, "replay-test");
    ASSERT_TRUE(n.ok()) << n.status().message();
    node = std::move(*n);
    auto c = StatusCollector::Start(*node);
    ASSERT_TRUE(c.ok()) << c.status().message();
    collector = std::move(*c);
  }
  std::unique_ptr<ReplayClient> Client(ReplayClientOptions o = {}) {
    o.shards = shards_n;
    auto c = ReplayClient::Create(*node, o);
    EXPECT_TRUE(c.ok()) << c.status().message();
    return c.ok() ? std::move(*c) : nullptr;
  }
  // the newest ReplayStats of shard k (schema 0 when none yet)
  msg::ReplayStats Stats(uint32_t k) {
    StatusView v = collector->Snapshot();
    auto it = v.shards.find(k);
    return it == v.shards.end() ? msg::ReplayStats{} : it->second.sample;
  }
  // runs coins-replay-cli with arguments
  CommandResult Cli(const std::string& args) { return RunCommand(Bin("coins-replay-cli") + " " + args); }
  ~ReplayCluster() {
    collector.reset();
    StopAll(actors, Scaled(std::chrono::seconds(5)));
    StopAll(shards, Scaled(std::chrono::seconds(5)));
    // snapshots are large; logs and stats files stay for a failed test's reader
    std::error_code ec;
    std::filesystem::remove_all(dir / "snapshots", ec);
  }
};

}  // namespace coins::testing
