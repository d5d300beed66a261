#include "orchestrator/launcher.h"

#include <signal.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <thread>

#include <fmt/format.h>

#include "common/cli_checks.h"
#include "common/dds/participant_ids.h"
#include "common/process.h"
#include "orchestrator/child_process.h"
#include "orchestrator/run_report.h"
#include "orchestrator/run_setup.h"
#include "orchestrator/status_collector.h"
#include "orchestrator/supervisor.h"
#include "orchestrator/system_config.h"

namespace coins {

namespace {

std::string Rate(double x) {
  if (x >= 1e6) return fmt::format("{:.2f}M", x / 1e6);
  if (x >= 1e3) return fmt::format("{:.1f}k", x / 1e3);
  return fmt::format("{:.0f}", x);
}

std::string ProgressLine(const StatusView& v, double elapsed, int64_t actors) {
  std::string line = fmt::format("[{:7.1f}s] steps {} ({}/s, {}/{} actors)", elapsed, Rate(double(v.total_steps())),
                                 Rate(v.total_steps_per_s()), v.actors.size(), actors);
  for (const auto& [id, s] : v.shards) {
    const auto& r = s.sample;
    double fill = r.capacity() ? 100.0 * double(r.size()) / double(r.capacity()) : 0.0;
    line += fmt::format(" | replay-{} {} {:.1f}% ({}/s)", id, Rate(double(r.size())), fill, Rate(r.insert_rate()));
  }
  return line;
}

// creates the run directory (fresh: without the previous run's state) and writes config.yaml
Status PrepareDirectory(const SystemConfig& c, RunPlan* plan, std::string* config_path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(fs::path(c.run.dir) / "logs", ec);
  if (ec) return Errorf("cannot create run directory {}: {}", c.run.dir, ec.message());
  if (plan->resume_epoch < 0) COINS_RETURN_IF_ERROR(ClearPreviousRun(c, plan));
  *config_path = (fs::path(c.run.dir) / "config.yaml").string();
  std::ofstream(*config_path) << plan->effective;
  return Status::Ok();
}

// shards first so actors find them, then learner and orchestrator, then actors; shards, learner
// and orchestrator of a resumed run start from the epoch's files (first start only)
Status StartChildren(Supervisor& sup, const SystemConfig& c, const std::string& config_path, int64_t resume_epoch) {
  const std::string bin = SelfDirectory();
  auto spec = [&](const std::string& binary, const std::string& name, int64_t id, bool resumes) {
    ChildSpec s{name, {bin + "/" + binary, "--config", config_path, "--name", name}, {}, binary == "coins-actor"};
    if (id >= 0) s.argv.insert(s.argv.end(), {"--id", std::to_string(id)});
    if (resumes && resume_epoch >= 0) s.first_start = {"--resume-epoch", std::to_string(resume_epoch)};
    return s;
  };
  for (int64_t k = 0; k < c.run.shards; ++k)
    COINS_RETURN_IF_ERROR(sup.Start(spec("coins-replay", fmt::format("replay-{}", k), k, true)));
  COINS_RETURN_IF_ERROR(sup.Start(spec("coins-learner", "learner", -1, true)));
  COINS_RETURN_IF_ERROR(sup.Start(spec("coins-orchestrator", "orchestrator", -1, true)));
  for (int64_t i = 0; i < c.run.actors; ++i)
    COINS_RETURN_IF_ERROR(sup.Start(spec("coins-actor", fmt::format("actor-{}", i), i, false)));
  return Status::Ok();
}

// one progress line and one metrics row a second
class Progress {
 public:
  Progress(const SystemConfig& c, bool quiet, std::optional<RunMetrics> metrics)
      : c_(c), quiet_(quiet), metrics_(std::move(metrics)) {}
  void Tick(const StatusView& v, const Supervisor& sup, std::chrono::steady_clock::time_point now) {
    if (now < next_) return;
    next_ = (next_ == std::chrono::steady_clock::time_point{} ? now : next_) + std::chrono::seconds(1);
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    if (!quiet_) std::cout << Line(v, sup, elapsed) << std::endl;
    const uint64_t steps = v.total_steps();
    const double rate =
        elapsed > last_wall_ ? double(steps - std::min(steps, last_steps_)) / (elapsed - last_wall_) : 0;
    if (metrics_) metrics_->Append(MakeRow(v, elapsed, rate, sup.restarts()));
    last_steps_ = steps, last_wall_ = elapsed;
  }
  std::string Line(const StatusView& v, const Supervisor& sup, double elapsed) const {
    return ProgressLine(v, elapsed, c_.run.actors) + " | " + ChainProgress(v, sup.restarts());
  }
  double elapsed() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }
  std::optional<RunMetrics>& metrics() { return metrics_; }

