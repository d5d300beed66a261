// The coins command rejects bad input with a one-line error and a non-zero exit before it
// starts any process.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <fstream>

#include "tests/process_harness.h"

namespace coins {
namespace {

using namespace coins::testing;

void ExpectRefused(const std::string& args, const std::string& expected) {
  auto dir = TempDir("cli");
  auto r = RunCommand(Bin("coins") + " run --dir " + (dir / "run").string() + " " + args);
  EXPECT_NE(r.code, 0) << args;
  EXPECT_NE(r.output.find(expected), std::string::npos) << args << "\n" << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "run" / "logs")) << "a process directory was made for: " << args;
}

TEST(Cli, BadRunInputIsRefusedBeforeStarting) {
  ExpectRefused("--shards 0", "--shards");
  ExpectRefused("--steps -5", "--steps: must be an integer in [0, 1125899906842624], got '-5'");
  ExpectRefused("--steps 18446744073709551616", "got '18446744073709551616'");
  ExpectRefused("--config /nonexistent.yaml", "/nonexistent.yaml");
  ExpectRefused("--env brekout", "brekout");
  ExpectRefused("--set replay.capcity=5", "unknown key 'replay.capcity' (did you mean 'capacity'?)");
  ExpectRefused("--set actor.envs=many", "actor.envs: expected an integer, got 'many'");
  ExpectRefused("--set learner.primitive_decision_period=4", "primitive_decision_period 4: primitive actions");
  ExpectRefused("--set orchestrator.chain=none --set learner.task_decision_period=4", "task_decision_period 4");
  ExpectRefused("--set learner.primitive_hold_decision=true", "primitive_hold_decision holds an action");
  ExpectRefused("--set learner.skill_hold_decision=true --set learner.skill_decision_period=0",
                "skill_decision_period is 0");
  ExpectRefused("--set learner.task_pair_head=[64]", "task_pair_head adds layers to a pair network");
  ExpectRefused("--set learner.task_pair_hidden=[16] --set learner.task_pair_head=[0.5]",
                "task_pair_head: 0.5 is not a layer size");
  auto dir = TempDir("cli-config");
  std::ofstream(dir / "bad.yaml") << "run:\n  actors: 2\n  shardz: 3\n";
  ExpectRefused("--config " + (dir / "bad.yaml").string(), "unknown key 'run.shardz' (did you mean 'shards'?)");
  std::ofstream(dir / "neg.yaml") << "run:\n  steps: -1\n";
  ExpectRefused("--config " + (dir / "neg.yaml").string(), "run.steps: must be in [0,");
}

// an error on one line (CLI11 may add its "Run with --help" hint below it) and a non-zero exit,
// no abort (a signal gives code -1 or 128 + n here)
void ExpectOneLineError(const CommandResult& r, const std::string& expected, const std::string& what) {
  EXPECT_TRUE(r.code > 0 && r.code < 128) << what << " exited with " << r.code << "\n" << r.output;
  EXPECT_NE(r.output.find(expected), std::string::npos) << what << "\n" << r.output;
  EXPECT_EQ(r.output.find("terminate called"), std::string::npos) << what << "\n" << r.output;
  std::string rest = r.output;
  auto hint = rest.find("Run with --help for more information.");
  if (hint != std::string::npos) rest.erase(hint);
  EXPECT_LE(std::count(rest.begin(), rest.end(), '\n'), 1) << what << "\n" << r.output;
}

// a discovery server that does not answer: one line naming its address and a non-zero exit,
// from `coins run` before it starts a process that moves data, and from a process alone
TEST(Cli, AnUnreachableDiscoveryServerIsNamedBeforeAnyDataMoves) {
  const std::string server = "10.255.255.1:11811";  // no host answers there
  const std::string dds = " --set dds.domain=" + std::to_string(TestDomain()) +
                          " --set dds.discovery=server --set dds.discovery_server=" + server +
                          " --set dds.server_wait_s=1";
  auto dir = TempDir("cli-unreachable");
  const auto start = std::chrono::steady_clock::now();
  auto run = RunCommand(Bin("coins") + " run --quiet --steps 1000 --dir " + (dir / "run").string() + dds);
  EXPECT_EQ(run.code, 1) << run.output;
  EXPECT_NE(run.output.find("coins run: dds: no discovery server answered at " + server + " (dds.discovery_server)"),
            std::string::npos)
      << run.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "run" / "logs" / "replay-0.log")) << "a shard was started";
  EXPECT_FALSE(std::filesystem::exists(dir / "run" / "logs" / "actor-0.log")) << "an actor was started";
  auto shard = RunCommand(Bin("coins-replay") + " --quiet-config --id 0" + dds);
  ExpectOneLineError(shard, "no discovery server answered at " + server, "coins-replay");
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(20));
}

TEST(Cli, YamlKeysThatAreNotNamesAreErrorsInEveryBinary) {
  auto dir = TempDir("cli-yaml");
  std::ofstream(dir / "top.yaml") << "[1]: 2\n";
  std::ofstream(dir / "section.yaml") << "replay:\n  [1]: 2\n";
  std::ofstream(dir / "actor.yaml") << "actor:\n  {a: 1}: 2\n";
  const std::string quiet = " --quiet-config --set dds.domain=" + std::to_string(TestDomain());
  ExpectOneLineError(
      RunCommand(Bin("coins") + " run --dir " + (dir / "run").string() + " --config " + (dir / "top.yaml").string()),
      "a top-level key is a list, not a section name", "coins run");
  for (const char* binary : {"coins-replay", "coins-actor", "coins-learner", "coins-orchestrator"}) {
    ExpectOneLineError(RunCommand(Bin(binary) + quiet + " --config " + (dir / "top.yaml").string()),
                       "a top-level key is a list", binary);
  }
  ExpectOneLineError(RunCommand(Bin("coins-replay") + quiet + " --config " + (dir / "section.yaml").string()),
                     "section 'replay' has a key that is a list, not a name", "coins-replay");
  ExpectOneLineError(RunCommand(Bin("coins-actor") + quiet + " --config " + (dir / "actor.yaml").string()),
                     "section 'actor' has a key that is a map, not a name", "coins-actor");
}

