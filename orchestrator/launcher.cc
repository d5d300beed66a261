#include "orchestrator/launcher.h"

#include <signal.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <set>
#include <thread>

#include <fmt/format.h>

#include "common/actor_stats_json.h"
#include "common/cli_checks.h"
#include "common/dds/discovery.h"
#include "common/dds/participant_ids.h"
#include "common/env_steps.h"
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
  if (!plan->resuming) COINS_RETURN_IF_ERROR(ClearPreviousRun(c, plan->roles, plan));
  *config_path = (fs::path(c.run.dir) / "config.yaml").string();
  std::ofstream(*config_path) << plan->effective;
  return Status::Ok();
}

// the discovery servers of dds.discovery_server that listen on an address of this host
std::vector<int> LocalDiscoveryServers(const SystemConfig& c) {
  std::vector<int> out;
  auto servers = dds::ParseServers(c.dds.discovery_server);
  const std::set<std::string> mine = LocalAddresses();
  for (size_t i = 0; servers.ok() && i < servers->size(); ++i)
    if (mine.count((*servers)[i].ip)) out.push_back(int(i));
  return out;
}

// where actor i of this run writes its final stats as it exits
std::string FinalStatsFile(const SystemConfig& c, int64_t i) {
  return (std::filesystem::path(c.run.dir) / "logs" / fmt::format("actor-{}.final.json", i)).string();
}

// discovery servers first, then shards so actors find them, then learner and orchestrator, then
// actors (of this host's roles); shards, learner and orchestrator of a resumed run start from the
// epoch's files (first start only). `collector` outlives the supervisor's restarts.
Status StartChildren(Supervisor& sup, const SystemConfig& c, const std::string& config_path, const RunPlan& plan,
                     const dds::Node& node, const StatusCollector& collector) {
  const std::string bin = SelfDirectory();
  const RunRoles& roles = plan.roles;
  auto spec = [&](const std::string& binary, const std::string& name, int64_t id, bool resumes) {
    ChildSpec s{name, {bin + "/" + binary, "--config", config_path, "--name", name}, {}, binary == "coins-actor"};
    if (id >= 0) s.argv.insert(s.argv.end(), {"--id", std::to_string(id)});
    if (resumes && plan.resume_epoch >= 0) s.first_start = {"--resume-epoch", std::to_string(plan.resume_epoch)};
    return s;
  };
  if (roles.Has("discovery")) {
    const std::vector<int> servers = LocalDiscoveryServers(c);
    // asked for by --role: this host must serve; a whole run may use servers elsewhere
    if (servers.empty() && !roles.all)
      return Errorf("--role discovery: no server of dds.discovery_server '{}' has an address of this host",
                    c.dds.discovery_server);
    for (int i : servers) {
      ChildSpec s{fmt::format("discovery-{}", i),
                  {bin + "/coins", "discovery-server", "--config", config_path, "--index", std::to_string(i)},
                  {}};
      COINS_RETURN_IF_ERROR(sup.Start(s));
    }
  }
  // the servers, here or elsewhere, answer before any process that moves data starts
  COINS_RETURN_IF_ERROR(node.AwaitDiscoveryServer());
  for (int64_t k : roles.shard_ids)
    COINS_RETURN_IF_ERROR(sup.Start(spec("coins-replay", fmt::format("replay-{}", k), k, true)));
  if (roles.Has("learner")) COINS_RETURN_IF_ERROR(sup.Start(spec("coins-learner", "learner", -1, true)));
  if (roles.Has("orchestrator")) COINS_RETURN_IF_ERROR(sup.Start(spec("coins-orchestrator", "orchestrator", -1, true)));
  for (int64_t i : roles.actor_ids) {
    ChildSpec actor = spec("coins-actor", fmt::format("actor-{}", i), i, false);
    const std::string stats = FinalStatsFile(c, i);
    std::error_code ec;
    std::filesystem::remove(stats, ec);  // an earlier run's, in a resumed run's directory
    actor.argv.insert(actor.argv.end(), {"--stats-out", stats});
    // a resumed run's actors count on from the epoch's env steps, split as the pacing splits them;
    // a restarted actor from the count it reported last (the pacing allows run steps: counting
    // from 0 again it would run ahead of the learner). A report still in flight when the count is
    // read is neither lost nor counted twice: EnvStepCount uses the restart's first step.
    const uint64_t share = ActorShare(plan.resume_env_steps, uint64_t(i), uint64_t(std::max<int64_t>(c.run.actors, 1)));
    // A resumed host without the orchestrator has no chain state: its actors take their share
    // from the orchestrator's ChainStatus before their first step.
    const bool from_chain = plan.resuming && !roles.Has("orchestrator") && c.actor.follow_chain;
    if (share > 0) actor.first_start = {"--first-step", std::to_string(share)};
    if (from_chain) actor.first_start.push_back("--first-step-from-chain");
    actor.restart_args = [&collector, id = uint32_t(i), share, from_chain] {
      std::vector<std::string> args = {"--first-step",
                                       std::to_string(std::max(share, collector.Snapshot().env_steps.last(id)))};
      if (from_chain) args.push_back("--first-step-from-chain");
      return args;
    };
    COINS_RETURN_IF_ERROR(sup.Start(actor));
  }
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
  std::string failure;        // a child that could not be kept running
  bool chain_done = false;    // ChainStatus.phase reached done
  bool budget_spent = false;  // this host's actors finished run.steps and the shards hold their rows
};

