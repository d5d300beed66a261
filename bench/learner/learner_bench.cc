// coins-bench-learner: learner updates/s sampling from replay shards over DDS against the same
// learner sampling from in-process shards, in one run. Breakout batches from a real actor fill
// K coins-replay processes (over DDS, shared memory) and K in-process ReplayService shards
// alike; the learner is an rl::Dqn (6 x 128 hidden, C51, dueling, double Q) on a goal-conditioned
// spec: obs = the Paddle and Ball features plus a goal over the Ball's velocity (hindsight,
// 3-step returns), batch 128. Medians over --repeats; in each repeat the variants take turns
// in slices of --seconds / 4.
//
//   learner_updates_per_s_inprocess   InProcessSource, no prefetch (the baseline)
//   learner_updates_per_s_dds         ReplayClient behind a PrefetchingSource (depth --depth)
//   learner_updates_per_s_dds_sync    ReplayClient, no prefetch
//   learner_updates_per_s_inprocess_prefetch   InProcessSource behind a PrefetchingSource (for
//                                     reading the others: on a busy machine a second thread
//                                     alone can change the learner's share of the CPU)
//   learner_dds_ratio                 dds / inprocess (median of per-repeat ratios; aim >= 0.8)
//   learner_dds_sync_ratio            dds_sync / inprocess
//   sample_rtt_ms                     one Sample() of the batch over DDS (round trip), median
//   sample_inprocess_ms               the same in-process
//   update_ms                         one Dqn update on a ready batch
//   learner_thread_cpu_ms_*           CPU time of the learner's thread per update, per variant
//                                     (with the rates, tells CPU cost from waiting and from
//                                     the share of the CPU a busy machine leaves the learner)
//   prefetch_ready_fraction           batches the prefetcher had ready when the learner asked
#include <unistd.h>

#include <time.h>

#include <filesystem>
#include <iostream>
#include <random>
#include <thread>

#include <CLI/CLI.hpp>

#include "bench/breakout_batches.h"
#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "common/figures.h"
#include "common/process.h"
#include "common/transition_batch.h"
#include "idl/transitionPubSubTypes.h"
#include "learner/replay_client/in_process_source.h"
#include "learner/replay_client/prefetcher.h"
#include "learner/replay_client/replay_client.h"
#include "learner/rl/dqn.h"
#include "orchestrator/child_process.h"
#include "orchestrator/status_collector.h"

