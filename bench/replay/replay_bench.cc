// coins-bench-replay: the replay service's figures. Breakout batches come from a real actor
// (captured in memory first, then replayed with fresh sequence numbers, so the env's speed
// does not limit the shard). Medians over --repeats runs.
//
//   inserts_per_s_1_actor / _2_actors   transitions/s stored by one coins-replay process fed
//                                       by 1 or 2 publisher participants over shared memory
//   samples_per_s_{uniform,prioritized}[_her]
//                                       transitions/s sampled at batch 256 through the DDS
//                                       sampling service (ReplayClient <-> coins-replay)
//   sampler_per_s_{uniform,prioritized}[_her]  the same, in-process (no DDS)
//   sampler_per_s_prioritized_levels    prioritised, restricted by a level_mask (in-process);
//   prioritized_levels_ratio            its ratio to the unrestricted prioritised draw
//   snapshot_write_s, snapshot_mb       a snapshot of 1M transitions (in-process shard)
//   insert_rate_baseline / insert_rate_during_snapshot, snapshot_insert_ratio
//   resume_s                            reading and restoring that snapshot
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <iostream>
#include <thread>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "actors/actor.h"
#include "bench/breakout_batches.h"
#include "bench/replay_shard.h"
#include "common/cli_checks.h"
#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "common/figures.h"
#include "common/process.h"
#include "idl/transitionPubSubTypes.h"
#include "learner/replay_client/replay_client.h"
#include "orchestrator/child_process.h"
#include "orchestrator/status_collector.h"
#include "replay/replay_service.h"