 private:
  const SystemConfig& c_;
  bool quiet_;
  std::optional<RunMetrics> metrics_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now(), next_{};
  uint64_t last_steps_ = 0;
  double last_wall_ = 0;
};

struct RunOutcome {
  std::string failure;      // a child that could not be kept running
  bool chain_done = false;  // ChainStatus.phase reached done
};

// watches children and status until the chain is done, the step budget is reached, a child
// fails for good, or a stop is requested
RunOutcome WatchRun(Supervisor& sup, StatusCollector& collector, const SystemConfig& c, Progress& progress) {
  RunOutcome out;
  bool actors_done = false;
  std::chrono::steady_clock::time_point drain_deadline;
  while (!StopRequested()) {
    const auto now = std::chrono::steady_clock::now();
    for (const auto& e : sup.Poll(now, c.run.steps > 0)) {
      // restarts are said as they happen; a failure ends the run and is said then
      if (e.kind == Supervisor::Event::Kind::kRestarting || e.kind == Supervisor::Event::Kind::kRestarted)
        std::cerr << "coins run: " << e.line << "\n";
      if (e.kind == Supervisor::Event::Kind::kFailed && out.failure.empty())
        out.failure = fmt::format("{}; see {}/logs/{}.log", e.line, c.run.dir, e.name);
    }
    if (!out.failure.empty()) break;
    StatusView view = collector.Snapshot();
    if (view.chain && view.chain->sample.phase() == "done") {
      out.chain_done = true;
      break;
    }
    // after the actors finish, wait for the shards to hold everything they published
    if (sup.actors_done() && !actors_done) {
      actors_done = true;
      drain_deadline = now + std::chrono::seconds(10);
    }
    if (actors_done) {
      // every actor that finished published at least its share of run.steps (one transition per
      // env step and level stream), and its final report says how many
      uint64_t expected = uint64_t(c.run.actors) * ((c.run.steps + c.run.actors - 1) / c.run.actors);
      if (c.actor.steps) expected = uint64_t(c.run.actors) * c.actor.steps;
      uint64_t published = 0;
      for (const auto& [id, a] : view.actors) published += a.sample.transitions_published();
      if (view.actors.size() == size_t(c.run.actors)) expected = std::max(expected, published);
      uint64_t stored = 0;
      for (const auto& [id, s] : view.shards) stored += s.sample.inserted_transitions();
      if (stored >= expected || now > drain_deadline) break;
    }
    progress.Tick(view, sup, now);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return out;
}

// the chain is done: its phase change cuts an epoch, in which the learner checkpoints the final
// policy (what `coins eval` loads); waits for it, at most the checkpoint timeout
void WaitForFinalEpoch(const SystemConfig& c) {
  const auto end =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(c.orchestrator.checkpoint_timeout_s + 2.0);
  while (!FinalEpoch(c.run.dir) && std::chrono::steady_clock::now() < end && !StopRequested())
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  if (auto e = FinalEpoch(c.run.dir))
    std::cout << "coins run: final checkpoint epoch " << *e << " complete\n";
  else
    std::cout << "coins run: no checkpoint epoch of the finished chain completed; the newest checkpoint is used\n";
}

// the summary (printed and summary.json), learning curves, and the final GIF of a finished chain
void ReportRun(const StatusView& view, Progress& progress, const Supervisor& sup, const SystemConfig& c,
               bool chain_done) {
  namespace fs = std::filesystem;
  nlohmann::json summary = RunSummary(view, progress.elapsed(), sup.restarts());
  std::cout << FormatSummary(summary);
  std::ofstream(fs::path(c.run.dir) / "summary.json") << summary.dump(1) << "\n";
  if (progress.metrics()) {
    auto plots = progress.metrics()->Plot();
    if (!plots.ok()) std::cout << "  " << plots.status().message() << "\n";
    for (const auto& f : plots.ok() ? *plots : std::vector<std::string>{})
      std::cout << "  learning curve: " << f << "\n";
  }
  std::cout << "  metrics: " << c.run.dir << "/metrics.csv, metrics.jsonl\n";
  if (chain_done) std::cout << "  " << WriteFinalGif(SelfDirectory() + "/coins", c.run.dir) << "\n";
}

// a clean stop, actors first: actors and shards get SIGTERM together; an actor publishes its
// last batches and waits for their acknowledgements, while its shard keeps storing without rate
// limiting (so a throttled actor can flush) until its writers are gone, then writes a final
// snapshot and reports (replay/replay_main.cc). The learner and the orchestrator stop once the
// actors are gone. Each group's grace covers its own flush before SIGKILL: an actor may wait
// flush_timeout_s for a shard to take its last batch and again for the acknowledgements; a
// shard drains for up to stop_drain_s and may write a snapshot.
void StopRun(std::vector<ChildProcess>& children, const SystemConfig& c) {
  using namespace std::chrono;
  auto secs = [](double s) { return duration_cast<milliseconds>(duration<double>(s)); };
  auto is = [](const ChildProcess& p, const char* prefix) { return p.name().rfind(prefix, 0) == 0; };
  auto actor = [&](const ChildProcess& p) { return is(p, "actor-"); };
  auto shard = [&](const ChildProcess& p) { return is(p, "replay-"); };
  auto other = [&](const ChildProcess& p) { return !actor(p) && !shard(p); };
  auto signal = [&](auto member) {
    for (auto& p : children)
      if (member(p) && !p.Poll()) p.Signal(SIGTERM);
  };
  auto wait = [&](auto member, milliseconds grace) {
    auto end = steady_clock::now() + grace;
    for (auto& p : children) {
      if (!member(p)) continue;
      auto left = duration_cast<milliseconds>(end - steady_clock::now());
      if (p.WaitFor(std::max(left, milliseconds(0)))) continue;
      std::cerr << "coins run: " << p.name() << " did not stop within " << grace.count() / 1000.0 << " s; killing it\n";
      p.Signal(SIGKILL);
      p.WaitFor(seconds(5));
    }
  };
  const double snapshot_s = c.replay.snapshot_dir.empty() ? 0.0 : 10.0 + double(c.replay.capacity_mb) / 50.0;
  const milliseconds actor_grace = secs(2 * c.actor.flush_timeout_s + 5);
  const milliseconds shard_grace = secs(c.replay.stop_drain_s + snapshot_s + 10);
  const auto shards_told = steady_clock::now();
  signal(actor);
  signal(shard);
  wait(actor, actor_grace);
  signal(other);
  wait(other, secs(30));  // a learner finishes the detect model it is training (seconds)
  wait(shard, std::max(milliseconds(0), shard_grace - duration_cast<milliseconds>(steady_clock::now() - shards_told)) +
                  secs(5));
}

// one line per actor: transitions it published and what the shards stored of them
void PrintFinalCounts(const StatusView& v, int64_t actors) {
  for (int64_t i = 0; i < actors; ++i) {
    uint64_t stored = 0;
    bool seen_by_shard = false;
    for (const auto& [id, s] : v.shards)
      for (const auto& a : s.sample.actors())
        if (a.actor_id() == uint64_t(i)) stored += a.transitions(), seen_by_shard = true;
    auto it = v.actors.find(uint32_t(i));
    if (it == v.actors.end()) {
      std::cout << fmt::format("coins run: actor-{}: no final report; shards stored {} of its transitions\n", i,
                               seen_by_shard ? std::to_string(stored) : std::string("none"));
      continue;
    }
    const uint64_t published = it->second.sample.transitions_published();
    std::string verdict = published == stored ? "all stored"
                          : published > stored
                              ? fmt::format("{} published but not stored", published - stored)
                              : fmt::format("{} more stored than published (resumed or restarted)", stored - published);
    std::cout << fmt::format("coins run: actor-{}: {} transitions published, {} stored ({})\n", i, published, stored,
                             verdict);
  }
}

}  // namespace

void AddRunCommand(CLI::App& app, int* exit_code) {
  auto flags = std::make_shared<RunFlags>();
  CLI::App* run =
      app.add_subcommand("run", "Start a whole run on this machine: replay shards, learner, orchestrator, actors.");
  run->add_option("--config", flags->config, "YAML config file")->check(CLI::ExistingFile);
  run->add_option("--actors", flags->actors, "actor processes (run.actors)")->check(CLI::Range(1, 1024));
  run->add_option("--shards", flags->shards, "replay shard processes (run.shards)")->check(CLI::Range(1, 256));
  run->add_option("--env", flags->env, "environment (run.env), see `coins env list`");
  run->add_option("--steps", flags->steps, "total env steps, 0 = until Ctrl-C (run.steps)")
      ->check(cli::Integer(0, int64_t(1) << 50));
  run->add_option("--dir", flags->dir, "run directory for config and logs (run.dir)");
  run->add_option("--resume", flags->resume,
                  "continue the stopped or crashed run in this directory from its newest complete checkpoint epoch "
                  "(its config.yaml; flags may change only operational keys)");
  run->add_option("--set", flags->overrides, "override a config value: section.key=value (repeatable)");
  run->add_flag("--quiet", flags->quiet, "no progress lines");
  run->callback([flags, exit_code] { *exit_code = RunLocal(*flags); });
}

int RunLocal(const RunFlags& flags) {
  SystemConfig c;
  RunPlan plan;
  std::string config_path;
  Status ready = PrepareRun(flags, c, &plan);
  if (ready.ok()) ready = PrepareDirectory(c, &plan, &config_path);
  if (!ready.ok()) {
    std::cerr << "coins run: " << ready.message() << "\n";
    return 2;
  }
  for (const auto& note : plan.notes) std::cout << note << "\n";
  std::cout << "coins run: " << c.run.env << ", " << c.run.actors << " actors, " << c.run.shards << " shards, "
            << (c.run.steps ? std::to_string(c.run.steps) + " steps" : std::string("until the chain is done"))
            << (plan.resume_epoch >= 0 ? fmt::format(", resuming epoch {}", plan.resume_epoch) : std::string())
            << ", up to " << c.run.max_restarts << " restarts a child; config and logs in " << c.run.dir << "\n";

  InstallStopSignals();
  SetupLogging("coins", "warn");
  // ports that killed processes of an earlier run left on this domain (see participant_ids.h)
  if (int zombies = dds::RemoveZombieSharedMemoryPorts(int(c.dds.domain)))
    std::cout << "coins run: removed " << zombies << " shared-memory ports left by killed processes on domain "
              << c.dds.domain << "\n";
  auto node = dds::Node::Create(c.dds, "coins-run");
  if (!node.ok()) {
    std::cerr << "coins run: " << node.status().message() << "\n";
    return 1;
  }
  auto collector = StatusCollector::Start(**node);
  if (!collector.ok()) {
    std::cerr << "coins run: " << collector.status().message() << "\n";
    return 1;
  }

  Supervisor sup((std::filesystem::path(c.run.dir) / "logs").string(), c.run.max_restarts);
  std::vector<ChildProcess>& children = sup.children();
  if (Status started = StartChildren(sup, c, config_path, plan.resume_epoch); !started.ok()) {
    std::cerr << "coins run: " << started.message() << "\n";
    StopAll(children, std::chrono::seconds(5));
    return 1;
  }
  auto metrics = RunMetrics::Open(c.run.dir);
  if (!metrics.ok()) std::cerr << "coins run: " << metrics.status().message() << "\n";
  Progress progress(c, flags.quiet, metrics.ok() ? std::optional<RunMetrics>(std::move(*metrics)) : std::nullopt);
  RunOutcome outcome = WatchRun(sup, **collector, c, progress);
  if (outcome.chain_done) WaitForFinalEpoch(c);
  const std::string& failure = outcome.failure;

  if (!failure.empty())
    std::cerr << "coins run: " << failure << "; stopping the other processes\n";
  else if (outcome.chain_done)
    std::cout << "coins run: the chain is done; stopping every process\n";
  else if (StopRequested())
    std::cout << "coins run: stopping (interrupted)\n";
  StopRun(children, c);
  // the final reports of the last processes may still be on their way
  auto reported = [&] { return (*collector)->Snapshot().actors.size() >= size_t(c.run.actors); };
  for (int i = 0; i < 40 && !reported(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // the shards' final stats, sent as they exited
  StatusView view = (*collector)->Snapshot();
  std::cout << progress.Line(view, sup, progress.elapsed()) << "\n";
  PrintFinalCounts(view, c.run.actors);
  for (const auto& child : children)
    if (!child.succeeded()) std::cout << "  " << child.name() << " " << child.Describe() << "\n";
  ReportRun(view, progress, sup, c, outcome.chain_done);
  return failure.empty() ? 0 : 1;
}

}  // namespace coins
