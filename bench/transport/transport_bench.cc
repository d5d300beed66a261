// coins-bench-transport: how much of an actor's standalone step rate survives publishing every
// transition to a replay shard process over Fast DDS shared memory (data-sharing, loaned
// samples). Standalone and published runs alternate, and the figures are medians.
//
//   standalone_steps_per_s     one actor stepping Breakout into batches kept in memory
//   transport_steps_per_s      the same actor publishing to one coins-replay process, counted
//                              once the shard has acknowledged every batch
//   transport_ratio            transport / standalone (goal: >= 0.8)
#include <unistd.h>

#include <filesystem>
#include <iostream>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "actors/actor.h"
#include "bench/replay_shard.h"
#include "common/cli_checks.h"
#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "common/figures.h"
#include "common/process.h"
#include "idl/transitionPubSubTypes.h"
#include "orchestrator/child_process.h"

namespace coins {
namespace {

struct Args {
  std::string env = "breakout";
  double seconds = 2.0;
  int repeats = 5;
  bool json = false;
  int64_t domain = -1;  // -1: a free domain of the lease range
  std::string only;     // "standalone" or "transport": measure one kind (for profiling)
};

// steps per second of one actor run of `seconds` into `sink` (including the final flush)
double TimedRun(const Args& a, BatchSink* sink, uint64_t seed) {
  ActorOptions options;
  auto actor = Actor::Create(a.env, options, 0, seed, sink);
  if (!actor.ok()) {
    std::cerr << "coins-bench-transport: " << actor.status().message() << "\n";
    std::exit(2);
  }
  auto start = std::chrono::steady_clock::now();
  auto end = start + std::chrono::duration<double>(a.seconds);
  (*actor)->Run(
      0, [&] { return std::chrono::steady_clock::now() >= end; }, [](const ActorCounters&) {}, std::chrono::hours(1));
  sink->Flush(std::chrono::seconds(30));
  double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return double((*actor)->counters().transitions_published) / dt;
}

int Main(int argc, char** argv) {
  Args a;
  CLI::App app("Actor step rate standalone and publishing to one replay shard over shared memory",
               "coins-bench-transport");
  app.add_option("--env", a.env, "environment");
  app.add_option("--seconds", a.seconds, "seconds per measurement")->check(cli::Finite(0, 3600, true));
  bench::AddDomainOption(app, &a.domain);
  app.add_option("--repeats", a.repeats, "measurements of each kind (medians are printed)")->check(CLI::Range(1, 100));
  app.add_flag("--json", a.json, "print one JSON object");
  app.add_option("--only", a.only, "measure only one kind (for profiling)")
      ->check(CLI::IsMember({"standalone", "transport"}));
  CLI11_PARSE(app, argc, argv);
  SetupLogging("bench", "warn");

  // one replay shard process on a private domain
  int exit_code = 0;
  auto process = bench::StartReplayShard("coins-bench-transport", int(a.domain),
                                         {"run.env=" + a.env, "replay.capacity=300000"}, &exit_code);
  if (!process.ok()) {
    std::cerr << "coins-bench-transport: " << process.status().message() << "\n";
    return exit_code;
  }
  const DdsOptions& dds = process->dds;
  std::vector<ChildProcess>& shard = process->processes;

  // every wait is bounded: a shard that dies or stops acknowledging ends the benchmark
  bool stop = false;
  auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(a.seconds * a.repeats * 4 + 60);
  auto sink = DdsBatchSink::Create(dds, "bench-transport", 0, [&] {
    return stop || shard[0].Poll() || std::chrono::steady_clock::now() > deadline;
  });
  if (!sink.ok()) {
    std::cerr << sink.status().message() << "\n";
    StopAll(shard, std::chrono::seconds(10));
    return 1;
  }
  DdsBatchSink& dds_sink = **sink;
  MemoryBatchSink memory_sink;
  // warm-up: wait for the match and touch the shard's first pages
  {
    Args warm = a;
    warm.seconds = 0.5;
    TimedRun(warm, &dds_sink, 99);
  }
  std::vector<double> standalone, transport;
  for (int r = 0; r < a.repeats; ++r) {
    if (a.only != "transport") standalone.push_back(TimedRun(a, &memory_sink, r + 1));
    if (a.only != "standalone") transport.push_back(TimedRun(a, &dds_sink, r + 1));
  }
  bool timed_out = std::chrono::steady_clock::now() > deadline;
  stop = true;
  StopAll(shard, std::chrono::seconds(10));
  if (timed_out) {
    std::cerr << "coins-bench-transport: the shard stopped acknowledging; figures are not valid\n";
    return 1;
  }
  std::filesystem::remove_all(process->dir);

  Figures f;
  f.AddMedian("standalone_steps_per_s", standalone, "steps/s");
  f.AddMedian("transport_steps_per_s", transport, "steps/s");
  f.Add("transport_ratio", f.Get("transport_steps_per_s") / f.Get("standalone_steps_per_s"), "ratio");
  f.Print(a.json);
  return 0;
}

}  // namespace
}  // namespace coins

int main(int argc, char** argv) { return coins::Main(argc, argv); }
