// coins-actor: runs environments with the skill hierarchy the orchestrator asks for (ChainCommand)
// and the learner's weights, paced by the learner's updates, and streams their transitions to
// replay shard (actor id mod run.shards) over DDS.
#include <optional>
#include <thread>

#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "actors/actor.h"
#include "actors/weights_store.h"
#include "common/actor_stats_json.h"
#include "common/dds/heartbeat.h"
#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "common/env_steps.h"
#include "common/files.h"
#include "common/process.h"
#include "common/run_options.h"
#include "idl/controlPubSubTypes.h"
#include "idl/statusPubSubTypes.h"
#include "idl/transitionPubSubTypes.h"
#include "idl/weightsPubSubTypes.h"

namespace coins {
namespace {

// the chain side of an actor: the newest command, the weights, the learner's progress; applied
// to the Actor between steps (its poll hook) and read by its pacing hook
class ChainFollower {
 public:
  // steps_from_chain: no step before the first ChainStatus, whose env steps (the run's, from
  // the orchestrator's chain state) give this actor's share to count on from when it is more
  // than the actor's count (a resumed run on a host without the orchestrator)
  ChainFollower(dds::Node& node, const envs::EnvSpec& env, int64_t actor_id, int64_t actors, bool steps_from_chain)
      : store_(env), actor_id_(uint64_t(actor_id)), actors_(uint64_t(actors)), await_chain_steps_(steps_from_chain) {
    auto c = node.MakeReader<msg::ChainCommandPubSubType>(dds::kChainCommandTopic, dds::LatchedReaderQos());
    auto w = node.MakeReader<msg::PolicyWeightsPubSubType>(dds::kWeightsTopic, dds::LatchedReaderQos());
    auto l = node.MakeReader<msg::LearnerStatusPubSubType>(dds::kLearnerStatusTopic, dds::StatusReaderQos());
    status_ = !c.ok() ? c.status() : !w.ok() ? w.status() : l.status();
    if (c.ok()) commands_ = *c;
    if (w.ok()) weights_ = *w;
    if (l.ok()) learner_ = *l;
    if (steps_from_chain && status_.ok()) {
      auto s = node.MakeReader<msg::ChainStatusPubSubType>(dds::kChainStatusTopic, dds::LatchedReaderQos());
      if (s.ok()) chain_status_ = *s;
      status_ = s.status();
    }
  }
  const Status& status() const { return status_; }
  // the link whose detector the hierarchy counts against the env's labels: the highest acting
  // level with a detector ("Paddle->Ball"); "" when none acts
  std::string CountedDetector() const {
    for (int L = acting(); L >= 1; --L) {
      const LevelModel* m = store_.models().at(L);
      if (m && !m->spec().detector.empty()) return m->spec().source + "->" + m->spec().goal.factor;
    }
    return "";
  }
  uint64_t rejected() const { return store_.rejected(); }
  uint64_t command_seq() const { return command_ ? command_->seq() : 0; }
  int acting() const { return command_ ? int(command_->acting_level()) : 0; }

  // the share of the run's env steps this actor counts on from, once the first ChainStatus came
  // (0 before, or when not asked for); the actor's count is moved up to it before its first step
  uint64_t TakeChainSteps(Actor& actor) {
    if (!await_chain_steps_) return 0;
    uint64_t run_steps = 0;
    bool seen = false;
    chain_status_.TakeAll(chain_status_scratch_, [&](const msg::ChainStatus& s, const auto&) {
      seen = true;
      run_steps = std::max(run_steps, s.env_steps());
    });
    if (!seen) return 0;
    await_chain_steps_ = false;
    const uint64_t share = Share(run_steps);
    if (share <= actor.counters().steps) return 0;
    actor.CountStepsFrom(share);
    return share;
  }