namespace coins {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

struct Args {
  int domain = -1;  // -1: 100 + pid % 100
  int shards = 2;
  int64_t fill = 100'000;  // transitions per shard
  int batch = 128;
  int depth = 2;
  double seconds = 3.0;
  int repeats = 3;
  bool json = false;
};

double Since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

[[noreturn]] void Fail(const std::string& what) {
  std::cerr << "coins-bench-learner: " << what << "\n";
  std::exit(1);
}

// obs = Paddle and Ball features; goal over the Ball's velocity (vy, vx)
SampleSpec LearnerSpec(const envs::EnvSpec& env) {
  SampleSpec s;
  for (const char* name : {"Paddle", "Ball"}) {
    int f = env.factor_index(name);
    if (f < 0) Fail(std::string("no factor ") + name);
    for (int j = 0; j < env.factors[size_t(f)].size(); ++j) s.features.push_back(uint16_t(env.factor_offset(f) + j));
  }
  s.target_offset = uint32_t(env.factor_offset(env.factor_index("Ball")));
  s.goal_mask = {0, 0, 1, 1, 0};
  s.goal_epsilon = 0.1f;
  s.her_strategy = msg::HER_FUTURE;
  s.her_ratio = 0.5f;
  s.n_step = 3;
  s.gamma = 0.99f;
  return s;
}

rl::DqnOptions Network(const SampleSpec& spec, const envs::EnvSpec& env, int batch) {
  rl::DqnOptions o;
  o.obs_dim = int(spec.features.size() + spec.goal_mask.size());
  o.num_actions = env.action.n;
  o.hidden = std::vector<int>(6, 128);
  o.batch_size = batch;
  o.seed = 1;
  return o;
}

// the batches one shard gets: actor `actor`, sequence numbers from 0, about `fill` transitions
template <typename Sink>
void FeedShard(const std::vector<std::unique_ptr<msg::TransitionBatch>>& batches, uint32_t actor, int64_t fill,
               Sink&& sink) {
  msg::TransitionBatch b;
  int64_t sent = 0;
  for (uint64_t seq = 0; sent < fill; ++seq) {
    b = *batches[seq % batches.size()];
    b.actor_id(actor);
    b.incarnation(1000 + actor);
    b.seq(seq);
    b.payload_hash(PayloadHash(b));  // the hash covers the header too
    sent += CountTransitions(b);
    sink(b);
  }
}

// K coins-replay processes on the bench's domain, filled over DDS
struct DdsShards {
  std::vector<ChildProcess> children;
  std::unique_ptr<dds::Node> node;
  std::unique_ptr<StatusCollector> collector;
  ~DdsShards() {
    collector.reset();
    StopAll(children, 10s);
  }
};

void StartShards(const Args& a, const DdsOptions& ddso, const fs::path& dir, DdsShards* s) {
  for (int k = 0; k < a.shards; ++k) {
    std::string name = "replay-" + std::to_string(k);
    auto child = ChildProcess::Spawn(
        name,
        {SelfDirectory() + "/coins-replay", "--id", std::to_string(k), "--name", name, "--quiet-config", "--set",
         "run.shards=" + std::to_string(a.shards), "--set", "dds.domain=" + std::to_string(ddso.domain), "--set",
         "replay.capacity=" + std::to_string(2 * a.fill + 100000), "--set", "replay.capacity_mb=256", "--set",
         "replay.status_period_s=0.1"},
        (dir / (name + ".log")).string());
    if (!child.ok()) Fail(child.status().message());
    s->children.push_back(std::move(*child));
  }
  auto node = dds::Node::Create(ddso, "bench-learner");
  if (!node.ok()) Fail(node.status().message());
  s->node = std::move(*node);
  auto collector = StatusCollector::Start(*s->node);
  if (!collector.ok()) Fail(collector.status().message());
  s->collector = std::move(*collector);
}

void FillDdsShards(const Args& a, const DdsOptions& ddso, DdsShards* s,
                   const std::vector<std::unique_ptr<msg::TransitionBatch>>& batches) {
  for (int k = 0; k < a.shards; ++k) {
    auto w = s->node->MakeWriter<msg::TransitionBatchPubSubType>(dds::kTransitionTopic, dds::TransitionWriterQos(ddso),
                                                                 dds::ShardPartition(k));
    if (!w.ok()) Fail(w.status().message());
    auto t0 = Clock::now();
    while (w->matched() == 0 && Since(t0) < 30) std::this_thread::sleep_for(10ms);
    if (w->matched() == 0) Fail("shard " + std::to_string(k) + " did not match the bench's writer");
    FeedShard(batches, uint32_t(100 + k), a.fill, [&](const msg::TransitionBatch& b) {
      auto until = Clock::now() + 10s;
      while (!w->Write(b))
        if (Clock::now() > until) Fail("shard " + std::to_string(k) + " stopped taking batches");
    });
    if (!w->WaitAcked(30s)) Fail("shard " + std::to_string(k) + " did not acknowledge its batches");
  }
  // the shards report what they hold
  auto t0 = Clock::now();
  for (int k = 0; k < a.shards; ++k)
    for (;;) {
      StatusView v = s->collector->Snapshot();
      auto it = v.shards.find(uint32_t(k));
      if (it != v.shards.end() && int64_t(it->second.sample.size()) >= a.fill) break;
      if (Since(t0) > 60) Fail("shard " + std::to_string(k) + " did not report its transitions");
      std::this_thread::sleep_for(50ms);
    }
}

// updates/s of the learner sampling from source for `seconds` (after a short warm-up)
// updates done and seconds spent by the learner sampling from source for `seconds`, after
// two untimed updates (a prefetcher's first batch, caches)
struct Slice {
  double updates = 0, seconds = 0, cpu_seconds = 0;  // cpu: of the learner's thread
  double rate() const { return seconds > 0 ? updates / seconds : 0; }
  double cpu_ms() const { return updates > 0 ? 1e3 * cpu_seconds / updates : 0; }
};
double ThreadCpuSeconds() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}
void Train(rl::Dqn* dqn, rl::BatchSource* source, double seconds, Slice* total) {
  for (int i = 0; i < 2; ++i)
    if (auto r = dqn->Train(source); !r.ok()) Fail(r.status().message());
  auto t0 = Clock::now();
  const double cpu0 = ThreadCpuSeconds();
  int64_t n = 0;
  while (Since(t0) < seconds) {
    if (auto r = dqn->Train(source); !r.ok()) Fail(r.status().message());
    ++n;
  }
  total->updates += double(n);
  total->seconds += Since(t0);
  total->cpu_seconds += ThreadCpuSeconds() - cpu0;
}