// transitions the actors `ids` are due to publish (their share of the budget, or what their
// reports say when that is more) and what the shards stored of them
std::pair<uint64_t, uint64_t> DueAndStored(const StatusView& view, const SystemConfig& c,
                                           const std::vector<int64_t>& ids) {
  const uint64_t share = c.actor.steps ? c.actor.steps : (c.run.steps + c.run.actors - 1) / c.run.actors;
  uint64_t published = 0, stored = 0;
  size_t reported = 0;
  for (int64_t i : ids) {
    if (auto it = view.actors.find(uint32_t(i)); it != view.actors.end())
      published += it->second.sample.transitions_published(), ++reported;
    for (const auto& [k, s] : view.shards)
      for (const auto& a : s.sample.actors())
        if (a.actor_id() == uint64_t(i)) stored += a.transitions();
  }
  uint64_t due = share * ids.size();
  if (reported == ids.size()) due = std::max(due, published);
  return {due, stored};
}

// watches children and status until the chain is done, this host's actors finished their step
// budget and the shards hold what they published, a child fails for good, or a stop is
// requested (a host without actors runs until the chain is done or it is stopped)
RunOutcome WatchRun(Supervisor& sup, StatusCollector& collector, const SystemConfig& c, const RunRoles& roles,
                    Progress& progress) {
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
    if (!roles.actor_ids.empty() && sup.actors_done() && !actors_done) {
      actors_done = true;
      drain_deadline = now + std::chrono::seconds(10);
    }
    if (actors_done) {
      // every actor that finished published at least its share of run.steps (one transition per
      // env step and level stream), and its final report says how many
      auto [due, stored] = DueAndStored(view, c, roles.actor_ids);
      if (stored >= due || now > drain_deadline) {
        out.budget_spent = true;
        break;
      }
    }
    progress.Tick(view, sup, now);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return out;
}

// the chain is done, or the run's step budget is spent: either cuts an epoch (the phase change,
// or the orchestrator seeing run.steps), in which the learner checkpoints the final policy (what
// `coins eval` and `--resume` load); waits for it, at most the checkpoint timeout
void WaitForFinalEpoch(const SystemConfig& c, bool chain_done) {
  const uint64_t budget = chain_done ? 0 : uint64_t(c.run.steps);
  const auto end =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(c.orchestrator.checkpoint_timeout_s + 2.0);
  while (!FinalEpoch(c.run.dir, budget) && std::chrono::steady_clock::now() < end && !StopRequested())
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  if (auto e = FinalEpoch(c.run.dir, budget))
    std::cout << "coins run: final checkpoint epoch " << *e << " complete\n";
  else
    std::cout << "coins run: no final checkpoint epoch completed; the newest checkpoint is used\n";
}