  // new commands, weights and learner progress; reconfigures the actor when they change it
  void Poll(Actor& actor) {
    const uint64_t before_changes = store_.structure_changes(), before_seq = command_seq();
    const int before_acting = acting();
    commands_.TakeAll(command_scratch_, [&](const msg::ChainCommand& c, const auto&) {
      if (c.schema_version() == msg::CHAIN_COMMAND_SCHEMA && (!command_ || c.seq() > command_->seq())) command_ = c;
    });
    bool weights = false;
    weights_.TakeAll(weights_scratch_, [&](const msg::PolicyWeights& w, const auto&) {
      if (Status s = store_.Apply(w); !s.ok())
        spdlog::warn("rejected: {}", s.message());
      else
        weights = true;
    });
    learner_.TakeAll(learner_scratch_, [&](const msg::LearnerStatus& s, const auto&) {
      if (command_ && s.command_seq() == command_->seq()) updates_ = s.updates();
    });
    if (command_seq() != before_seq) updates_ = 0;
    const bool restart = store_.structure_changes() != before_changes || acting() != before_acting;
    if (restart || weights || command_seq() != before_seq)
      actor.Configure(&store_.models(), acting(), command_seq(), store_.versions(), restart);
  }
  // this actor's share of the steps the command allows now
  uint64_t Allowance() const {
    // no steps before the command, nor before the weights its acting level needs: steps taken
    // at a lower level would count against the pacing and train nothing
    if (!command_ || store_.models().contiguous() < acting() || await_chain_steps_) return 0;
    double total = double(command_->step_base()) + command_->steps_per_update() * double(updates_);
    if (command_->step_base() == 0 && command_->steps_per_update() == 0) total = 1e18;
    if (command_->step_limit() > 0) total = std::min(total, double(command_->step_limit()));
    return Share(uint64_t(total));
  }
  // this actor's part of `all` run steps, as the launcher and the pacing split them
  uint64_t Share(uint64_t all) const { return ActorShare(all, actor_id_, actors_); }

  void Fill(msg::ActorStats* stats, const ActorCounters& c) const {
    stats->command_seq(command_seq());
    stats->acting_level(acting());
    std::vector<uint64_t> ended(8), reached(8);
    for (int i = 0; i < 8; ++i)
      ended[size_t(i)] = c.hierarchy.goals_ended[i], reached[size_t(i)] = c.hierarchy.goals_reached[i];
    stats->goals_started(ended);
    stats->goals_reached(reached);
    stats->policy_versions(store_.versions());
    stats->weights_rejected(store_.rejected());
    stats->paced_waits(c.paced_waits);
    stats->detector_pair(CountedDetector());
    stats->detector_states(c.hierarchy.detector_states);
    stats->detector_truth(c.hierarchy.detector_truth);
    stats->detector_fp(c.hierarchy.detector_fp);
    stats->detector_fn(c.hierarchy.detector_fn);
  }