TEST(Cli, AShardLargerThanTheMachineIsRefusedBeforeStarting) {
  ExpectRefused("--set replay.capacity_mb=1048576", "replay.capacity_mb 1048576");
  // one shard fits, but not 64 of them
  ExpectRefused("--shards 64 --set replay.capacity_mb=4096", "64 shards would need about");
  ExpectOneLineError(RunCommand(Bin("coins-replay") + " --quiet-config --set replay.capacity_mb=1048576"),
                     "more than 90% of this machine's", "coins-replay");
}

TEST(Cli, AnEvalEpsilonOutsideZeroToOneIsRefused) {
  for (const char* value : {"nan", "inf", "-0.1", "1.5"})
    ExpectOneLineError(RunCommand(Bin("coins") + " eval /nonexistent --explore " + value),
                       std::string("--explore: must be a finite number in [0, 1], got '") + value + "'",
                       std::string("eval --explore ") + value);
}

TEST(Cli, BadNumbersToTheBenchmarksAreErrorsNotHangs) {
  if (!COINS_HAVE_BENCH) GTEST_SKIP() << "built with COINS_BUILD_BENCH=OFF";
  auto t0 = std::chrono::steady_clock::now();
  for (const char* bench : {"transport", "replay"})
    for (const char* value : {"nan", "1e30", "inf", "-1", "0"})
      ExpectOneLineError(RunCommand(Bin("coins") + " bench " + bench + " --seconds " + value),
                         std::string("--seconds: must be a finite number in (0, 3600], got '") + value + "'",
                         std::string(bench) + " --seconds " + value);
  ExpectOneLineError(RunCommand(Bin("coins") + " bench transport --domain 999"), "--domain", "--domain 999");
  for (const char* value : {"inf", "nan", "0", "-2", "1e9"}) {
    auto r = RunCommand(Bin("coins") + " bench env --scale " + value);
    EXPECT_EQ(r.code, 2) << value << "\n" << r.output;
    EXPECT_NE(r.output.find(std::string("--scale: must be a finite number in (0, 100], got '") + value + "'"),
              std::string::npos)
        << r.output;
  }
  auto reps = RunCommand(Bin("coins") + " bench nn --reps 99999999999999999999");
  EXPECT_EQ(reps.code, 2) << reps.output;
  EXPECT_NE(reps.output.find("--reps: must be an integer in [1, 1000]"), std::string::npos) << reps.output;
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(30));
}

// the learner benchmark's DDS shards store what it sends and it measures both sources (it failed
// with "shard 0 did not report its transitions" once the payload hash covered the header, since it
// renumbered its batches without rehashing them)
TEST(Cli, TheLearnerBenchmarkSamplesFromDdsShardsAndInProcess) {
  if (!COINS_HAVE_BENCH) GTEST_SKIP() << "built with COINS_BUILD_BENCH=OFF";
  auto r =
      RunCommand(Bin("coins") + " bench learner --fill 10000 --seconds 0.5 --repeats 1 --shards 1 --json --domain " +
                 std::to_string(TestDomain()));
  ASSERT_EQ(r.code, 0) << r.output;
  // the JSON object is the last line
  const size_t line = r.output.rfind("\n{");
  const auto j = nlohmann::json::parse(r.output.substr(line == std::string::npos ? 0 : line + 1), nullptr, false);
  ASSERT_TRUE(j.is_object()) << r.output;
  // at least 10 updates a second, or that divided by the sanitizer's slow-down (ASan: 8 in-process)
  const double floor = 10.0 / TestTimeScale();
  EXPECT_GT(j.value("learner_updates_per_s_dds", 0.0), floor) << r.output;
  EXPECT_GT(j.value("learner_updates_per_s_inprocess", 0.0), floor) << r.output;
}

TEST(Cli, HelpOnEverySubcommand) {
  for (const char* sub : {"run", "monitor", "bench", "transfer", "experiment transfer", "experiment pushing", "eval"}) {
    auto r = RunCommand(Bin("coins") + " " + sub + " --help");
    EXPECT_EQ(r.code, 0) << sub;
    EXPECT_NE(r.output.find("Usage"), std::string::npos) << sub << "\n" << r.output;
  }
  auto r = RunCommand(Bin("coins") + " bench nosuchbench");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find(COINS_HAVE_BENCH ? "unknown benchmark 'nosuchbench'" : "this build has none"),
            std::string::npos)
      << r.output;
}

TEST(Cli, ProcessBinariesValidateTheirConfig) {
  auto r = RunCommand(Bin("coins-replay") + " --set replay.capacity=0");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("replay.capacity: must be in"), std::string::npos) << r.output;
  r = RunCommand(Bin("coins-actor") +
                 " --set run.env=nope --quiet-config --set dds.domain=" + std::to_string(TestDomain(9)));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("nope"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace coins