// the summary (printed and summary.json), learning curves, and the final GIF of a finished chain
void ReportRun(const StatusView& view, Progress& progress, const Supervisor& sup, const SystemConfig& c,
               bool final_gif) {
  namespace fs = std::filesystem;
  const double wall_s = progress.elapsed() + (progress.metrics() ? progress.metrics()->wall_offset() : 0.0);
  nlohmann::json summary = RunSummary(view, wall_s, sup.restarts());
  if (progress.metrics()) {
    summary["evals"] = EvalMilestones(progress.metrics()->evals(), c.run.report_returns);
    summary["skill_evals"] = EvalMilestones(progress.metrics()->skill_evals(), c.run.report_returns);
  }
  summary.update(KeptWeightsOf(c.run.dir));
  if (!c.learner.keep_best_task) summary["kept_task"] = {{"newest", true}};
  std::cout << FormatSummary(summary);
  std::ofstream(fs::path(c.run.dir) / "summary.json") << summary.dump(1) << "\n";
  if (progress.metrics()) {
    auto plots = progress.metrics()->Plot();
    if (!plots.ok()) std::cout << "  " << plots.status().message() << "\n";
    for (const auto& f : plots.ok() ? *plots : std::vector<std::string>{})
      std::cout << "  learning curve: " << f << "\n";
  }
  std::cout << "  metrics: " << c.run.dir << "/metrics.csv, metrics.jsonl\n";
  if (final_gif) std::cout << "  " << WriteFinalGif(SelfDirectory() + "/coins", c.run.dir) << "\n";
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
  auto discovery = [&](const ChildProcess& p) { return is(p, "discovery-"); };
  auto other = [&](const ChildProcess& p) { return !actor(p) && !shard(p) && !discovery(p); };
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
  signal(discovery);  // last: the others found each other through it until they ended
  wait(discovery, secs(10));
}

// one line per actor of this host: transitions it published and what the shards stored of them
void PrintFinalCounts(const StatusView& v, const std::vector<int64_t>& actors) {
  for (int64_t i : actors) {
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
    const msg::ActorStats& a = it->second.sample;
    if (a.env_errors() > 0) verdict += fmt::format("; {} env steps failed, their episodes ended", a.env_errors());
    if (a.goals_clipped() > 0) verdict += fmt::format("; {} goals clipped to their goal space", a.goals_clipped());
    std::cout << fmt::format("coins run: actor-{}: {} transitions published, {} stored ({})\n", i, published, stored,
                             verdict);
  }
}

}  // namespace

void AddRunFlags(CLI::App* cmd, RunFlags* flags) {
  cmd->add_option("--actors", flags->actors, "actor processes (run.actors)")->check(CLI::Range(1, 1024));
  cmd->add_option("--shards", flags->shards, "replay shard processes (run.shards)")->check(CLI::Range(1, 256));
  cmd->add_option("--dir", flags->dir, "run directory for config and logs (run.dir)");
  cmd->add_option("--resume", flags->resume,
                  "continue the stopped or crashed run in this directory from its newest complete checkpoint epoch "
                  "(its config.yaml; flags may change only operational keys)");
  cmd->add_option("--set", flags->overrides, "override a config value: section.key=value (repeatable)");
  cmd->add_flag("--quiet", flags->quiet, "no progress lines");
}

void AddRunCommand(CLI::App& app, int* exit_code) {
  auto flags = std::make_shared<RunFlags>();
  CLI::App* run =
      app.add_subcommand("run", "Start a whole run on this machine: replay shards, learner, orchestrator, actors.");
  run->add_option("--config", flags->config, "YAML config file")->check(CLI::ExistingFile);
  run->add_option("--env", flags->env, "environment (run.env), see `coins env list`");
  run->add_option("--steps", flags->steps, "total env steps, 0 = until Ctrl-C (run.steps)")
      ->check(cli::Integer(0, int64_t(1) << 50));
  AddRunFlags(run, flags.get());
  run->add_option("--role", flags->roles,
                  "this host's share of a cluster run: a comma list of discovery, replay, learner, orchestrator, "
                  "actors (default: everything; see orchestrator/run_roles.h)");
  run->add_option("--actor-ids", flags->actor_ids, "the actors of this host, K or A-B (default: all of run.actors)");
  run->add_option("--shard-ids", flags->shard_ids, "the shards of this host, K or A-B (default: all of run.shards)");
  run->callback([flags, exit_code] { *exit_code = RunLocal(*flags); });
}

