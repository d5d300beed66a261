// System test of the chain protocol (orchestrator/README.md) across real processes: a
// coins-replay shard, a coins-actor and coins-orchestrator on a private DDS domain; the test
// speaks the learner's side over DDS (LearnerStatus, InteractionScores, checkpoint acks).
#include <signal.h>

#include <gtest/gtest.h>

#include <fstream>

#include "common/checkpoint.h"
#include "common/dds/node.h"
#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "idl/controlPubSubTypes.h"
#include "idl/statusPubSubTypes.h"
#include "orchestrator/orchestrator_options.h"
#include "tests/process_harness.h"

namespace coins {
namespace {

using namespace coins::testing;
namespace fs = std::filesystem;
using std::chrono::seconds;

// the learner's side of the protocol, driven by the test
struct FakeLearner {
  std::unique_ptr<dds::Node> node;
  dds::Writer<msg::LearnerStatus> status;
  dds::Writer<msg::InteractionScores> scores;
  dds::Reader<msg::ChainCommand> commands;
  dds::Reader<msg::Control> control;
  msg::ChainCommand newest;
  msg::LearnerStatus report;
  std::vector<msg::Control> controls;

  void Open(int domain) {
    DdsOptions dds;
    dds.domain = domain;
    auto n = dds::Node::Create(dds, "fake-learner");
    ASSERT_TRUE(n.ok()) << n.status().message();
    node = std::move(*n);
    auto st = node->MakeWriter<msg::LearnerStatusPubSubType>(dds::kLearnerStatusTopic, dds::StatusWriterQos());
    auto sc = node->MakeWriter<msg::InteractionScoresPubSubType>(dds::kScoresTopic, dds::StatusWriterQos());
    auto cm = node->MakeReader<msg::ChainCommandPubSubType>(dds::kChainCommandTopic, dds::LatchedReaderQos());
    auto ct = node->MakeReader<msg::ControlPubSubType>(dds::kControlTopic, dds::CommandReaderQos());
    ASSERT_TRUE(st.ok() && sc.ok() && cm.ok() && ct.ok());
    status = *st, scores = *sc, commands = *cm, control = *ct;
    report.schema_version(msg::STATUS_SCHEMA);
    report.state("running");
  }
  // takes commands and controls, publishes the status; every 100 ms until pred() or timeout
  template <typename Pred>
  bool Until(Pred pred, seconds timeout) {
    return WaitUntil(
        [&] {
          commands.TakeAll([&](const msg::ChainCommand& c, const auto&) { newest = c; });
          control.TakeAll([&](const msg::Control& c, const auto&) { controls.push_back(c); });
          report.command_seq(newest.seq());
          report.job(newest.job());
          status.Write(report);
          return pred();
        },
        timeout);
  }
};

struct Cluster {
  fs::path dir;
  int domain;
  std::vector<ChildProcess> procs;  // shard, actor, orchestrator

