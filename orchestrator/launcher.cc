#include "orchestrator/launcher.h"

#include <signal.h>

#include <filesystem>
#include <fstream>
#include <iostream>

#include <fmt/format.h>

#include "actors/actor_options.h"
#include "actors/envs/env.h"
#include "common/cli_checks.h"
#include "common/dds/dds_options.h"
#include "common/process.h"
#include "common/run_options.h"
#include "learner/learner_options.h"
#include "orchestrator/child_process.h"
#include "orchestrator/orchestrator_options.h"
#include "orchestrator/status_collector.h"
#include "replay/replay_options.h"

namespace coins {

namespace {

struct SystemConfig {
  DdsOptions dds;
  RunOptions run;
  ActorOptions actor;
  ReplayOptions replay;
  LearnerOptions learner;
  OrchestratorOptions orchestrator;
  ConfigLoader Loader() {
    return ConfigLoader({ConfigSection::Of("dds", dds), ConfigSection::Of("run", run),
                         ConfigSection::Of("actor", actor), ConfigSection::Of("replay", replay),
                         ConfigSection::Of("learner", learner), ConfigSection::Of("orchestrator", orchestrator)});
  }
};

// loads the file, applies the flags and overrides, validates everything before any process starts
Status LoadSystemConfig(const RunFlags& f, SystemConfig& c, std::string* effective) {
  ConfigLoader loader = c.Loader();
  if (!f.config.empty()) COINS_RETURN_IF_ERROR(loader.LoadFile(f.config));
  std::vector<std::string> sets = f.overrides;
  if (f.actors >= 0) sets.push_back(fmt::format("run.actors={}", f.actors));
  if (f.shards >= 0) sets.push_back(fmt::format("run.shards={}", f.shards));
  if (f.steps >= 0) sets.push_back(fmt::format("run.steps={}", f.steps));
  if (!f.env.empty()) sets.push_back("run.env=" + f.env);
  if (!f.dir.empty()) sets.push_back("run.dir=" + f.dir);
  for (const auto& s : sets) COINS_RETURN_IF_ERROR(loader.ApplyOverride(s));
  COINS_RETURN_IF_ERROR(loader.Validate());
  // every shard of the run on this machine
  COINS_RETURN_IF_ERROR(CheckShardMemory(c.replay, c.run.shards));
  auto env = envs::MakeEnv(c.run.env);
  if (!env.ok()) return env.status().WithContext("run.env");
  *effective = loader.Dump();
  return Status::Ok();
}

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
      std::cerr << "coins run: " << p.name() << " did not stop within " << grace.count() / 1000.0
                << " s; killing it\n";
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
  wait(other, secs(10));
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
  CLI::App* run = app.add_subcommand("run", "Start a whole run on this machine: replay shards, learner, orchestrator, actors.");
  run->add_option("--config", flags->config, "YAML config file")->check(CLI::ExistingFile);
  run->add_option("--actors", flags->actors, "actor processes (run.actors)")->check(CLI::Range(1, 1024));
  run->add_option("--shards", flags->shards, "replay shard processes (run.shards)")->check(CLI::Range(1, 256));
  run->add_option("--env", flags->env, "environment (run.env), see `coins env list`");
  run->add_option("--steps", flags->steps, "total env steps, 0 = until Ctrl-C (run.steps)")
      ->check(cli::Integer(0, int64_t(1) << 50));
  run->add_option("--dir", flags->dir, "run directory for config and logs (run.dir)");
  run->add_option("--set", flags->overrides, "override a config value: section.key=value (repeatable)");
  run->add_flag("--quiet", flags->quiet, "no progress lines");
  run->callback([flags, exit_code] { *exit_code = RunLocal(*flags); });
}

int RunLocal(const RunFlags& flags) {
  SystemConfig c;
  std::string effective;
  if (Status s = LoadSystemConfig(flags, c, &effective); !s.ok()) {
    std::cerr << "coins run: " << s.message() << "\n";
    return 2;
  }
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(fs::path(c.run.dir) / "logs", ec);
  if (ec) {
    std::cerr << "coins run: cannot create run directory " << c.run.dir << ": " << ec.message() << "\n";
    return 2;
  }
  std::string config_path = (fs::path(c.run.dir) / "config.yaml").string();
  std::ofstream(config_path) << effective;
  std::cout << "coins run: " << c.run.env << ", " << c.run.actors << " actors, " << c.run.shards << " shards, "
            << (c.run.steps ? std::to_string(c.run.steps) + " steps" : std::string("until Ctrl-C"))
            << "; config and logs in " << c.run.dir << "\n";

  InstallStopSignals();
  SetupLogging("coins", "warn");
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

  // children: shards first so actors find them, then learner and orchestrator, then actors
  std::string bin = SelfDirectory();
  std::vector<ChildProcess> children;
  auto spawn = [&](const std::string& binary, const std::string& name, int64_t id) -> Status {
    std::vector<std::string> argv = {bin + "/" + binary, "--config", config_path, "--name", name};
    if (id >= 0) argv.insert(argv.end(), {"--id", std::to_string(id)});
    auto child = ChildProcess::Spawn(name, argv, (fs::path(c.run.dir) / "logs" / (name + ".log")).string());
    if (!child.ok()) return child.status();
    children.push_back(std::move(*child));
    return Status::Ok();
  };
  Status started = Status::Ok();
  for (int64_t k = 0; k < c.run.shards && started.ok(); ++k) started = spawn("coins-replay", fmt::format("replay-{}", k), k);
  if (started.ok()) started = spawn("coins-learner", "learner", -1);
  if (started.ok()) started = spawn("coins-orchestrator", "orchestrator", -1);
  for (int64_t i = 0; i < c.run.actors && started.ok(); ++i) started = spawn("coins-actor", fmt::format("actor-{}", i), i);
  if (!started.ok()) {
    std::cerr << "coins run: " << started.message() << "\n";
    StopAll(children, std::chrono::seconds(5));
    return 1;
  }

  auto start = std::chrono::steady_clock::now();
  auto next_line = start + std::chrono::seconds(1);
  std::string failure;
  bool actors_done = false;
  std::chrono::steady_clock::time_point drain_deadline;
  while (!StopRequested()) {
    // a child that ends on its own: actors that finished their steps are fine, anything else is a failure
    bool all_actors_done = true;
    for (auto& child : children) {
      bool is_actor = child.name().rfind("actor-", 0) == 0;
      if (child.Poll() && !(is_actor && c.run.steps > 0 && child.succeeded())) {
        failure = fmt::format("{} (pid {}) {}; see {}/logs/{}.log", child.name(), child.pid(), child.Describe(),
                              c.run.dir, child.name());
        break;
      }
      if (is_actor && !child.exited()) all_actors_done = false;
    }
    if (!failure.empty()) break;
    StatusView view = (*collector)->Snapshot();
    // after the actors finish, wait for the shards to hold everything they published
    if (all_actors_done && !actors_done) {
      actors_done = true;
      drain_deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    }
    if (actors_done) {
      // every actor that finished published exactly its share of run.steps
      uint64_t expected = uint64_t(c.run.actors) * ((c.run.steps + c.run.actors - 1) / c.run.actors);
      if (c.actor.steps) expected = uint64_t(c.run.actors) * c.actor.steps;
      uint64_t stored = 0;
      for (const auto& [id, s] : view.shards) stored += s.sample.inserted_transitions();
      if (stored >= expected || std::chrono::steady_clock::now() > drain_deadline) break;
    }
    auto now = std::chrono::steady_clock::now();
    if (now >= next_line && !flags.quiet) {
      std::cout << ProgressLine(view, std::chrono::duration<double>(now - start).count(), c.run.actors) << std::endl;
      next_line += std::chrono::seconds(1);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }

  if (!failure.empty()) std::cerr << "coins run: " << failure << "; stopping the other processes\n";
  else if (StopRequested()) std::cout << "coins run: stopping (interrupted)\n";
  StopRun(children, c);
  // the final reports of the last processes may still be on their way
  auto reported = [&] { return (*collector)->Snapshot().actors.size() >= size_t(c.run.actors); };
  for (int i = 0; i < 40 && !reported(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // the shards' final stats, sent as they exited
  StatusView view = (*collector)->Snapshot();
  std::cout << ProgressLine(view, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
                            c.run.actors)
            << "\n";
  PrintFinalCounts(view, c.run.actors);
  for (const auto& child : children)
    if (!child.succeeded()) std::cout << "  " << child.name() << " " << child.Describe() << "\n";
  return failure.empty() ? 0 : 1;
}

}  // namespace coins
