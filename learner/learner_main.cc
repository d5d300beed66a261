// coins-learner: the learner process. Follows the orchestrator's ChainCommand (detect rounds,
// skill and task training: learner/learner_core.h), samples from the replay shards over DDS,
// publishes InteractionScores, PolicyWeights and LearnerStatus, writes a checkpoint when a
// Control CHECKPOINT asks, and resumes from its newest checkpoint when it starts again.
#include <filesystem>
#include <map>
#include <thread>

#include <spdlog/spdlog.h>

#include "actors/envs/env.h"
#include "common/dds/heartbeat.h"
#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "common/env_steps.h"
#include "common/process.h"
#include "common/run_options.h"
#include "idl/controlPubSubTypes.h"
#include "idl/statusPubSubTypes.h"
#include "idl/weightsPubSubTypes.h"
#include "learner/checkpoint_dirs.h"
#include "learner/learner_core.h"
#include "learner/learner_options.h"
#include "learner/replay_client/prefetcher.h"
#include "learner/replay_client/replay_client.h"

namespace coins {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct Topics {
  dds::Reader<msg::ChainCommand> commands;
  dds::Reader<msg::Control> control;
  dds::Reader<msg::ActorStats> actors;
  dds::Writer<msg::PolicyWeights> weights;
  dds::Writer<msg::InteractionScores> scores;
  dds::Writer<msg::LearnerStatus> status;
};

Result<Topics> OpenTopics(dds::Node& node) {
  Topics t;
  auto commands = node.MakeReader<msg::ChainCommandPubSubType>(dds::kChainCommandTopic, dds::LatchedReaderQos());
  auto control = node.MakeReader<msg::ControlPubSubType>(dds::kControlTopic, dds::CommandReaderQos());
  auto actors = node.MakeReader<msg::ActorStatsPubSubType>(dds::kActorStatsTopic, dds::StatusReaderQos());
  auto weights = node.MakeWriter<msg::PolicyWeightsPubSubType>(dds::kWeightsTopic, dds::LatchedWriterQos());
  auto scores = node.MakeWriter<msg::InteractionScoresPubSubType>(dds::kScoresTopic, dds::StatusWriterQos());
  auto status = node.MakeWriter<msg::LearnerStatusPubSubType>(dds::kLearnerStatusTopic, dds::StatusWriterQos());
  for (const Status* s :
       {&commands.status(), &control.status(), &actors.status(), &weights.status(), &scores.status(), &status.status()})
    if (!s->ok()) return *s;
  t.commands = *commands;
  t.control = *control;
  t.actors = *actors;
  t.weights = *weights;
  t.scores = *scores;
  t.status = *status;
  return t;
}

// env steps of the run from the actors' reports
class EnvSteps {
 public:
  void Take(dds::Reader<msg::ActorStats>& reader) {
    reader.TakeAll(scratch_, [&](const msg::ActorStats& s, const auto&) {
      count_.Report(s.actor_id(), s.steps(), s.incarnation(), s.first_step());
    });
  }
  uint64_t total() const { return count_.total(); }

 private:
  EnvStepCount count_;
  msg::ActorStats scratch_;
};

void PublishOutputs(Topics& t, LearnerCore::Outputs& out) {
  for (const auto& s : out.scores) t.scores.Write(s);
  for (const auto& w : out.weights) {
    t.weights.Write(w);
    spdlog::info("published {} v{} ({} bytes, learner step {})", w.name(), w.version() & ((uint64_t(1) << 40) - 1),
                 w.blob().size(), w.learner_step());
  }
  out.scores.clear();
  out.weights.clear();
}

class LearnerProcess {
 public:
  LearnerProcess(const RunOptions& run, const LearnerOptions& options, Topics topics, std::unique_ptr<LearnerCore> core,
                 SampleSource* source)
      : run_(run), options_(options), t_(std::move(topics)), core_(std::move(core)), source_(source) {}
  int Run(dds::Heartbeat& heartbeat);

 private:
  void TakeCommands();
  void TakeControl();
  void PublishStatus(dds::Heartbeat& heartbeat);