  std::vector<std::string> Flags() { return {"--config", (dir / "config.yaml").string(), "--quiet-config"}; }
  void WriteConfig() {
    std::ofstream(dir / "config.yaml")
        << "dds: {domain: " << domain << "}\n"
        << "run: {env: breakout, actors: 1, shards: 1, steps: 0, dir: " << (dir / "run").string() << "}\n"
        << "actor: {steps: 3000, status_period_s: 0.2, batch_rows: 64}\n"
        << "replay: {capacity_mb: 64, status_period_s: 0.2, snapshot_dir: " << (dir / "run" / "replay").string()
        << "}\n"
        << "orchestrator: {detect_every_steps: 2000, checkpoint_period_s: 3600, checkpoint_timeout_s: 60}\n";
  }
  ChildProcess Start(const std::string& binary, const std::string& name, std::vector<std::string> extra) {
    std::vector<std::string> argv = {Bin(binary), "--name", name};
    for (auto& f : Flags()) argv.push_back(f);
    argv.insert(argv.end(), extra.begin(), extra.end());
    auto c = ChildProcess::Spawn(name, argv, (dir / (name + ".log")).string(), true);
    EXPECT_TRUE(c.ok()) << c.status().message();
    return std::move(*c);
  }
  ~Cluster() { StopAll(procs, seconds(10)); }
};

msg::InteractionScore Score(const std::string& target, double sc, bool eligible) {
  msg::InteractionScore s;
  s.source("Action");
  s.target(target);
  s.score(sc);
  s.pass(sc > 3);
  s.eligible(eligible);
  s.mask({0, 1, 0, 0, 0});
  s.goal_kind("continuous");
  s.goal_set({-1, 1});
  return s;
}

TEST(ChainProtocol, DetectAcceptCheckpointAndRestartOverRealProcesses) {
  Cluster c{TempDir("chain-protocol"), TestDomain(10), {}};
  c.WriteConfig();
  FakeLearner learner;
  learner.Open(c.domain);
  c.procs.push_back(c.Start("coins-replay", "replay-0", {"--id", "0"}));
  c.procs.push_back(c.Start("coins-orchestrator", "orchestrator", {}));
  c.procs.push_back(c.Start("coins-actor", "actor-0", {"--id", "0"}));

  // 3000 random steps pass the detect point at 2000: a detect round of Action's targets
  ASSERT_TRUE(learner.Until([&] { return learner.newest.phase() == "detecting"; }, seconds(60)));
  EXPECT_EQ(learner.newest.seq(), 2u);
  EXPECT_EQ(learner.newest.round(), 1u);
  EXPECT_EQ(learner.newest.job(), "detect");
  EXPECT_EQ(learner.newest.targets(), (std::vector<std::string>{"Paddle", "Ball", "Block"}));
  EXPECT_EQ(learner.newest.step_base(), 2000u);

  // the phase change cut epoch 1: the shard snapshots it; the epoch completes with our ack
  ASSERT_TRUE(learner.Until([&] { return !learner.controls.empty(); }, seconds(10)));
  const msg::Control cut = learner.controls.front();
  EXPECT_EQ(cut.command(), msg::CONTROL_CHECKPOINT);
  EXPECT_EQ(cut.argument(), "1");
  EXPECT_EQ(cut.command_id(), CheckpointCommandId(1));
  learner.report.checkpoint_epoch(1);
  learner.report.checkpoint_command(cut.command_id());
  ASSERT_TRUE(learner.Until([&] { return learner.newest.epoch() == 1; }, seconds(30)));
  EXPECT_EQ(learner.newest.seq(), 2u) << "an epoch update is not a new command";
  EXPECT_TRUE(fs::exists(c.dir / "run" / "chain" / "chain-epoch-1.json"));
  // the shard acknowledged with a snapshot stamped with the epoch's id (or none: a shard that
  // held nothing yet when the command came writes no file)
  std::ifstream shard_log(c.dir / "replay-0.log");
  std::string shard_text((std::istreambuf_iterator<char>(shard_log)), std::istreambuf_iterator<char>());
  EXPECT_NE(shard_text.find("(command " + std::to_string(CheckpointCommandId(1)) + ")"), std::string::npos)
      << shard_text;
  const fs::path snapshot = c.dir / "run" / "replay" / "shard-0-00000000.snap";
  if (fs::exists(snapshot)) {
    auto inspect = RunCommand(Bin("coins") + " replay inspect --json " + snapshot.string());
    ASSERT_EQ(inspect.code, 0) << inspect.output;
    EXPECT_EQ(nlohmann::json::parse(inspect.output)["meta"]["command_id"], CheckpointCommandId(1));
  }

  // stale scores (old seq) change nothing; the round's answer accepts the argmax eligible link
  msg::InteractionScores answer;
  answer.schema_version(msg::STATUS_SCHEMA);
  answer.source("Action");
  answer.round(1);
  answer.command_seq(1);
  answer.scores({Score("Paddle", 6.5, true), Score("Ball", 2.0, true), Score("Block", 9.0, false)});
  learner.scores.Write(answer);
  learner.Until([] { return false; }, seconds(1));
  EXPECT_EQ(learner.newest.phase(), "detecting");
  answer.command_seq(2);
  learner.scores.Write(answer);
  ASSERT_TRUE(learner.Until([&] { return learner.newest.phase() == "training-skill"; }, seconds(20)));
  const msg::ChainCommand accepted = learner.newest;
  EXPECT_EQ(accepted.seq(), 3u);
  EXPECT_EQ(accepted.job(), "train-skill");
  ASSERT_EQ(accepted.links().size(), 1u);
  EXPECT_EQ(accepted.links()[0].target(), "Paddle");
  EXPECT_EQ(accepted.links()[0].score(), 6.5);
  EXPECT_EQ(accepted.links()[0].mask(), (std::vector<float>{0, 1, 0, 0, 0}));
  EXPECT_EQ(accepted.acting_level(), 1);
  EXPECT_EQ(accepted.steps_per_update(), OrchestratorOptions{}.skill_steps_per_update);

  // kill -9 of the orchestrator: restarted, it publishes the same command from chain.json. A
  // late joiner reads it (latched); a fresh participant, because Fast DDS 2.9 may leave the
  // shared-memory port of a reader unusable when a writer is killed while writing to it
  c.procs[1].Signal(SIGKILL);
  ASSERT_TRUE(c.procs[1].WaitFor(Scaled(seconds(5))));
  c.procs[1] = c.Start("coins-orchestrator", "orchestrator", {});
  FakeLearner late;
  late.Open(c.domain);
  ASSERT_TRUE(late.Until([&] { return late.newest.seq() != 0; }, seconds(30)));
  EXPECT_EQ(late.newest, accepted);
  std::ifstream log(c.dir / "orchestrator.log");
  std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("continuing the chain from"), std::string::npos) << text;
}

}  // namespace
}  // namespace coins