// median milliseconds of one Sample() of the batch
double SampleMs(SampleSource* source, const SampleSpec& spec, int batch, int calls) {
  SampleColumns c;
  std::vector<double> ms;
  for (int i = 0; i < calls + 3; ++i) {
    auto t0 = Clock::now();
    if (Status s = source->Sample(spec, batch, &c); !s.ok()) Fail(s.message());
    if (i >= 3) ms.push_back(Since(t0) * 1e3);
  }
  return Median(ms);
}

double UpdateMs(rl::Dqn* dqn, SampleSource* source, const SampleSpec& spec, int batch, int updates) {
  SampleBatchSource batches(source, spec);
  rl::Batch b;
  if (Status s = batches.Sample(batch, &b); !s.ok()) Fail(s.message());
  auto t0 = Clock::now();
  for (int i = 0; i < updates; ++i) dqn->Update(b);
  return Since(t0) * 1e3 / updates;
}

struct Rates {
  std::vector<double> local, dds, sync, local_pf, ratio, sync_ratio, rtt, local_ms, update_ms, ready;
  std::vector<double> cpu_local, cpu_dds, cpu_sync, cpu_local_pf;
};

// one repeat: the variants take turns in short slices (so that load from other processes on a
// shared machine falls on all of them alike), each with its own network
void Repeat(const Args& a, const SampleSpec& spec, const rl::DqnOptions& net, InProcessSource* local,
            ReplayClient* client, Rates* r) {
  constexpr int kSlices = 4;
  rl::Dqn d_local(net), d_dds(net), d_sync(net), d_local_pf(net);
  SampleBatchSource local_batches(local, spec), sync_batches(client, spec);
  Slice l, d, s, lp;
  PrefetchStats st;
  // a prefetcher owns its source while it lives
  auto prefetched = [&](SampleSource* source, rl::Dqn* dqn, Slice* slice, PrefetchStats* stats) {
    auto prefetch = PrefetchingSource::Create(source, {.depth = a.depth, .wait = 10s});
    if (!prefetch.ok()) Fail(prefetch.status().message());
    SampleBatchSource batches(prefetch->get(), spec);
    Train(dqn, &batches, a.seconds / kSlices, slice);
    PrefetchStats one = (*prefetch)->stats();
    stats->batches += one.batches;
    stats->ready += one.ready;
  };
  for (int i = 0; i < kSlices; ++i) {
    Train(&d_local, &local_batches, a.seconds / kSlices, &l);
    prefetched(client, &d_dds, &d, &st);
    Train(&d_sync, &sync_batches, a.seconds / kSlices, &s);
    PrefetchStats ignored;
    prefetched(local, &d_local_pf, &lp, &ignored);
  }
  r->local.push_back(l.rate());
  r->local_pf.push_back(lp.rate());
  r->cpu_local.push_back(l.cpu_ms());
  r->cpu_dds.push_back(d.cpu_ms());
  r->cpu_sync.push_back(s.cpu_ms());
  r->cpu_local_pf.push_back(lp.cpu_ms());
  r->dds.push_back(d.rate());
  r->sync.push_back(s.rate());
  r->ratio.push_back(d.rate() / l.rate());
  r->sync_ratio.push_back(s.rate() / l.rate());
  r->ready.push_back(st.batches ? double(st.ready) / double(st.batches) : 0);
  r->rtt.push_back(SampleMs(client, spec, a.batch, 50));
  r->local_ms.push_back(SampleMs(local, spec, a.batch, 50));
  r->update_ms.push_back(UpdateMs(&d_local, local, spec, a.batch, 50));
}

