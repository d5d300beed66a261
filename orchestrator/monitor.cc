#include "orchestrator/monitor.h"

#include <unistd.h>

#include <iostream>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "common/cli_checks.h"
#include "common/process.h"
#include "orchestrator/status_collector.h"

namespace coins {

namespace {

struct MonitorFlags {
  std::string config;
  int64_t domain = -1;
  double seconds = 0;
  bool json = false;
};

double Age(const StatusView::Clock::time_point& t) {
  return std::chrono::duration<double>(StatusView::Clock::now() - t).count();
}

std::string Floats(const std::vector<float>& x) {
  std::string out;
  for (size_t i = 0; i < x.size() && i < 12; ++i) out += (i ? " " : "") + fmt::format("{:g}", x[i]);
  return "[" + out + (x.size() > 12 ? " ..." : "") + "]";
}

// the chain: phase, links with Sc_I, masks, goal sets and skill success, the newest scores,
// the newest evaluation, the learner
std::string ChainTable(const StatusView& v) {
  std::ostringstream out;
  if (!v.chain) return "\nchain: no ChainStatus yet\n";
  const auto& c = v.chain->sample;
  out << fmt::format("\nchain: phase {}, source {}, round {}, env steps {}, epoch {}\n  {}\n", c.phase(), c.source(),
                     c.round(), c.env_steps(), c.epoch(), c.message());
  for (const auto& l : c.links())
    out << fmt::format(
        "  link {}->{}: Sc_I {:.2f}, {}, success {:.3f}, accepted at {}, learned at {}\n    mask {} goals {} {}\n",
        l.source(), l.target(), l.score(), l.state(), l.skill_success(), l.accepted_at_steps(), l.learned_at_steps(),
        Floats(l.mask()), l.goal_kind(), Floats(l.goal_set()));
  for (const auto& s : c.last_scores())
    out << fmt::format("  score {}->{}: Sc_I {:.2f}, {} detections ({:.1f} by chance){}{}\n", s.source(), s.target(),
                       s.score(), s.interactions(), s.chance_interactions(), s.eligible() ? "" : " (not eligible)",
                       s.note().empty() ? "" : " " + s.note());
  if (c.eval_env_steps())
    out << fmt::format("  eval return {:.2f} +- {:.2f} at {} env steps\n", c.eval_return_mean(), c.eval_return_sd(),
                       c.eval_env_steps());
  if (v.learner) {
    const auto& l = v.learner->sample;
    out << fmt::format(
        "  learner: job {} ({}), {} updates ({:.0f}/s), lag median {:.1f} p99 {:.1f}, checkpoint epoch {}\n", l.job(),
        l.state(), l.updates(), l.updates_per_s(), l.lag_median(), l.lag_p99(), l.checkpoint_epoch());
    if (l.eval_env_steps())
      out << fmt::format(
          "  greedy evaluation at {} env steps: success {:.3f}, hit rate {:.3f}, angle accuracy {:.3f}{}\n",
          l.eval_env_steps(), l.eval_success(), l.eval_hit_rate(), l.eval_angle_accuracy(),
          l.eval_play_episodes() ? fmt::format("; on random goals it plays the task for {:.2f} +- {:.2f}",
                                               l.eval_play_return_mean(), l.eval_play_return_sd())
                                 : std::string());
  }
  return out.str();
}

std::string Table(const StatusView& v) {
  std::ostringstream out;
  out << fmt::format("{:<16} {:<13} {:>8} {:>10} {:>6}\n", "process", "role", "pid", "uptime_s", "seen");
  for (const auto& [name, h] : v.heartbeats)
    out << fmt::format("{:<16} {:<13} {:>8} {:>10.1f} {:>5.1f}s{}\n", name, h.sample.role(), h.sample.pid(),
                       h.sample.uptime_s(), Age(h.received), Age(h.received) > 5 ? "  (silent)" : "");
  out << fmt::format("\n{:<8} {:<18} {:>6} {:>12} {:>12} {:>10} {:>10}\n", "actor", "env", "shard", "steps", "steps/s",
                     "episodes", "return");
  for (const auto& [id, a] : v.actors)
    out << fmt::format("{:<8} {:<18} {:>6} {:>12} {:>12.0f} {:>10} {:>10.2f}\n", id, a.sample.env(), a.sample.shard(),
                       a.sample.steps(), a.sample.steps_per_s(), a.sample.episodes(), a.sample.mean_episode_return());
  out << fmt::format("\n{:<8} {:>12} {:>12} {:>7} {:>12} {:>6} {:>6} {:>8}\n", "shard", "size", "capacity", "fill",
                     "insert/s", "dups", "gaps", "rejected");
  for (const auto& [id, s] : v.shards) {
    const auto& r = s.sample;
    double fill = r.capacity() ? 100.0 * double(r.size()) / double(r.capacity()) : 0.0;
    out << fmt::format("{:<8} {:>12} {:>12} {:>6.1f}% {:>12.0f} {:>6} {:>6} {:>8}\n", id, r.size(), r.capacity(), fill,
                       r.insert_rate(), r.duplicates(), r.gaps(), r.rejected());
  }
  out << ChainTable(v);
  return out.str();
}

nlohmann::json Json(const StatusView& v) {
  nlohmann::json j;
  j["processes"] = nlohmann::json::array();
  for (const auto& [name, h] : v.heartbeats)
    j["processes"].push_back({{"name", name},
                              {"role", h.sample.role()},
                              {"pid", h.sample.pid()},
                              {"state", h.sample.state()},
                              {"seen_s_ago", Age(h.received)}});
  j["actors"] = nlohmann::json::array();
  for (const auto& [id, a] : v.actors)
    j["actors"].push_back({{"actor_id", id},
                           {"env", a.sample.env()},
                           {"shard", a.sample.shard()},
                           {"steps", a.sample.steps()},
                           {"steps_per_s", a.sample.steps_per_s()},
                           {"transitions_published", a.sample.transitions_published()},
                           {"goals_started", a.sample.goals_started()},
                           {"goals_reached", a.sample.goals_reached()}});
  j["shards"] = nlohmann::json::array();
  for (const auto& [id, s] : v.shards)
    j["shards"].push_back({{"shard_id", id},
                           {"size", s.sample.size()},
                           {"capacity", s.sample.capacity()},
                           {"inserted_transitions", s.sample.inserted_transitions()},
                           {"insert_rate", s.sample.insert_rate()},
                           {"rejected", s.sample.rejected()}});
  if (v.chain) {
    const auto& c = v.chain->sample;
    nlohmann::json links = nlohmann::json::array();
    for (const auto& l : c.links())
      links.push_back({{"source", l.source()},
                       {"target", l.target()},
                       {"score", l.score()},
                       {"state", l.state()},
                       {"skill_success", l.skill_success()},
                       {"mask", l.mask()},
                       {"goal_kind", l.goal_kind()},
                       {"goal_set", l.goal_set()},
                       {"accepted_at_steps", l.accepted_at_steps()},
                       {"learned_at_steps", l.learned_at_steps()}});
    j["chain"] = {{"phase", c.phase()},
                  {"env_steps", c.env_steps()},
                  {"source", c.source()},
                  {"round", c.round()},
                  {"epoch", c.epoch()},
                  {"message", c.message()},
                  {"links", links},
                  {"eval_return_mean", c.eval_return_mean()},
                  {"eval_return_sd", c.eval_return_sd()},
                  {"eval_env_steps", c.eval_env_steps()}};
  }
  if (v.learner)
    j["learner"] = {{"job", v.learner->sample.job()},
                    {"state", v.learner->sample.state()},
                    {"updates", v.learner->sample.updates()},
                    {"lag_median", v.learner->sample.lag_median()},
                    {"eval_env_steps", v.learner->sample.eval_env_steps()},
                    {"eval_success", v.learner->sample.eval_success()},
                    {"eval_hit_rate", v.learner->sample.eval_hit_rate()},
                    {"eval_play_return_mean", v.learner->sample.eval_play_return_mean()},
                    {"eval_play_episodes", v.learner->sample.eval_play_episodes()}};
  return j;
}

int RunMonitor(const MonitorFlags& f) {
  DdsOptions dds;
  ConfigLoader loader({ConfigSection::Of("dds", dds)});
  Status s = f.config.empty() ? Status::Ok() : loader.LoadFile(f.config);
  if (s.ok() && f.domain >= 0) s = loader.ApplyOverride(fmt::format("dds.domain={}", f.domain));
  if (!s.ok()) {
    std::cerr << "coins monitor: " << s.message() << "\n";
    return 2;
  }
  InstallStopSignals();
  SetupLogging("coins-monitor", "warn");
  if (dds.identity.empty()) dds.identity = "monitor";
  auto node = dds::Node::Join(dds, "coins-monitor");
  if (!node.ok()) {
    std::cerr << "coins monitor: " << node.status().message() << "\n";
    return 1;
  }
  auto collector = StatusCollector::Start(**node);
  if (!collector.ok()) {
    std::cerr << "coins monitor: " << collector.status().message() << "\n";
    return 1;
  }
  bool tty = isatty(STDOUT_FILENO) && !f.json;
  auto start = std::chrono::steady_clock::now();
  while (!StopRequested()) {
    bool last = SleepUnlessStopped(std::chrono::seconds(1)) ||
                (f.seconds > 0 && std::chrono::steady_clock::now() - start >= std::chrono::duration<double>(f.seconds));
    StatusView v = (*collector)->Snapshot();
    if (f.json) {
      if (last) std::cout << Json(v).dump() << std::endl;
    } else {
      if (tty) std::cout << "\x1b[H\x1b[2J";
      std::cout << fmt::format("coins monitor, domain {}\n\n", dds.domain) << Table(v) << std::endl;
    }
    if (last) break;
  }
  return 0;
}

}  // namespace

void AddMonitorCommand(CLI::App& app, int* exit_code) {
  auto flags = std::make_shared<MonitorFlags>();
  CLI::App* m = app.add_subcommand("monitor", "Show a live table of every coins process in the DDS domain.");
  m->add_option("--config", flags->config, "YAML config file (its dds section is used)")->check(CLI::ExistingFile);
  m->add_option("--domain", flags->domain, "DDS domain id (overrides the config)")->check(CLI::Range(0, 232));
  m->add_option("--seconds", flags->seconds, "stop after this many seconds (0: until Ctrl-C)")
      ->check(cli::Finite(0, 1e7));
  m->add_flag("--json", flags->json, "print one JSON object of the final view instead of tables");
  m->callback([flags, exit_code] { *exit_code = RunMonitor(*flags); });
}

}  // namespace coins