int RunLocal(const RunFlags& flags, const RunSeed& seed) {
  SystemConfig c;
  RunPlan plan;
  std::string config_path;
  Status ready = PrepareRun(flags, c, &plan);
  if (ready.ok()) ready = PrepareDirectory(c, &plan, &config_path);
  if (ready.ok() && seed && !plan.resuming) ready = seed(c);
  if (!ready.ok()) {
    std::cerr << flags.command << ": " << ready.message() << "\n";
    return 2;
  }
  for (const auto& note : plan.notes) std::cout << note << "\n";
  std::cout << "coins run: " << c.run.env << ", " << c.run.actors << " actors, " << c.run.shards << " shards, "
            << (c.run.steps ? std::to_string(c.run.steps) + " steps" : std::string("until the chain is done"))
            << (plan.resume_epoch >= 0 ? fmt::format(", resuming epoch {}", plan.resume_epoch) : std::string())
            << ", up to " << c.run.max_restarts << " restarts a child; config and logs in " << c.run.dir << "\n";
  if (!plan.roles.all) std::cout << "coins run: this host runs " << plan.roles.Describe() << "\n";

  InstallStopSignals();
  SetupLogging("coins", "warn");
  // ports that killed processes of an earlier run left on this domain (see participant_ids.h)
  if (int zombies = dds::RemoveZombieSharedMemoryPorts(int(c.dds.domain)))
    std::cout << "coins run: removed " << zombies << " shared-memory ports left by killed processes on domain "
              << c.dds.domain << "\n";
  DdsOptions operator_dds = c.dds;
  if (operator_dds.identity.empty()) operator_dds.identity = "operator";
  auto node = dds::Node::Create(operator_dds, "coins-run");
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
  if (Status started = StartChildren(sup, c, config_path, plan, **node, **collector); !started.ok()) {
    std::cerr << "coins run: " << started.message() << "\n";
    StopAll(children, std::chrono::seconds(5));
    return 1;
  }
  auto metrics = RunMetrics::Open(c.run.dir, plan.resume_epoch >= 0);
  if (!metrics.ok()) std::cerr << "coins run: " << metrics.status().message() << "\n";
  Progress progress(c, flags.quiet, metrics.ok() ? std::optional<RunMetrics>(std::move(*metrics)) : std::nullopt);
  RunOutcome outcome = WatchRun(sup, **collector, c, plan.roles, progress);
  if ((outcome.chain_done || outcome.budget_spent) && plan.roles.Has("orchestrator"))
    WaitForFinalEpoch(c, outcome.chain_done);
  const std::string& failure = outcome.failure;

  if (!failure.empty())
    std::cerr << "coins run: " << failure << "; stopping the other processes\n";
  else if (outcome.chain_done)
    std::cout << "coins run: the chain is done; stopping every process\n";
  else if (StopRequested())
    std::cout << "coins run: stopping (interrupted)\n";
  StopRun(children, c);
  // the final reports of the last processes may still be on their way
  auto reported = [&] {
    auto v = (*collector)->Snapshot();
    for (int64_t i : plan.roles.actor_ids)
      if (!v.actors.count(uint32_t(i))) return false;
    return true;
  };
  for (int i = 0; i < 40 && !reported(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  // an actor that ended before this process's reader matched its writer: its final stats file
  for (int64_t i : plan.roles.actor_ids) {
    if ((*collector)->Snapshot().actors.count(uint32_t(i))) continue;
    const std::string file = FinalStatsFile(c, i);
    if (!std::filesystem::exists(file)) continue;
    auto stats = ReadActorStatsFile(file);
    if (!stats.ok()) {
      std::cout << "coins run: " << stats.status().message() << "\n";
      continue;
    }
    (*collector)->Report(*stats);
    std::cout << fmt::format("coins run: actor-{}: final report read from {} (none arrived over DDS)\n", i, file);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // the shards' final stats, sent as they exited
  StatusView view = (*collector)->Snapshot();
  std::cout << progress.Line(view, sup, progress.elapsed()) << "\n";
  PrintFinalCounts(view, plan.roles.actor_ids);
  for (const auto& child : children)
    if (!child.succeeded()) std::cout << "  " << child.name() << " " << child.Describe() << "\n";
  ReportRun(view, progress, sup, c, outcome.chain_done && plan.roles.Has("learner"));
  return failure.empty() ? 0 : 1;
}

}  // namespace coins