  RunOptions run_;
  LearnerOptions options_;
  Topics t_;
  std::unique_ptr<LearnerCore> core_;
  SampleSource* source_;
  EnvSteps env_steps_;
  uint64_t last_checkpoint_command_ = 0;  // the newest checkpoint command written
  LearnerCore::Outputs out_;
  std::vector<msg::InteractionScores> last_scores_;
  uint64_t last_updates_ = 0;
  Clock::time_point last_status_ = Clock::now();
  std::string failure_;
};

void LearnerProcess::TakeCommands() {
  msg::ChainCommand newest;
  bool got = false;
  t_.commands.TakeAll([&](const msg::ChainCommand& c, const auto&) {
    if (c.schema_version() != msg::CHAIN_COMMAND_SCHEMA) {
      spdlog::warn("ignoring ChainCommand with schema {}", c.schema_version());
      return;
    }
    if (!got || c.seq() > newest.seq()) newest = c, got = true;
  });
  // after a resume the core holds the checkpoint's seq but waits for that command in full
  if (!got || (core_->has_command() && newest.seq() == core_->command_seq())) return;
  if (Status s = core_->OnCommand(newest, &out_); !s.ok()) {
    failure_ = s.message();
    spdlog::error("command {}: {}", newest.seq(), s.message());
    return;
  }
  spdlog::info("command {}: phase {}, job {}", newest.seq(), newest.phase(), newest.job());
  failure_.clear();  // a failure belongs to the command that had it
  last_scores_.clear();
  PublishOutputs(t_, out_);
}

void LearnerProcess::TakeControl() {
  t_.control.TakeAll([&](const msg::Control& c, const auto&) {
    if (c.command() != msg::CONTROL_CHECKPOINT || (c.target() != "all" && c.target() != "learner")) return;
    const std::string& a = c.argument();
    if (a.empty() || a.size() > 15 || a.find_first_not_of("0123456789") != std::string::npos) {
      spdlog::warn("checkpoint command {}: epoch '{}' is not a number", c.command_id(), a);
      return;
    }
    const uint64_t epoch = std::stoull(a);
    // the orchestrator repeats a command until every process acknowledged it: written once
    if (c.command_id() == last_checkpoint_command_) return;
    std::error_code ec;
    fs::create_directories(fs::path(run_.dir) / "checkpoints", ec);
    const auto start = Clock::now();
    if (Status s = core_->SaveCheckpoint(CheckpointDir(run_.dir, epoch), epoch, c.command_id()); !s.ok()) {
      spdlog::error("checkpoint epoch {}: {}", epoch, s.message());
      return;
    }
    last_checkpoint_command_ = c.command_id();
    PruneCheckpoints(run_.dir, options_.checkpoint_keep);
    spdlog::info("checkpoint epoch {} written in {:.2f} s", epoch,
                 std::chrono::duration<double>(Clock::now() - start).count());
  });
}

void LearnerProcess::PublishStatus(dds::Heartbeat& heartbeat) {
  const auto now = Clock::now();
  const double dt = std::chrono::duration<double>(now - last_status_).count();
  if (dt < options_.status_period_s) return;
  msg::LearnerStatus s = core_->status();
  s.updates_per_s(double(s.total_updates() - last_updates_) / dt);
  if (!failure_.empty()) {
    s.state("failed");
    s.message(failure_);
  }
  last_updates_ = s.total_updates();
  last_status_ = now;
  t_.status.Write(s);
  // scores of a finished round stay visible while the orchestrator may still be deciding
  for (const auto& sc : last_scores_) t_.scores.Write(sc);
  heartbeat.Publish("running");
}

int LearnerProcess::Run(dds::Heartbeat& heartbeat) {
  // a detect round or a detector retrain holds Work for seconds (minutes at the default budgets
  // on a slow machine): status, checkpoint acknowledgements and the heartbeat keep going
  core_->SetProgressTick([this, &heartbeat] { PublishStatus(heartbeat); });
  while (!StopRequested()) {
    TakeCommands();
    TakeControl();
    env_steps_.Take(t_.actors);
    auto worked = core_->Work(source_, env_steps_.total(), &out_);
    if (!worked.ok()) {
      failure_ = worked.status().message();
      spdlog::error("{}", failure_);
      SleepUnlessStopped(std::chrono::milliseconds(500));
    } else if (*worked) {
      failure_.clear();
    }
    if (!out_.scores.empty()) last_scores_ = out_.scores;
    PublishOutputs(t_, out_);
    PublishStatus(heartbeat);
    if (worked.ok() && !*worked) SleepUnlessStopped(std::chrono::milliseconds(5));
  }
  heartbeat.Publish("stopping");
  return 0;
}

int LearnerMain(int argc, char** argv) {
  ProcessMain main("coins-learner", "Trains detectors, skills and the task policy from replay samples.");
  RunOptions run;
  LearnerOptions options;
  int64_t resume_epoch = -1;
  main.AddSection(ConfigSection::Of("run", run));
  main.AddSection(ConfigSection::Of("learner", options));
  main.AddSection(ConfigSection::Of("detector", options.detector));
  main.app()
      .add_option("--resume-epoch", resume_epoch, "start from this checkpoint epoch (default: the newest)")
      ->check(CLI::NonNegativeNumber);
  if (int rc = main.Parse(argc, argv); rc >= 0) return rc;
  if (main.name() == "coins-learner") main.name() = "learner";

  auto env = envs::MakeEnv(run.env);
  if (!env.ok()) return ExitWithError(env.status().WithContext("run.env"), 2);
  auto core = std::make_unique<LearnerCore>((*env)->spec(), options, uint64_t(run.seed));
  const int64_t epoch = resume_epoch >= 0 ? resume_epoch : NewestCheckpointEpoch(run.dir);
  if (epoch >= 0) {
    if (Status s = core->LoadCheckpoint(CheckpointDir(run.dir, uint64_t(epoch))); !s.ok())
      return ExitWithError(s.WithContext("resume"), 2);
    spdlog::info("resumed from checkpoint epoch {}", epoch);
  }

  auto dds = main.OpenNode("learner");
  if (!dds.ok()) return ExitWithError(dds.status(), 1);
  auto topics = OpenTopics(*dds->node);
  if (!topics.ok()) return ExitWithError(topics.status().WithContext("cannot open DDS topics"), 1);
  ReplayClientOptions co;
  co.shards = int(run.shards);
  co.name = main.name();
  co.shard_wait = std::chrono::milliseconds(int64_t(options.shard_wait_s * 1000));
  auto client = ReplayClient::Create(*dds->node, co);
  if (!client.ok()) return ExitWithError(client.status().WithContext("cannot open DDS topics"), 1);
  auto prefetch = PrefetchingSource::Create(client->get());
  if (!prefetch.ok()) return ExitWithError(prefetch.status(), 1);
  dds->heartbeat.Publish("running");
  LearnerProcess process(run, options, std::move(*topics), std::move(core), prefetch->get());
  return process.Run(dds->heartbeat);
}

}  // namespace
}  // namespace coins

int main(int argc, char** argv) { return coins::LearnerMain(argc, argv); }
