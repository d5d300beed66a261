// System tests of `coins run` and `coins monitor`: the whole set of processes on loopback.
#include <signal.h>

#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <regex>

#include "tests/process_harness.h"

namespace coins {
namespace {

using namespace coins::testing;

std::string RunFlags(const std::filesystem::path& dir, int domain) {
  return " --dir " + dir.string() + " --set dds.domain=" + std::to_string(domain) +
         " --set replay.capacity_mb=64 --set actor.status_period_s=0.2 --set replay.status_period_s=0.2";
}

TEST(Run, ReachesItsStepBudgetAndStopsCleanly) {
  auto dir = TempDir("run-budget");
  // the data path alone: actors play random actions without the chain's pacing
  auto r = RunCommand(Bin("coins") + " run --steps 60000 --actors 2 --shards 2" + RunFlags(dir / "run", TestDomain(3)) +
                      " --set actor.follow_chain=false");
  ASSERT_EQ(r.code, 0) << r.output;
  // the last progress line counts every step, and both shards hold them all
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.output, m, std::regex(R"(steps (\d+\.\d+)k)"))) << r.output;
  // the last progress line (the summary after it counts "env steps" too)
  std::string last = r.output.substr(r.output.rfind("] steps "));
  EXPECT_NE(last.find("steps 60.0k"), std::string::npos) << r.output;
  EXPECT_NE(last.find("replay-0 30.0k"), std::string::npos) << r.output;
  EXPECT_NE(last.find("replay-1 30.0k"), std::string::npos) << r.output;
  // every process wrote a log and the effective config was saved
  for (const char* name : {"actor-0", "actor-1", "replay-0", "replay-1", "learner", "orchestrator"})
    EXPECT_TRUE(std::filesystem::exists(dir / "run" / "logs" / (std::string(name) + ".log"))) << name;
  EXPECT_TRUE(std::filesystem::exists(dir / "run" / "config.yaml"));
}

