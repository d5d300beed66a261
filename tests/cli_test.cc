// The coins command rejects bad input with a one-line error and a non-zero exit before it
// starts any process.
#include <gtest/gtest.h>

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
  ExpectRefused("--steps -5", "--steps");
  ExpectRefused("--config /nonexistent.yaml", "/nonexistent.yaml");
  ExpectRefused("--env brekout", "brekout");
  ExpectRefused("--set replay.capcity=5", "unknown key 'replay.capcity' (did you mean 'capacity'?)");
  ExpectRefused("--set actor.envs=many", "actor.envs: expected an integer, got 'many'");
  auto dir = TempDir("cli-config");
  std::ofstream(dir / "bad.yaml") << "run:\n  actors: 2\n  shardz: 3\n";
  ExpectRefused("--config " + (dir / "bad.yaml").string(), "unknown key 'run.shardz' (did you mean 'shards'?)");
  std::ofstream(dir / "neg.yaml") << "run:\n  steps: -1\n";
  ExpectRefused("--config " + (dir / "neg.yaml").string(), "run.steps: must be in [0,");
}

TEST(Cli, HelpOnEverySubcommand) {
  for (const char* sub : {"run", "monitor", "bench"}) {
    auto r = RunCommand(Bin("coins") + " " + sub + " --help");
    EXPECT_EQ(r.code, 0) << sub;
    EXPECT_NE(r.output.find("Usage"), std::string::npos) << sub << "\n" << r.output;
  }
  auto r = RunCommand(Bin("coins") + " bench nosuchbench");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("unknown benchmark 'nosuchbench'"), std::string::npos) << r.output;
}

TEST(Cli, ProcessBinariesValidateTheirConfig) {
  auto r = RunCommand(Bin("coins-replay") + " --set replay.capacity=0");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("replay.capacity: must be in"), std::string::npos) << r.output;
  r = RunCommand(Bin("coins-actor") + " --set run.env=nope --quiet-config --set dds.domain=" +
                 std::to_string(TestDomain(9)));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("nope"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace coins