 private:
  WeightsStore store_;
  uint64_t actor_id_, actors_;
  bool await_chain_steps_;
  Status status_;
  dds::Reader<msg::ChainStatus> chain_status_;
  msg::ChainStatus chain_status_scratch_;
  dds::Reader<msg::ChainCommand> commands_;
  dds::Reader<msg::PolicyWeights> weights_;
  dds::Reader<msg::LearnerStatus> learner_;
  msg::ChainCommand command_scratch_;
  msg::PolicyWeights weights_scratch_;
  msg::LearnerStatus learner_scratch_;
  std::optional<msg::ChainCommand> command_;
  uint64_t updates_ = 0;
};

// the sink of the actor's batches. After a stop request the actor stops stepping but still
// publishes its partial batches; the sink gives up waiting for the shard only once
// flush_timeout_s has passed. The sink has a participant of its own, which it replaces when the
// stream stalls (actors/batch_sink.h).
Result<std::unique_ptr<DdsBatchSink>> OpenSink(const DdsOptions& dds, const std::string& name, int64_t shard,
                                               double flush_timeout_s) {
  const auto flush_timeout = std::chrono::duration<double>(flush_timeout_s);
  auto stopping = [flush_timeout, stop_seen = std::optional<std::chrono::steady_clock::time_point>()]() mutable {
    if (!StopRequested()) return false;
    if (!stop_seen) stop_seen = std::chrono::steady_clock::now();
    return std::chrono::steady_clock::now() - *stop_seen > flush_timeout;
  };
  auto sink = DdsBatchSink::Create(dds, name + ".transitions", shard, stopping);
  if (!sink.ok()) return sink.status().WithContext("cannot open DDS topics");
  return sink;
}

// ActorStats: filled from the actor's counters with the step rate since the last fill
class StatsReporter {
 public:
  StatsReporter(int64_t id, const std::string& env, int64_t shard, const DdsBatchSink& sink, const ChainFollower* chain,
                uint64_t incarnation, uint64_t first_step)
      : sink_(sink), chain_(chain), last_steps_(first_step) {
    stats_.schema_version(msg::STATUS_SCHEMA);
    stats_.actor_id(static_cast<uint32_t>(id));
    stats_.incarnation(incarnation);
    stats_.first_step(first_step);
    stats_.env(env);
    stats_.shard(static_cast<uint32_t>(shard));
  }
  // the count moved to `first` before the first step
  void CountFrom(uint64_t first) {
    stats_.first_step(first);
    last_steps_ = first;
  }
  const msg::ActorStats& Fill(const ActorCounters& c) {
    auto now = std::chrono::steady_clock::now();
    double dt = std::chrono::duration<double>(now - last_time_).count();
    stats_.steps_per_s(dt > 0 ? (c.steps - last_steps_) / dt : 0.0);
    last_time_ = now;
    last_steps_ = c.steps;
    stats_.steps(c.steps);
    stats_.episodes(c.episodes);
    stats_.batches(c.batches);
    stats_.transitions_published(c.transitions_published);
    stats_.payload_checksum(c.payload_checksum);
    stats_.publish_retries(sink_.retries());
    stats_.env_errors(c.step_errors);
    uint64_t clipped = 0;
    for (uint64_t n : c.hierarchy.goals_clipped) clipped += n;
    stats_.goals_clipped(clipped);
    stats_.mean_episode_return(c.returns_counted ? c.return_sum / c.returns_counted : 0.0);
    if (chain_) chain_->Fill(&stats_, c);
    return stats_;
  }