namespace coins {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

struct Args {
  double seconds = 2.0;
  int repeats = 3;
  int64_t snapshot_transitions = 1'000'000;
  bool json = false;
  int64_t domain = -1;  // -1: a free domain of the lease range
};

double Since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// the transitions/s one shard process stores from `publishers` participants over SHM
double InsertRate(const Args& a, const DdsOptions& ddso, StatusCollector& collector,
                  const std::vector<std::unique_ptr<msg::TransitionBatch>>& batches, int publishers,
                  uint32_t actor_base) {
  std::atomic<bool> stop{false};
  std::vector<std::thread> threads;
  for (int p = 0; p < publishers; ++p) {
    threads.emplace_back([&, p] {
      auto node = dds::Node::Create(ddso, "bench-publisher-" + std::to_string(p));
      if (!node.ok()) return;
      auto w = (*node)->MakeWriter<msg::TransitionBatchPubSubType>(
          dds::kTransitionTopic, dds::TransitionWriterQos(ddso), dds::ShardPartition(0));
      if (!w.ok()) return;
      while (w->matched() == 0 && !stop) std::this_thread::sleep_for(10ms);
      msg::TransitionBatch b;
      uint64_t incarnation = uint64_t(Clock::now().time_since_epoch().count());
      for (uint64_t seq = 0; !stop; ++seq) {
        b = *batches[seq % batches.size()];
        b.actor_id(actor_base + uint32_t(p));
        b.incarnation(incarnation);
        b.seq(seq);
        b.payload_hash(PayloadHash(b));  // the hash covers the header too
        while (!w->Write(b) && !stop) {
        }
      }
      w->WaitAcked(5s);
    });
  }
  // warm up, then count what the shard reports over the window
  auto inserted = [&] {
    StatusView v = collector.Snapshot();
    return v.shards.count(0) ? v.shards[0].sample.inserted_transitions() : 0;
  };
  std::this_thread::sleep_for(1s);
  uint64_t i0 = inserted();
  auto t0 = Clock::now();
  std::this_thread::sleep_for(std::chrono::duration<double>(a.seconds));
  uint64_t i1 = inserted();
  double rate = double(i1 - i0) / Since(t0);
  stop = true;
  for (auto& t : threads) t.join();
  return rate;
}

msg::SampleRequest Request(uint8_t strategy, bool her) {
  msg::SampleRequest q;
  q.schema_version(msg::SAMPLING_SCHEMA);
  q.correlation_id(1);
  q.shard_id(-1);
  q.batch_size(256);
  q.strategy(strategy);
  q.skill_level(-1);
  q.n_step(1);
  q.gamma(0.99f);
  q.timeout_ms(1000);
  if (her) {
    q.her_strategy(msg::HER_FUTURE);
    q.her_ratio(0.8f);
    q.goal_mask({1.0f, 1.0f});
    q.target_offset(0);
    q.goal_epsilon(0.5f);
  }
  return q;
}

// snapshot figures on an in-process shard of n transitions
void SnapshotFigures(const Args& a, const std::vector<std::unique_ptr<msg::TransitionBatch>>& batches, Figures* f) {
  fs::path dir = fs::temp_directory_path() / ("coins-bench-replay-snap-" + std::to_string(getpid()));
  fs::remove_all(dir);
  ReplayOptions o;
  o.capacity = a.snapshot_transitions;
  o.capacity_mb = 1024;
  o.snapshot_dir = dir.string();
  o.snapshot_keep = 1;
  ResumeReport report;
  auto service = ReplayService::Open(0, o, &report);
  if (!service.ok()) {
    std::cerr << "coins-bench-replay: " << service.status().message() << "\n";
    std::exit(1);
  }
  ReplayService& s = **service;
  uint64_t seq = 0;
  msg::TransitionBatch b;
  auto insert_for = [&](double seconds, const std::atomic<bool>* until_done) {
    auto t0 = Clock::now();
    uint64_t n = 0;
    while (until_done ? !until_done->load() : Since(t0) < seconds) {
      b = *batches[seq % batches.size()];
      b.seq(seq++);
      b.payload_hash(PayloadHash(b));  // the hash covers the header too
      s.Insert(b, 1s);
      n += CountTransitions(b);
    }
    return double(n) / Since(t0);
  };
  // fill to capacity (eviction keeps the size just below it)
  while (s.Stats(false).shard.inserted_transitions < uint64_t(a.snapshot_transitions)) insert_for(0.5, nullptr);
  std::vector<double> base, during, write_s, size_mb, ratio, resume;
  for (int r = 0; r < a.repeats; ++r) {
    double b0 = insert_for(a.seconds, nullptr);
    std::atomic<bool> done{false};
    Result<SnapshotWriteResult> w = Errorf("not run");
    std::thread writer([&] {
      LowerThreadPriority();  // as coins-replay's snapshot thread
      w = s.Snapshot(uint64_t(r + 1));
      done = true;
    });
    double d = insert_for(0, &done);
    writer.join();
    if (!w.ok()) {
      std::cerr << "coins-bench-replay: " << w.status().message() << "\n";
      std::exit(1);
    }
    base.push_back(b0);
    during.push_back(d);
    ratio.push_back(d / b0);
    write_s.push_back(w->seconds);
    size_mb.push_back(double(w->bytes) / 1e6);
    // resume: a second shard 0 opening the same directory (read, check, restore)
    auto img_t0 = Clock::now();
    ResumeReport r0;
    auto reopened = ReplayService::Open(0, o, &r0);
    if (!reopened.ok() || r0.transitions == 0) {
      std::cerr << "coins-bench-replay: resume failed: "
                << (reopened.ok() ? (r0.corrupt.empty() ? std::string("no transitions") : r0.corrupt.front())
                                  : reopened.status().message())
                << "\n";
      std::exit(1);
    }
    resume.push_back(Since(img_t0));
  }
  f->AddMedian("snapshot_transitions", std::vector<double>(1, double(s.size())), "transitions");
  f->AddMedian("snapshot_write_s", write_s, "s");
  f->AddMedian("snapshot_mb", size_mb, "MB");
  f->AddMedian("insert_rate_baseline", base, "transitions/s");
  f->AddMedian("insert_rate_during_snapshot", during, "transitions/s");
  f->AddMedian("snapshot_insert_ratio", ratio, "ratio");
  f->AddMedian("resume_s", resume, "s");
  fs::remove_all(dir);
}

// the sampling configurations measured: name, strategy, hindsight
constexpr std::tuple<const char*, uint8_t, bool> kSamplings[] = {{"uniform", msg::SAMPLE_UNIFORM, false},
                                                                 {"prioritized", msg::SAMPLE_PRIORITIZED, false},
                                                                 {"uniform_her", msg::SAMPLE_UNIFORM, true},
                                                                 {"prioritized_her", msg::SAMPLE_PRIORITIZED, true}};

// sampling over DDS from the filled shard
Status DdsSamplingFigures(const Args& a, dds::Node& node, Figures* f) {
  ReplayClientOptions co;
  co.shards = 1;
  co.timeout = 5s;
  auto client = ReplayClient::Create(node, co);
  if (!client.ok() || !(*client)->WaitForShards(20s)) return Errorf("sampling client did not match the shard");
  rl::Batch batch;
  for (auto [name, strategy, her] : kSamplings) {
    auto& o = (*client)->options();
    o.strategy = strategy;
    o.her_strategy = her ? msg::HER_FUTURE : msg::HER_NONE;
    o.her_ratio = her ? 0.8f : 0.0f;
    o.goal_mask = her ? std::vector<float>{1.0f, 1.0f} : std::vector<float>{};
    o.goal_epsilon = 0.5f;
    std::vector<double> rates;
    for (int r = 0; r < a.repeats; ++r) {
      auto t0 = Clock::now();
      uint64_t n = 0;
      while (Since(t0) < a.seconds) {
        COINS_RETURN_IF_ERROR((*client)->Sample(256, &batch));
        // priorities move as a learner's would
        if (strategy == msg::SAMPLE_PRIORITIZED) {
          std::vector<float> p(batch.keys.size(), 0.5f + float(n % 7));
          (*client)->UpdatePriorities(batch.keys, p);
        }
        n += 256;
      }
      rates.push_back(double(n) / Since(t0));
    }
    f->AddMedian(std::string("samples_per_s_") + name, rates, "transitions/s");
  }
  return Status::Ok();
}

// the sampler alone, in-process, on the same kind of data
void SamplerFigures(const Args& a, const std::vector<std::unique_ptr<msg::TransitionBatch>>& batches, Figures* f) {
  ReplayOptions o;
  o.capacity = 1'000'000;
  ResumeReport rep;
  auto s = ReplayService::Open(0, o, &rep);
  msg::TransitionBatch b;
  for (uint64_t seq = 0; seq < 4000; ++seq) {
    b = *batches[seq % batches.size()];
    b.seq(seq);
    b.payload_hash(PayloadHash(b));
    (*s)->Insert(b, 1s);
  }
  msg::SampleReply reply;
  for (auto [name, strategy, her] : kSamplings) {
    std::vector<double> rates;
    auto q = Request(strategy, her);
    for (int r = 0; r < a.repeats; ++r) {
      auto t0 = Clock::now();
      uint64_t n = 0;
      while (Since(t0) < a.seconds / 2) {
        (*s)->Sample(q, &reply, 1s);
        n += reply.n();
      }
      rates.push_back(double(n) / Since(t0));
    }
    f->AddMedian(std::string("sampler_per_s_") + name, rates, "transitions/s");
  }
  // prioritised draws restricted to skill levels (a chain's skill trains on its own level)
  // through the per-level masses, against the unrestricted prioritised draw above
  std::vector<double> rates;
  auto q = Request(msg::SAMPLE_PRIORITIZED, false);
  q.level_mask(0xFF);
  for (int r = 0; r < a.repeats; ++r) {
    auto t0 = Clock::now();
    uint64_t n = 0;
    while (Since(t0) < a.seconds / 2) {
      (*s)->Sample(q, &reply, 1s);
      if (reply.n() == 0) {
        std::cerr << "coins-bench-replay: level-restricted sampling: " << reply.error() << "\n";
        return;
      }
      n += reply.n();
    }
    rates.push_back(double(n) / Since(t0));
  }
  f->AddMedian("sampler_per_s_prioritized_levels", rates, "transitions/s");
  f->Add("prioritized_levels_ratio", f->Get("sampler_per_s_prioritized_levels") / f->Get("sampler_per_s_prioritized"),
         "x");
}

int Main(int argc, char** argv) {
  Args a;
  CLI::App app("Replay service figures: inserts, samples, snapshots, resume", "coins-bench-replay");
  app.add_option("--seconds", a.seconds, "seconds per measurement")->check(cli::Finite(0, 3600, true));
  bench::AddDomainOption(app, &a.domain);
  app.add_option("--repeats", a.repeats, "measurements of each kind (medians are printed)")->check(CLI::Range(1, 100));
  app.add_option("--snapshot-transitions", a.snapshot_transitions, "transitions in the snapshot figures")
      ->check(CLI::Range(int64_t(10000), int64_t(1) << 30));
  app.add_flag("--json", a.json, "print one JSON object");
  CLI11_PARSE(app, argc, argv);
  SetupLogging("bench", "warn");
  auto batches = bench::BreakoutBatches(400);
  Figures f;

  // one shard process on a private domain
  int exit_code = 0;
  auto process = bench::StartReplayShard("coins-bench-replay", int(a.domain),
                                         {"replay.capacity=1000000", "replay.status_period_s=0.1"}, &exit_code);
  if (!process.ok()) {
    std::cerr << "coins-bench-replay: " << process.status().message() << "\n";
    return exit_code;
  }
  const DdsOptions& dds = process->dds;
  std::vector<ChildProcess>& shard = process->processes;
  auto node = dds::Node::Create(dds, "bench-replay");
  if (!node.ok()) return 1;
  auto collector = StatusCollector::Start(**node);
  if (!collector.ok()) return 1;
  std::vector<double> one, two;
  for (int r = 0; r < a.repeats; ++r) {
    one.push_back(InsertRate(a, dds, **collector, batches, 1, 10 + 4 * r));
    two.push_back(InsertRate(a, dds, **collector, batches, 2, 11 + 4 * r + 1));
  }
  f.AddMedian("inserts_per_s_1_actor", one, "transitions/s");
  f.AddMedian("inserts_per_s_2_actors", two, "transitions/s");

  Status sampled = DdsSamplingFigures(a, **node, &f);
  StopAll(shard, 10s);
  fs::remove_all(process->dir);
  if (!sampled.ok()) {
    std::cerr << "coins-bench-replay: " << sampled.message() << "\n";
    return 1;
  }
  SamplerFigures(a, batches, &f);
  SnapshotFigures(a, batches, &f);
  f.Print(a.json);
  return 0;
}

}  // namespace
}  // namespace coins

int main(int argc, char** argv) { return coins::Main(argc, argv); }
