// System tests of `coins run` with the chain: a crashed child is restarted (bounded), the
// restarted orchestrator continues its chain, a replay shard stopped or killed during skill
// training is waited for, and `--resume RUN_DIR` starts every process from the newest complete
// epoch or refuses with one line.
#include <signal.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>

#include "common/checkpoint.h"
#include "orchestrator/chain_store.h"
#include "tests/process_harness.h"

namespace coins {
namespace {

using namespace coins::testing;
using namespace std::chrono_literals;
namespace fs = std::filesystem;

std::string Flags(const fs::path& dir, int domain) {
  return " --dir " + dir.string() + " --set dds.domain=" + std::to_string(domain) +
         " --set replay.capacity_mb=64 --set actor.status_period_s=0.2 --set replay.status_period_s=0.2";
}

// writes chain-epoch-N.json as the orchestrator does when epoch N completes
void MakeEpoch(const fs::path& run, uint64_t epoch) {
  auto j = ReadJson(run / "chain" / "chain.json");
  ASSERT_TRUE(j.is_object());
  j["state"]["epoch"] = epoch;
  j["state"]["last_cut_epoch"] = epoch;
  std::ofstream(run / "chain" / ("chain-epoch-" + std::to_string(epoch) + ".json")) << j.dump(1);
}

TEST(ChainRun, ACrashedOrchestratorIsRestartedAndContinuesUntilItsRetriesAreSpent) {
  auto dir = TempDir("chain-restart");
  const fs::path run = dir / "run";
  std::vector<ChildProcess> coins;
  auto child =
      ChildProcess::Spawn("coins-run",
                          {"/bin/sh", "-c",
                           "exec " + Bin("coins") + " run --steps 0 --actors 1 --shards 1 --set run.max_restarts=1" +
                               Flags(run, TestDomain(6))},
                          (dir / "run.log").string());
  ASSERT_TRUE(child.ok());
  coins.push_back(std::move(*child));
  // the chain leaves collecting at the first detect point (10k random steps)
  ASSERT_TRUE(WaitUntil([&] { return ChainState(run).value("seq", 0) >= 2; }, std::chrono::seconds(60)))
      << ReadText(dir / "run.log");
  const pid_t first = PidOf("coins-orchestrator", run);
  ASSERT_GT(first, 0);
  ASSERT_EQ(kill(first, SIGKILL), 0);
  // what the killed orchestrator persisted last: nothing else writes chain.json
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const nlohmann::json at_kill = ChainState(run);
  ASSERT_TRUE(WaitUntil([&] { return ReadText(dir / "run.log").find("orchestrator restarted") != std::string::npos; },
                        std::chrono::seconds(20)))
      << ReadText(dir / "run.log");
  // the restarted orchestrator continues the persisted chain: the same command seq, then onwards
  const std::string resumed = "(seq " + std::to_string(at_kill["seq"].get<uint64_t>()) + ", epoch";
  ASSERT_TRUE(WaitUntil(
      [&] {
        const std::string log = ReadText(run / "logs" / "orchestrator.log");
        const size_t at = log.find("continuing the chain from");
        return at != std::string::npos && log.find(resumed, at) != std::string::npos;
      },
      std::chrono::seconds(20)))
      << resumed << "\n"
      << ReadText(run / "logs" / "orchestrator.log");
  std::this_thread::sleep_for(std::chrono::seconds(1));
  EXPECT_GE(ChainState(run)["seq"].get<uint64_t>(), at_kill["seq"].get<uint64_t>());
  EXPECT_GE(ChainState(run)["env_steps"].get<uint64_t>(), at_kill["env_steps"].get<uint64_t>());
  // a second crash spends the last retry: the run stops, naming the child and why
  pid_t second = -1;
  ASSERT_TRUE(WaitUntil([&] { return (second = PidOf("coins-orchestrator", run)) > 0 && second != first; },
                        std::chrono::seconds(10)));
  ASSERT_EQ(kill(second, SIGKILL), 0);
  ASSERT_TRUE(coins[0].WaitFor(Scaled(std::chrono::seconds(40)))) << ReadText(dir / "run.log");
  const std::string out = ReadText(dir / "run.log");
  EXPECT_EQ(WEXITSTATUS(coins[0].status()), 1) << out;
  EXPECT_NE(
      out.find("orchestrator (pid " + std::to_string(first) + ") was killed by signal 9 (Killed); restarting (1/1)"),
      std::string::npos)
      << out;
  EXPECT_NE(out.find("orchestrator (pid " + std::to_string(second) +
                     ") was killed by signal 9 (Killed); restarts "
                     "exhausted (1/1)"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("| restarts 1"), std::string::npos) << out;
  EXPECT_EQ(PidOf("coins-actor", run), -1) << "an actor outlived the run";
}

// the newest update count of the trained level the learner logged with its weights, or -1
int64_t NewestLearnerStep(const fs::path& run) {
  const std::string log = ReadText(run / "logs" / "learner.log");
  const size_t at = log.rfind("learner step ");
  return at == std::string::npos ? -1 : std::stoll(log.substr(at + 13));
}

// how often text occurs in a file
size_t Occurrences(const fs::path& file, const std::string& text) {
  const std::string s = ReadText(file);
  size_t n = 0;
  for (size_t at = s.find(text); at != std::string::npos; at = s.find(text, at + 1)) ++n;
  return n;
}

// a shard stopped (SIGTERM: it writes its final snapshot) and then killed (SIGKILL) during skill
// training, each time restarted by `coins run`, is waited for: the learner samples from the shard
// that answers, takes the restarted one back, and the skill's training goes on
TEST(ChainRun, AReplayShardStoppedOrKilledDuringSkillTrainingIsWaitedFor) {
  auto dir = TempDir("chain-shard-away");
  const fs::path run = dir / "run";
  // a quick detect round (Action->Paddle scores about 4.2 > eps_SI 3); the skill never converges here
  const std::string chain_flags =
      " --set detector.passive_steps=1000 --set detector.passive_hard_steps=600 --set detector.active_steps=2500"
      " --set orchestrator.skill_min_goals=1000000000";
  std::vector<ChildProcess> coins;
  auto child = ChildProcess::Spawn(
      "coins-run",
      {"/bin/sh", "-c",
       "exec " + Bin("coins") + " run --steps 0 --actors 2 --shards 2" + Flags(run, TestDomain()) + chain_flags},
      (dir / "run.log").string());
  ASSERT_TRUE(child.ok());
  coins.push_back(std::move(*child));
  auto log = [&] {
    return ReadText(dir / "run.log") + "\n--- learner\n" + ReadText(run / "logs" / "learner.log") +
           "\n--- orchestrator\n" + ReadText(run / "logs" / "orchestrator.log");
  };
  // the round takes ~10 s here; under a sanitizer beside other tests it took more than 240 s
  ASSERT_TRUE(WaitUntil([&] { return ChainState(run).value("phase", "") == "training-skill"; }, 120s)) << log();
  ASSERT_TRUE(WaitUntil([&] { return NewestLearnerStep(run) >= 500; }, 30s)) << log();

  for (int sig : {SIGTERM, SIGKILL}) {
    SCOPED_TRACE(sig == SIGTERM ? "SIGTERM" : "SIGKILL");
    const size_t restarts = Occurrences(dir / "run.log", "replay-0 restarted");
    const size_t back = Occurrences(run / "logs" / "learner.log", "replay shard 0 answers again");
    auto pid = RunCommand("pgrep -f '[c]oins-replay --config " + (run / "config.yaml").string() + " --name replay-0 '");
    ASSERT_EQ(pid.code, 0) << pid.output;
    ASSERT_EQ(kill(pid_t(std::stol(pid.output)), sig), 0);
    ASSERT_TRUE(WaitUntil([&] { return Occurrences(dir / "run.log", "replay-0 restarted") > restarts; }, 20s)) << log();
    // the skill's training goes on: the learner keeps updating, the link stays in training
    const int64_t at_restart = NewestLearnerStep(run);
    auto ended = [&] { return ChainState(run).value("phase", "") != "training-skill"; };
    EXPECT_TRUE(WaitUntil([&] { return ended() || NewestLearnerStep(run) >= at_restart + 500; }, 30s)) << log();
    const nlohmann::json state = ChainState(run);
    ASSERT_EQ(state.value("phase", ""), "training-skill") << state.dump(1) << "\n" << log();
    ASSERT_EQ(state["links"].size(), 1u) << state.dump(1);
    // and samples from the restarted shard again: its newest line in the learner's log says so
    auto taken_back = [&] {
      const std::string learner = ReadText(run / "logs" / "learner.log");
      const size_t again = learner.rfind("replay shard 0 answers again"),
                   away = learner.rfind("replay shard 0: no reply");
      return Occurrences(run / "logs" / "learner.log", "replay shard 0 answers again") > back &&
             (away == std::string::npos || again > away);
    };
    EXPECT_TRUE(WaitUntil(taken_back, 20s)) << log();
  }
  coins[0].Signal(SIGTERM);
  ASSERT_TRUE(coins[0].WaitFor(Scaled(40s))) << log();
  EXPECT_TRUE(coins[0].succeeded()) << log();
}

// a short finished run to resume from: its config.yaml and chain.json
fs::path FinishedRun(const std::string& name, int domain) {
  auto dir = TempDir(name);
  // the chain stays in collecting (detect point out of reach), so the paced actor runs its steps
  auto r =
      RunCommand(Bin("coins") + " run --steps 20000 --actors 1 --shards 1 --quiet" + Flags(dir / "run", domain) +
                 " --set orchestrator.detect_every_steps=1000000000 --set orchestrator.detect_budget_steps=1000000000");
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(fs::exists(dir / "run" / "chain" / "chain.json")) << r.output;
  return dir / "run";
}

TEST(ChainRun, ResumeRefusesWithOneLineWhatDiffersOrIsMissing) {
  const fs::path run = FinishedRun("chain-resume-refused", TestDomain(7));
  for (uint64_t e : chain::ChainStore::Epochs(run / "chain"))
    fs::remove(run / "chain" / ("chain-epoch-" + std::to_string(e) + ".json"));
  auto one_line = [](const CommandResult& r) { return std::count(r.output.begin(), r.output.end(), '\n') == 1; };
  auto r = RunCommand(Bin("coins") + " run --resume " + run.string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_TRUE(one_line(r)) << r.output;
  EXPECT_NE(r.output.find("no complete checkpoint epoch in " + (run / "chain").string()), std::string::npos)
      << r.output;

  MakeEpoch(run, 1);
  r = RunCommand(Bin("coins") + " run --resume " + run.string() + " --set orchestrator.eps_si=5");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_TRUE(one_line(r)) << r.output;
  EXPECT_NE(r.output.find("orchestrator.eps_si is 5 here, 3 in " + (run / "config.yaml").string()), std::string::npos)
      << r.output;
  std::ofstream(run.parent_path() / "other.yaml")
      << "orchestrator:\n  detect_every_steps: 5000\n  detect_budget_steps: 1000000000\n";
  r = RunCommand(Bin("coins") + " run --resume " + run.string() + " --config " +
                 (run.parent_path() / "other.yaml").string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_TRUE(one_line(r)) << r.output;
  EXPECT_NE(r.output.find("orchestrator.detect_every_steps is 5000 here, 1000000000 in"), std::string::npos)
      << r.output;
}

// the chain stays in collecting (detect point out of reach) while epochs are cut every 2 s (times
// the test time scale):
// the shard snapshots and the learner checkpoints, all acknowledged
TEST(ChainRun, ResumeStartsShardsLearnerAndOrchestratorFromTheNewestCompleteEpoch) {
  auto dir = TempDir("chain-resume");
  const fs::path run = dir / "run";
  const std::string chain_flags =
      " --set orchestrator.detect_every_steps=1000000000 --set "
      "orchestrator.detect_budget_steps=1000000000 --set orchestrator.checkpoint_period_s=" +
      ScaledSeconds(2) + " --set orchestrator.checkpoint_timeout_s=" + ScaledSeconds(2);
  std::vector<ChildProcess> coins;
  auto first = ChildProcess::Spawn("coins-run",
                                   {"/bin/sh", "-c",
                                    "exec " + Bin("coins") +
                                        " run --steps 0 --actors 1 "
                                        "--shards 1 --quiet" +
                                        Flags(run, TestDomain(8)) + chain_flags},
                                   (dir / "first.log").string());
  ASSERT_TRUE(first.ok());
  coins.push_back(std::move(*first));
  ASSERT_TRUE(WaitUntil([&] { return !chain::ChainStore::Epochs(run / "chain").empty(); }, std::chrono::seconds(90)))
      << ReadText(run / "logs" / "orchestrator.log");
  coins[0].Signal(SIGTERM);
  ASSERT_TRUE(coins[0].WaitFor(Scaled(std::chrono::seconds(40))));
  ASSERT_TRUE(coins[0].succeeded()) << ReadText(dir / "first.log");
  const uint64_t epoch = chain::ChainStore::Epochs(run / "chain").back();
  std::ofstream(run / "chain" / ("chain-epoch-" + std::to_string(epoch + 5) + ".json")) << "{";  // newest, corrupt
  const std::vector<std::string> first_rows = Lines(ReadText(run / "metrics.csv"));
  ASSERT_GT(first_rows.size(), 2u);
  const std::string e = std::to_string(epoch);
  const uint64_t epoch_steps = nlohmann::json::parse(ReadText(run / "chain" / ("chain-epoch-" + e + ".json")))
                                   .at("state")
                                   .at("env_steps")
                                   .get<uint64_t>();
  ASSERT_GT(epoch_steps, 0u);

  auto second = ChildProcess::Spawn(
      "coins-run", {"/bin/sh", "-c", "exec " + Bin("coins") + " run --resume " + run.string() + " --steps 0"},
      (dir / "resume.log").string());
  ASSERT_TRUE(second.ok());
  coins[0] = std::move(*second);
  auto logged = [&](const std::string& process, const std::string& text) {
    return WaitUntil([&] { return ReadText(run / "logs" / (process + ".log")).find(text) != std::string::npos; },
                     std::chrono::seconds(40));
  };
  EXPECT_TRUE(logged("orchestrator", "resuming the chain from epoch " + e))
      << ReadText(run / "logs" / "orchestrator.log");
  EXPECT_TRUE(logged("learner", "resumed from checkpoint epoch " + e)) << ReadText(run / "logs" / "learner.log");
  // the shard restored the snapshot stamped with the epoch's command id
  ASSERT_TRUE(logged("replay-0", "resumed ")) << ReadText(run / "logs" / "replay-0.log");
  const std::string replay_log = ReadText(run / "logs" / "replay-0.log");
  const size_t from = replay_log.find(" from ", replay_log.find("resumed ")) + 6;
  const std::string snapshot = replay_log.substr(from, replay_log.find(" in ", from) - from);
  auto inspect = RunCommand(Bin("coins") + " replay inspect --json " + snapshot);
  ASSERT_EQ(inspect.code, 0) << snapshot << "\n" << inspect.output;
  EXPECT_EQ(nlohmann::json::parse(inspect.output)["meta"]["command_id"], CheckpointCommandId(epoch));
  // an actor killed inside the run is restarted counting on from the steps it had reported
  const auto run_steps = [&]() -> uint64_t {  // env steps of metrics.csv's newest row (0: a row cut mid-write)
    const std::string last_row = Lines(ReadText(run / "metrics.csv")).back();
    const size_t column = last_row.find(',') + 1;
    try {
      return std::stoull(last_row.substr(column, last_row.find(',', column) - column));
    } catch (const std::exception&) {
      return 0;
    }
  };
  const uint64_t before_kill = run_steps();
  RunCommand("pkill -9 -f '[c]oins-actor.*" + run.string() + "/'");
  EXPECT_TRUE(WaitUntil([&] { return ReadText(dir / "resume.log").find("actor-0 restarted") != std::string::npos; },
                        std::chrono::seconds(30)))
      << ReadText(dir / "resume.log");
  // the restart appends to the actor's log; stop only once it is running (a slow start, under a
  // sanitizer, would otherwise be cut before it handles signals and leave no final report)
  const auto counting = [&] {
    const std::string log = ReadText(run / "logs" / "actor-0.log");
    size_t n = 0;
    for (size_t at = log.find("counting env steps on from"); at != std::string::npos;
         at = log.find("counting env steps on from", at + 1))
      ++n;
    return n;
  };
  EXPECT_TRUE(WaitUntil([&] { return counting() >= 2; }, std::chrono::seconds(30)))
      << ReadText(run / "logs" / "actor-0.log");
  coins[0].Signal(SIGTERM);
  ASSERT_TRUE(coins[0].WaitFor(Scaled(std::chrono::seconds(40))));
  const std::string out = ReadText(dir / "resume.log");
  EXPECT_TRUE(coins[0].succeeded()) << out;
  EXPECT_NE(out.find("resuming epoch " + e), std::string::npos) << out;
  EXPECT_NE(out.find("skipping epoch " + std::to_string(epoch + 5)), std::string::npos) << out;
  EXPECT_EQ(out.find("removed the previous run"), std::string::npos) << out;
  // the actor counted on from the epoch's env steps (the chain's step bases and pacing are in
  // the run's steps: counting from 0 again would let it run unpaced while the learner waited)
  const auto actor = nlohmann::json::parse(ReadText(run / "logs" / "actor-0.final.json"));
  // (>=: a slow restart may be stopped before its first step)
  EXPECT_GE(actor.at("steps").get<uint64_t>(), epoch_steps) << actor.dump();
  EXPECT_GE(actor.at("steps").get<uint64_t>(), before_kill) << actor.dump();
  // the resumed run appended its metrics rows after the first run's, its wall clock going on
  const std::vector<std::string> rows = Lines(ReadText(run / "metrics.csv"));
  ASSERT_GT(rows.size(), first_rows.size());
  EXPECT_TRUE(std::equal(first_rows.begin(), first_rows.end(), rows.begin()));
  EXPECT_EQ(std::count(rows.begin(), rows.end(), rows[0]), 1);
  for (size_t i = 2; i < rows.size(); ++i)
    EXPECT_LE(std::stod(rows[i - 1]), std::stod(rows[i])) << "wall_s of row " << i << ": " << rows[i];
}

// two "hosts" on one machine: the orchestrator's (with the shard and the learner) and one with
// only the actor. Resumed, the actor host has no chain state of its own: its actor waits for the
// orchestrator's ChainStatus and counts on from its share of the epoch's env steps.
TEST(ChainRun, AResumedActorHostCountsOnFromTheChainsEnvSteps) {
  auto dir = TempDir("chain-resume-roles");
  const fs::path a = dir / "a", b = dir / "b";
  const int domain = TestDomain(8);
  const std::string common =
      " --steps 0 --actors 1 --shards 1 --quiet --set orchestrator.detect_every_steps=1000000000 --set "
      "orchestrator.detect_budget_steps=1000000000 --set orchestrator.checkpoint_period_s=" +
      ScaledSeconds(2) + " --set orchestrator.checkpoint_timeout_s=" + ScaledSeconds(2);
  const std::string roles_a = " --role replay,learner,orchestrator", roles_b = " --role actors";
  auto start = [&](const std::string& args, const fs::path& log) {
    auto c = ChildProcess::Spawn("coins-run", {"/bin/sh", "-c", "exec " + Bin("coins") + " run" + args}, log.string());
    EXPECT_TRUE(c.ok());
    return std::move(*c);
  };
  auto stop = [](ChildProcess& c) {
    c.Signal(SIGTERM);
    return c.WaitFor(Scaled(std::chrono::seconds(40))) && c.succeeded();
  };
  {
    ChildProcess host_a = start(common + roles_a + Flags(a, domain), dir / "a1.log");
    ChildProcess host_b = start(common + roles_b + Flags(b, domain), dir / "b1.log");
    ASSERT_TRUE(WaitUntil([&] { return !chain::ChainStore::Epochs(a / "chain").empty(); }, std::chrono::seconds(90)))
        << ReadText(a / "logs" / "orchestrator.log");
    EXPECT_TRUE(stop(host_b)) << ReadText(dir / "b1.log");
    EXPECT_TRUE(stop(host_a)) << ReadText(dir / "a1.log");
  }
  const uint64_t epoch = chain::ChainStore::Epochs(a / "chain").back();
  const uint64_t epoch_steps =
      nlohmann::json::parse(ReadText(a / "chain" / ("chain-epoch-" + std::to_string(epoch) + ".json")))
          .at("state")
          .at("env_steps")
          .get<uint64_t>();
  ASSERT_GT(epoch_steps, 0u);

  ChildProcess host_a = start(" --resume " + a.string() + roles_a + " --steps 0", dir / "a2.log");
  ChildProcess host_b = start(" --resume " + b.string() + roles_b + " --steps 0", dir / "b2.log");
  const std::string line = "counting env steps on from ";
  EXPECT_TRUE(WaitUntil([&] { return ReadText(b / "logs" / "actor-0.log").find(line) != std::string::npos; },
                        std::chrono::seconds(60)))
      << ReadText(b / "logs" / "actor-0.log");
  EXPECT_TRUE(stop(host_b)) << ReadText(dir / "b2.log");
  EXPECT_TRUE(stop(host_a)) << ReadText(dir / "a2.log");
  // the share of one actor is the whole count of the epoch (or more: the status may be newer);
  // counting from 0 the unpaced actor could pass the epoch's count too, its first step not
  const auto actor = nlohmann::json::parse(ReadText(b / "logs" / "actor-0.final.json"));
  EXPECT_GE(actor.at("first_step").get<uint64_t>(), epoch_steps) << actor.dump();
  EXPECT_GE(actor.at("steps").get<uint64_t>(), epoch_steps) << actor.dump();
  const std::string log = ReadText(b / "logs" / "actor-0.log");
  const size_t at = log.find(line);
  ASSERT_NE(at, std::string::npos) << log;
  EXPECT_EQ(std::stoull(log.substr(at + line.size())), actor.at("first_step").get<uint64_t>()) << log;
}

}  // namespace
}  // namespace coins
