// System test of the chain on MuJoCo pushing across real processes: `coins run` with
// deploy/configs/pushing.yaml (shard, learner, orchestrator, two actors over Fast DDS) accepts
// Action->Gripper from its own detect round (mask x, y, z, continuous goals), rejects
// Action->Block, and trains the gripper skill (ddpg over the 3-d displacement action) from replay
// until `coins eval` of its checkpoint reaches 90% of random goals within 4.8 mm. On the way, a
// kill -9 of the learner restarts it from its newest checkpoint (its first gripper weights carry
// the checkpoint's checksum); after the stop, `coins run --resume` continues the same skill.
#include <signal.h>

#include <gtest/gtest.h>

#include "orchestrator/chain_store.h"
#include "tests/process_harness.h"
#include "tests/weights_watch.h"

namespace coins {
namespace {

using namespace coins::testing;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

// the learner updates in the newest complete checkpoint while it trains level 1 (0 when none)
int64_t GripperUpdates(const fs::path& run) {
  const nlohmann::json state = NewestLearnerCheckpoint(run);
  if (!state.is_object() || state.value("train_level", 0) != 1) return 0;
  return state.value("total_updates", int64_t(0));
}

TEST(PushingChain, AcceptsActionToGripperAndTrainsTheGripperSkillAcrossProcesses) {
  auto dir = TempDir("pushing-chain");
  const fs::path run = dir / "run";
  const int domain = TestDomain();
  auto weights = WeightsWatch::Create(domain);
  ASSERT_TRUE(weights.ok()) << weights.status().message();
  std::vector<ChildProcess> coins;
  auto child = ChildProcess::Spawn(
      "coins-run",
      {"/bin/sh", "-c",
       "exec " + Bin("coins") + " run --config " + COINS_PUSHING_CONFIG + " --steps 0 --actors 2 --shards 1 --quiet" +
           " --dir " + run.string() + " --set dds.domain=" + std::to_string(domain) +
           " --set replay.capacity_mb=128 --set orchestrator.checkpoint_period_s=" + ScaledSeconds(5) +
           " --set run.max_restarts=2" + " --set orchestrator.checkpoint_timeout_s=" + ScaledSeconds(5)},
      (dir / "run.log").string());
  ASSERT_TRUE(child.ok());
  coins.push_back(std::move(*child));
  auto log = [&] {
    return ReadText(dir / "run.log") + "\n--- orchestrator\n" + ReadText(run / "logs" / "orchestrator.log");
  };

  // the first detect round of the actions: the gripper passes, the block does not
  // (a run that exits early fails the test at once, with its log)
  auto phase = [&](const std::string& want) { return coins[0].Poll() || ChainState(run).value("phase", "") == want; };
  ASSERT_TRUE(WaitUntil([&] { return phase("training-skill"); }, 180s)) << log();
  ASSERT_FALSE(coins[0].exited()) << log();
  const nlohmann::json accepted = ChainState(run);
  ASSERT_EQ(accepted["links"].size(), 1u);
  const nlohmann::json& link = accepted["links"][0]["spec"];
  EXPECT_EQ(link["source"], "Action");
  EXPECT_EQ(link["target"], "Gripper");
  EXPECT_GT(link["score"].get<double>(), 3.0);
  EXPECT_EQ(link["mask"], nlohmann::json({1.0, 1.0, 1.0}));
  EXPECT_EQ(link["goal_kind"], "continuous");
  bool block_scored = false;
  for (const auto& s : accepted["last_scores"])
    if (s["target"] == "Block") {
      block_scored = true;
      EXPECT_FALSE(s["pass"].get<bool>()) << s.dump();
      EXPECT_LT(s["score"].get<double>(), 3.0) << s.dump();
    }
  EXPECT_TRUE(block_scored) << accepted["last_scores"].dump();

  // a checkpoint with gripper training in it, then kill -9 of the learner: `coins run` restarts
  // it, and the first gripper weights it publishes are the checkpoint's
  ASSERT_TRUE(WaitUntil([&] { return coins[0].Poll() || GripperUpdates(run) > 0; }, 120s)) << log();
  const pid_t learner = PidOf("coins-learner", run);
  ASSERT_GT(learner, 0);
  ASSERT_EQ(kill(learner, SIGKILL), 0);
  std::this_thread::sleep_for(200ms);  // nothing checkpoints while the learner is down
  const auto expected = LevelChecksum(NewestLearnerCheckpoint(run), 1);
  ASSERT_TRUE(expected.has_value());
  weights->Drain();
  const auto first_after = weights->NextChecksum("skill/Gripper", 60s);
  ASSERT_TRUE(first_after.has_value()) << log();
  EXPECT_EQ(*first_after, *expected) << "the restarted learner's first gripper weights differ from its checkpoint";
  EXPECT_NE(ReadText(dir / "run.log").find("learner (pid " + std::to_string(learner) + ") was killed by signal 9"),
            std::string::npos)
      << log();
  EXPECT_EQ(ChainState(run)["links"].size(), 1u);

  // the gripper skill trains from replay (greedy success passed 0.9 by ~20k updates in every
  // run so far); then the run stops cleanly
  ASSERT_TRUE(WaitUntil([&] { return coins[0].Poll() || GripperUpdates(run) >= 20000; }, 300s)) << log();
  ASSERT_FALSE(coins[0].exited()) << log();
  coins[0].Signal(SIGTERM);
  ASSERT_TRUE(coins[0].WaitFor(Scaled(90s))) << log();
  EXPECT_EQ(PidOf("coins-actor", run), -1) << "an actor outlived the run";

  auto eval = RunCommand(Bin("coins") + " eval " + run.string() + " --skill Gripper --episodes 100 --seed 3 --json");
  ASSERT_EQ(eval.code, 0) << eval.output;
  const auto j = nlohmann::json::parse(eval.output.substr(eval.output.find('{')), nullptr, false);
  ASSERT_TRUE(j.is_object()) << eval.output;
  EXPECT_EQ(j["goals"], 100);
  EXPECT_GE(j["success"].get<double>(), 0.9) << eval.output;
  // the control step's speed: the env's step alone is a part of it
  EXPECT_GT(j["steps_per_s"].get<double>(), 0.0) << eval.output;
  EXPECT_GT(j["env_steps_per_s"].get<double>(), j["steps_per_s"].get<double>()) << eval.output;
  EXPECT_EQ(j["goal_sample_ratio"], 0.0) << eval.output;  // pushing.yaml: gripper goals anywhere
  // the same skill on goals near the gripper (what its parent asks), and the flag refused without --skill
  auto near = RunCommand(Bin("coins") + " eval " + run.string() +
                         " --skill Gripper --episodes 100 --seed 3 --goal-sample-ratio 0.05 --json");
  ASSERT_EQ(near.code, 0) << near.output;
  const auto jn = nlohmann::json::parse(near.output.substr(near.output.find('{')), nullptr, false);
  ASSERT_TRUE(jn.is_object()) << near.output;
  EXPECT_DOUBLE_EQ(jn["goal_sample_ratio"].get<double>(), 0.05);
  EXPECT_GE(jn["success"].get<double>(), 0.9) << near.output;
  EXPECT_LT(jn["steps"].get<double>(), j["steps"].get<double>()) << "near goals are reached sooner";
  auto no_skill = RunCommand(Bin("coins") + " eval " + run.string() + " --goal-sample-ratio 0.05");
  EXPECT_NE(no_skill.code, 0);
  EXPECT_NE(no_skill.output.find("--goal-sample-ratio needs --skill"), std::string::npos) << no_skill.output;

  // resumed, the run goes on training the same skill from its newest complete epoch
  const int64_t stopped_at = GripperUpdates(run);
  ASSERT_FALSE(chain::ChainStore::Epochs(run / "chain").empty());
  const std::string epoch = std::to_string(chain::ChainStore::Epochs(run / "chain").back());
  auto resumed = ChildProcess::Spawn(
      "coins-run", {"/bin/sh", "-c", "exec " + Bin("coins") + " run --resume " + run.string() + " --steps 0"},
      (dir / "resume.log").string());
  ASSERT_TRUE(resumed.ok());
  coins[0] = std::move(*resumed);
  auto resume_log = [&] {
    return ReadText(dir / "resume.log") + "\n--- learner\n" + ReadText(run / "logs" / "learner.log");
  };
  EXPECT_TRUE(WaitUntil([&] { return coins[0].Poll() || GripperUpdates(run) > stopped_at; }, 120s)) << resume_log();
  EXPECT_NE(ReadText(dir / "resume.log").find("resuming epoch " + epoch), std::string::npos) << resume_log();
  EXPECT_EQ(ChainState(run).value("phase", ""), "training-skill");
  EXPECT_EQ(ChainState(run)["links"].size(), 1u);
  coins[0].Signal(SIGTERM);
  ASSERT_TRUE(coins[0].WaitFor(Scaled(90s))) << resume_log();
  EXPECT_TRUE(coins[0].succeeded()) << resume_log();
}

}  // namespace
}  // namespace coins
