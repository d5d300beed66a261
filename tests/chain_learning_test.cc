// System test of the chain learning across real processes: `coins run` (shard, learner,
// orchestrator, two actors over Fast DDS) accepts Action->Paddle from its own detect round and
// trains the paddle skill to its success bar; a kill -9 of the learner mid-skill restarts it
// from its newest checkpoint (the first weights it publishes carry exactly the checkpoint's
// acting checksum) and the skill goes on to its bar. (A kill -9 of the orchestrator is
// chain_run_test's; together with this one it trips Fast DDS 2.9's reuse of a killed
// process's shared-memory port now and then, see the note in orchestrator/README.md.)
#include <signal.h>

#include <gtest/gtest.h>

#include "tests/process_harness.h"
#include "tests/weights_watch.h"

namespace coins {
namespace {

using namespace coins::testing;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

TEST(ChainLearning, PaddleSkillLearnedAcrossProcessesThroughKillNineOfTheLearner) {
  auto dir = TempDir("chain-learning");
  const fs::path run = dir / "run";
  const int domain = TestDomain();

  // the test watches the weights the learner publishes, from before anything starts
  auto weights = WeightsWatch::Create(domain);
  ASSERT_TRUE(weights.ok()) << weights.status().message();

  std::vector<ChildProcess> coins;
  auto child = ChildProcess::Spawn(
      "coins-run",
      {"/bin/sh", "-c",
       "exec " + Bin("coins") + " run --steps 0 --actors 2 --shards 1 --quiet --dir " + run.string() +
           " --set dds.domain=" + std::to_string(domain) +
           " --set replay.capacity_mb=128 --set run.max_restarts=2 --set orchestrator.checkpoint_period_s=" +
           ScaledSeconds(3) + " --set orchestrator.checkpoint_timeout_s=" + ScaledSeconds(3) +
           " --set orchestrator.skill_max_steps=300000"},
      (dir / "run.log").string());
  ASSERT_TRUE(child.ok());
  coins.push_back(std::move(*child));
  auto log = [&] {
    return ReadText(dir / "run.log") + "\n--- orchestrator\n" + ReadText(run / "logs" / "orchestrator.log");
  };

  // Action->Paddle accepted by the orchestrator from the learner's scores, then trained from replay
  ASSERT_TRUE(WaitUntil([&] { return ChainState(run).value("phase", "") == "training-skill"; }, 120s)) << log();
  const nlohmann::json accepted = ChainState(run);
  ASSERT_EQ(accepted["links"].size(), 1u);
  EXPECT_EQ(accepted["links"][0]["spec"]["source"], "Action");
  EXPECT_EQ(accepted["links"][0]["spec"]["target"], "Paddle");
  EXPECT_GT(accepted["links"][0]["spec"]["score"].get<double>(), 3.0);

  // a checkpoint with training in it, then kill -9 of the learner
  ASSERT_TRUE(WaitUntil([&] { return LevelChecksum(NewestLearnerCheckpoint(run), 1).has_value(); }, 90s)) << log();
  const pid_t learner = PidOf("coins-learner", run);
  ASSERT_GT(learner, 0);
  ASSERT_EQ(kill(learner, SIGKILL), 0);
  const uint64_t seq_at_kill = ChainState(run)["seq"].get<uint64_t>();
  // nothing writes checkpoints while the learner is down: the newest one is what it resumes from
  std::this_thread::sleep_for(200ms);
  const auto expected = LevelChecksum(NewestLearnerCheckpoint(run), 1);
  ASSERT_TRUE(expected.has_value());
  weights->Drain();  // what the killed learner sent
  const auto first_after = weights->NextChecksum("skill/Paddle", 60s);
  ASSERT_TRUE(first_after.has_value()) << log();
  EXPECT_EQ(*first_after, *expected) << "the restarted learner's first paddle weights differ from its checkpoint";
  EXPECT_NE(ReadText(dir / "run.log").find("learner (pid " + std::to_string(learner) + ") was killed by signal 9"),
            std::string::npos);
  // the chain did not move back: the same command, or onwards
  EXPECT_GE(ChainState(run)["seq"].get<uint64_t>(), seq_at_kill);

  // the paddle skill reaches its bar: converged with a goal-reaching rate of at least 0.85
  // (actors explore, so the measured rate is below the greedy one)
  ASSERT_TRUE(WaitUntil([&] { return ChainState(run)["links"][0].value("learned_at_steps", 0) > 0; }, 240s)) << log();
  const nlohmann::json learned = ChainState(run)["links"][0];
  EXPECT_EQ(learned["learned_by"], "converged") << learned.dump();
  EXPECT_GE(learned["success"]["best"].get<double>(), 0.85) << learned.dump();
  EXPECT_NE(ChainState(run)["phase"], "training-skill");

  coins[0].Signal(SIGTERM);
  ASSERT_TRUE(coins[0].WaitFor(Scaled(90s))) << log();
  EXPECT_EQ(PidOf("coins-actor", run), -1) << "an actor outlived the run";

  // coins eval: no task policy yet is one line naming what there is; the paddle skill from the
  // newest checkpoint, greedy, reaches most of its goals (0.73 to 0.89 in the runs so far)
  auto no_task = RunCommand(Bin("coins") + " eval " + run.string());
  EXPECT_EQ(no_task.code, 2) << no_task.output;
  EXPECT_NE(no_task.output.find("no task policy"), std::string::npos) << no_task.output;
  EXPECT_NE(no_task.output.find("skill/Paddle"), std::string::npos) << no_task.output;
  auto paddle = RunCommand(Bin("coins") + " eval " + run.string() + " --skill Paddle --episodes 100 --seed 5 --json");
  ASSERT_EQ(paddle.code, 0) << paddle.output;
  const auto j = nlohmann::json::parse(paddle.output.substr(paddle.output.find('{')), nullptr, false);
  ASSERT_TRUE(j.is_object()) << paddle.output;
  EXPECT_EQ(j["goals"], 100);
  EXPECT_GE(j["success"].get<double>(), 0.6) << paddle.output;  // measured 0.73-0.89 over runs
  // the same skill on random goals playing whole Breakout episodes (each ends at its first drop,
  // -10, after the blocks it broke); the flag needs a skill
  auto play = RunCommand(Bin("coins") + " eval " + run.string() + " --skill Paddle --play-task --episodes 5 --json");
  ASSERT_EQ(play.code, 0) << play.output;
  const auto jp = nlohmann::json::parse(play.output.substr(play.output.find('{')), nullptr, false);
  ASSERT_TRUE(jp.is_object()) << play.output;
  EXPECT_EQ(jp["play_task"], true);
  ASSERT_EQ(jp["returns"].size(), 5u) << play.output;
  for (const auto& ret : jp["returns"]) {
    EXPECT_GE(ret.get<double>(), -10.0) << play.output;
    EXPECT_LE(ret.get<double>(), 100.0) << play.output;
  }
  auto play_task = RunCommand(Bin("coins") + " eval " + run.string() + " --play-task");
  EXPECT_EQ(play_task.code, 2);
  EXPECT_NE(play_task.output.find("--play-task needs --skill"), std::string::npos) << play_task.output;
}

}  // namespace
}  // namespace coins