 private:
  msg::ActorStats stats_;
  const DdsBatchSink& sink_;
  const ChainFollower* chain_;
  std::chrono::steady_clock::time_point last_time_ = std::chrono::steady_clock::now();
  uint64_t last_steps_ = 0;
};

// the final stats: published once the watchers had a moment to match, written to --stats-out,
// and logged
void ReportFinalStats(dds::Writer<msg::ActorStats>& writer, const msg::ActorStats& stats,
                      const std::string& stats_out) {
  // a short run can end before anyone watching (coins run, monitor) has discovered this actor:
  // give them a moment to match so the final stats are seen
  for (int i = 0; i < 100 && writer.matched() == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  writer.Write(stats);
  writer.WaitAcked(std::chrono::seconds(2));
  if (!stats_out.empty()) {
    if (Status s = WriteFileAtomic(stats_out, ActorStatsJson(stats).dump() + "\n"); !s.ok())
      spdlog::warn("{}", s.message());
  }
  spdlog::info("done: {} steps, {} episodes, {} batches, {} transitions published", stats.steps(), stats.episodes(),
               stats.batches(), stats.transitions_published());
  if (stats.detector_states())
    spdlog::info("detector {} against the env's labels: {} states, {} labelled, {} false positives, {} missed",
                 stats.detector_pair(), stats.detector_states(), stats.detector_truth(), stats.detector_fp(),
                 stats.detector_fn());
}

}  // namespace

int ActorMain(int argc, char** argv) {
  ProcessMain main("coins-actor", "Runs environments and streams their transitions to a replay shard over DDS.");
  RunOptions run;
  ActorOptions options;
  int64_t id = 0;
  std::string stats_out;
  main.AddSection(ConfigSection::Of("run", run));
  main.AddSection(ConfigSection::Of("actor", options));
  main.app().add_option("--id", id, "actor id (publishes to shard id mod run.shards)")->check(CLI::Range(0, 1 << 20));
  main.app().add_option("--stats-out", stats_out, "write the final ActorStats as JSON to this file");
  uint64_t first_step = 0;
  bool first_step_from_chain = false;
  main.app().add_option("--first-step", first_step,
                        "count env steps from here (a resumed run: this actor's share of the run's steps)");
  main.app().add_flag("--first-step-from-chain", first_step_from_chain,
                      "take no step before the orchestrator's first ChainStatus, and count on from this actor's "
                      "share of its env steps when that is more (a resumed run on a host without the orchestrator)");
  if (int rc = main.Parse(argc, argv); rc >= 0) return rc;
  if (main.name() == "coins-actor") main.name() = "actor-" + std::to_string(id);
  if (first_step_from_chain && !options.follow_chain)
    return ExitWithError(Errorf("--first-step-from-chain needs actor.follow_chain: true"), 2);

  int64_t shard = id % run.shards;
  uint64_t steps = options.steps ? options.steps : (run.steps ? (run.steps + run.actors - 1) / run.actors : 0);

  auto dds = main.OpenNode("actor");
  if (!dds.ok()) return ExitWithError(dds.status(), 1);
  auto stats_writer = dds->node->MakeWriter<msg::ActorStatsPubSubType>(dds::kActorStatsTopic, dds::StatusWriterQos());
  if (!stats_writer.ok()) return ExitWithError(stats_writer.status().WithContext("cannot open DDS topics"), 1);
  auto sink = OpenSink(main.dds(), main.name(), shard, options.flush_timeout_s);
  if (!sink.ok()) return ExitWithError(sink.status(), 1);
  auto actor = Actor::Create(run.env, options, static_cast<uint32_t>(id), static_cast<uint64_t>(run.seed), sink->get());
  if (!actor.ok()) return ExitWithError(actor.status(), 2);
  std::unique_ptr<ChainFollower> chain;
  if (options.follow_chain) {
    chain = std::make_unique<ChainFollower>(*dds->node, (*actor)->spec(), id, run.actors, first_step_from_chain);
    if (!chain->status().ok()) return ExitWithError(chain->status().WithContext("cannot open DDS topics"), 1);
  }
  spdlog::info("env {} (state {} floats), {} envs, publishing to shard {}, steps {}{}{}", run.env,
               (*actor)->spec().state_dim(), options.envs, shard, steps ? std::to_string(steps) : "unbounded",
               chain ? ", following the chain" : ", random actions",
               first_step ? fmt::format(", counting env steps on from {}", first_step) : "");
  dds::Heartbeat& heartbeat = dds->heartbeat;
  heartbeat.Publish("running");

  // status: ActorStats with the step rate over the last period
  (*actor)->CountStepsFrom(first_step);
  StatsReporter stats(id, run.env, shard, **sink, chain.get(), (*actor)->incarnation(), first_step);
  Actor::Hooks hooks;
  hooks.stop = [] { return StopRequested(); };
  hooks.period = std::chrono::milliseconds(static_cast<int64_t>(options.status_period_s * 1000));
  hooks.on_period = [&](const ActorCounters& c) {
    stats_writer->Write(stats.Fill(c));
    heartbeat.Publish("running");
  };
  if (chain) {
    hooks.poll = [&](Actor& a) {
      if (const uint64_t share = chain->TakeChainSteps(a); share > 0) {
        stats.CountFrom(share);
        spdlog::info("counting env steps on from {}: its share of the run's env steps in the chain status", share);
      }
      chain->Poll(a);
    };
    hooks.allowance = [&] { return chain->Allowance(); };
  }
  (*actor)->Run(steps, hooks);

  heartbeat.Publish("stopping");
  bool acked = (*sink)->Flush(std::chrono::milliseconds(static_cast<int64_t>(options.flush_timeout_s * 1000)));
  if (!acked) spdlog::warn("not every batch was acknowledged within {} s", options.flush_timeout_s);
  ReportFinalStats(*stats_writer, stats.Fill((*actor)->counters()), stats_out);
  return 0;
}

}  // namespace coins

int main(int argc, char** argv) { return coins::ActorMain(argc, argv); }