int Main(int argc, char** argv) {
  Args a;
  CLI::App app("Learner updates/s from replay shards over DDS against in-process shards", "coins-bench-learner");
  app.add_option("--domain", a.domain,
                 "DDS domain of the bench's shards (default 100 + pid % 100); never one "
                 "another live test or bench uses")
      ->check(CLI::Range(0, 232));
  app.add_option("--shards", a.shards, "replay shards")->check(CLI::Range(1, 8));
  app.add_option("--fill", a.fill, "transitions per shard")->check(CLI::Range(int64_t(10000), int64_t(10'000'000)));
  app.add_option("--batch", a.batch, "learner batch size")->check(CLI::Range(1, 4096));
  app.add_option("--depth", a.depth, "prefetch depth (batches ready ahead)")->check(CLI::Range(1, 2));
  app.add_option("--seconds", a.seconds, "seconds per variant and repeat")->check(CLI::PositiveNumber);
  app.add_option("--repeats", a.repeats, "measurements of each kind (medians are printed)")->check(CLI::Range(1, 100));
  app.add_flag("--json", a.json, "print one JSON object");
  CLI11_PARSE(app, argc, argv);
  SetupLogging("bench", "warn");

  envs::EnvSpec env;
  auto batches = bench::BreakoutBatches(400, 256, &env);
  const SampleSpec spec = LearnerSpec(env);
  const rl::DqnOptions net = Network(spec, env, a.batch);
  if (Status s = net.Validate(); !s.ok()) Fail(s.message());

  // in-process shards
  std::vector<std::unique_ptr<ReplayService>> services;
  std::vector<ReplayService*> raw;
  for (int k = 0; k < a.shards; ++k) {
    ReplayOptions o;
    o.capacity = 2 * a.fill + 100000;
    o.capacity_mb = 256;
    ResumeReport report;
    auto s = ReplayService::Open(uint32_t(k), o, &report);
    if (!s.ok()) Fail(s.status().message());
    FeedShard(batches, uint32_t(100 + k), a.fill, [&](const msg::TransitionBatch& b) { (*s)->Insert(b, 1s); });
    raw.push_back(s->get());
    services.push_back(std::move(*s));
  }
  InProcessSource local(raw);

  // the same data in coins-replay processes
  DdsOptions ddso;
  ddso.domain = a.domain >= 0 ? a.domain : 100 + getpid() % 100;
  auto dir = fs::temp_directory_path() / ("coins-bench-learner-" + std::to_string(getpid()));
  fs::create_directories(dir);
  DdsShards shards;
  StartShards(a, ddso, dir, &shards);
  FillDdsShards(a, ddso, &shards, batches);
  ReplayClientOptions co;
  co.shards = a.shards;
  co.timeout = 5s;
  auto client = ReplayClient::Create(*shards.node, co);
  if (!client.ok() || !(*client)->WaitForShards(20s)) Fail("the sampling client did not match the shards");

  Rates r;
  for (int i = 0; i < a.repeats; ++i) Repeat(a, spec, net, &local, client->get(), &r);
  Figures f;
  f.Add("learner_batch", a.batch, "transitions");
  f.Add("learner_obs_dim", net.obs_dim, "features");
  f.AddMedian("learner_updates_per_s_inprocess", r.local, "updates/s");
  f.AddMedian("learner_updates_per_s_dds", r.dds, "updates/s");
  f.AddMedian("learner_updates_per_s_dds_sync", r.sync, "updates/s");
  f.AddMedian("learner_updates_per_s_inprocess_prefetch", r.local_pf, "updates/s");
  f.AddMedian("learner_dds_ratio", r.ratio, "ratio");
  f.AddMedian("learner_dds_sync_ratio", r.sync_ratio, "ratio");
  f.AddMedian("sample_rtt_ms", r.rtt, "ms");
  f.AddMedian("sample_inprocess_ms", r.local_ms, "ms");
  f.AddMedian("update_ms", r.update_ms, "ms");
  f.AddMedian("learner_thread_cpu_ms_inprocess", r.cpu_local, "ms/update");
  f.AddMedian("learner_thread_cpu_ms_dds", r.cpu_dds, "ms/update");
  f.AddMedian("learner_thread_cpu_ms_dds_sync", r.cpu_sync, "ms/update");
  f.AddMedian("learner_thread_cpu_ms_inprocess_prefetch", r.cpu_local_pf, "ms/update");
  f.AddMedian("prefetch_ready_fraction", r.ready, "ratio");
  client->reset();
  f.Print(a.json);
  fs::remove_all(dir);
  return 0;
}

}  // namespace
}  // namespace coins

int main(int argc, char** argv) { return coins::Main(argc, argv); }