TEST(Run, NamesAChildThatDiesAndStopsTheRest) {
  auto dir = TempDir("run-death");
  std::string cmd = Bin("coins") + " run --steps 0 --actors 1 --shards 1 --set run.max_restarts=0" +
                    RunFlags(dir / "run", TestDomain(4));
  // kill the shard once it is up; coins run must notice, say which and how, and exit non-zero
  // ([c] keeps the patterns from matching the shell that runs pgrep itself)
  std::thread killer([&] {
    WaitUntil([&] { return RunCommand("pgrep -f '[c]oins-replay.*" + (dir / "run").string() + "'").code == 0; },
              std::chrono::seconds(20));
    std::this_thread::sleep_for(std::chrono::seconds(2));
    RunCommand("pkill -9 -f '[c]oins-replay.*" + (dir / "run").string() + "'");
  });
  auto r = RunCommand(cmd);
  killer.join();
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("replay-0 (pid"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("was killed by signal 9 (Killed); restarts exhausted (0/0)"), std::string::npos) << r.output;
  // the actor's own flush (it waits for a shard that is gone) fits in its shutdown grace: it
  // ends by itself, not by SIGKILL (a SIGTERM that comes before its handler is installed, as
  // under a sanitizer's slow start, ends it too: that is not what this checks)
  EXPECT_EQ(r.output.find("actor-0 was killed by signal 9"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("killing it"), std::string::npos) << r.output;
  // nothing of the run is left behind
  EXPECT_NE(RunCommand("pgrep -f '[c]oins-actor.*" + (dir / "run").string() + "'").code, 0);
}

// `coins run` stopped by SIGTERM (as by Ctrl-C) while actors publish: every transition an actor
// counted as published is stored, and the run says so per actor
void StopRunAndCheckCounts(const std::string& name, const std::string& extra) {
  auto dir = TempDir(name);
  std::string cmd =
      Bin("coins") + " run --steps 0 --actors 2 --shards 2 --quiet" + RunFlags(dir / "run", TestDomain()) + extra;
  std::vector<ChildProcess> run;
  auto child = ChildProcess::Spawn("coins-run", {"/bin/sh", "-c", "exec " + cmd}, (dir / "run.log").string());
  ASSERT_TRUE(child.ok());
  run.push_back(std::move(*child));
  // let both shards take data for a while
  auto log = [&] {
    std::ifstream in(dir / "run" / "logs" / "replay-1.log");
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  ASSERT_TRUE(WaitUntil([&] { return log().find("listening") != std::string::npos; }, std::chrono::seconds(30)));
  std::this_thread::sleep_for(std::chrono::seconds(4));
  run[0].Signal(SIGTERM);
  ASSERT_TRUE(run[0].WaitFor(Scaled(std::chrono::seconds(90))));
  EXPECT_TRUE(run[0].succeeded()) << run[0].Describe();
  std::ifstream in(dir / "run.log");
  std::string out((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (int i = 0; i < 2; ++i) {
    std::smatch m;
    std::regex line("actor-" + std::to_string(i) + R"(: (\d+) transitions published, (\d+) stored \(([^)]*)\))");
    ASSERT_TRUE(std::regex_search(out, m, line)) << out;
    EXPECT_GT(std::stoull(m[1].str()), 0u) << out;
    EXPECT_EQ(m[1].str(), m[2].str()) << out;
    EXPECT_EQ(m[3].str(), "all stored") << out;
  }
  EXPECT_EQ(out.find("killing it"), std::string::npos) << out;
}

TEST(Run, SigtermStoresEveryTransitionPublished) { StopRunAndCheckCounts("run-sigterm", ""); }

TEST(Run, SigtermStoresEveryTransitionPublishedToThrottledShards) {
  // the shards' rate limiters hold inserts back (nothing samples): actors are blocked when the
  // stop comes, and must still flush everything they counted as published
  StopRunAndCheckCounts("run-sigterm-limited",
                        " --set replay.samples_per_insert=1 --set replay.error_buffer=3000 --set replay.min_size=1000");
}

TEST(Run, MonitorSeesEveryProcess) {
  auto dir = TempDir("run-monitor");
  int domain = TestDomain(5);
  // the chain stays in collecting (its detect point out of reach): every process reports freely
  std::string cmd =
      Bin("coins") + " run --steps 0 --actors 2 --shards 1 --quiet" + RunFlags(dir / "run", domain) +
      " --set orchestrator.detect_every_steps=1000000000 --set orchestrator.detect_budget_steps=1000000000";
  std::vector<ChildProcess> run;
  auto child = ChildProcess::Spawn("coins-run", {"/bin/sh", "-c", "exec " + cmd}, (dir / "run.log").string());
  ASSERT_TRUE(child.ok());
  run.push_back(std::move(*child));
  // on a loaded machine the processes take a while to start: watch once the shard listens
  WaitUntil(
      [&] {
        std::ifstream log(dir / "run" / "logs" / "replay-0.log");
        std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
        return text.find("listening on partition") != std::string::npos;
      },
      std::chrono::seconds(30));
  // the monitor listens for a sanitized build's time too: a shard busy storing both actors' data
  // under ThreadSanitizer was not heard within an unscaled 4 s
  auto r = RunCommand(Bin("coins") + " monitor --json --seconds " + ScaledSeconds(4) + " --domain " +
                      std::to_string(domain));
  StopAll(run, std::chrono::seconds(15));
  ASSERT_EQ(r.code, 0) << r.output;
  auto j = nlohmann::json::parse(r.output.substr(r.output.find('{')), nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << r.output;
  std::set<std::string> names;
  for (const auto& p : j["processes"]) names.insert(p["name"].get<std::string>());
  for (const char* name : {"actor-0", "actor-1", "replay-0", "learner", "orchestrator"})
    EXPECT_TRUE(names.count(name)) << name;
  ASSERT_EQ(j["actors"].size(), 2u);
  EXPECT_GT(j["actors"][0]["steps"].get<uint64_t>(), 0u);
  ASSERT_EQ(j["shards"].size(), 1u);
  EXPECT_GT(j["shards"][0]["inserted_transitions"].get<uint64_t>(), 0u);
  // the orchestrator's chain: collecting random-action data for Action
  ASSERT_TRUE(j["chain"].is_object()) << r.output;
  EXPECT_EQ(j["chain"]["phase"], "collecting") << j["chain"];
  EXPECT_EQ(j["chain"]["source"], "Action") << j["chain"];
  EXPECT_NE(j["chain"]["message"].get<std::string>().find("collecting for source Action"), std::string::npos)
      << j["chain"];
  // coins run stopped on SIGTERM like on Ctrl-C: exit 0
  EXPECT_TRUE(run[0].succeeded()) << run[0].Describe();
}

}  // namespace
}  // namespace coins
