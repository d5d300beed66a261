// Supervisor with real child processes (/bin/sh): restarts, their bound, and what is not restarted.
#include "orchestrator/supervisor.h"

#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

namespace coins {
namespace {

namespace fs = std::filesystem;
using Kind = Supervisor::Event::Kind;

fs::path LogDir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("coins-supervisor-" + name + "-" + std::to_string(getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::string ReadLog(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

ChildSpec Shell(const std::string& name, const std::string& script, bool actor = false) {
  return ChildSpec{name, {"/bin/sh", "-c", script, "sh"}, {}, actor};
}

// polls until `pred(events so far)` holds or 20 s pass; returns every event seen
template <typename Pred>
std::vector<Supervisor::Event> PollUntil(Supervisor& sup, bool actors_may_finish, Pred pred) {
  std::vector<Supervisor::Event> all;
  auto end = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < end && !pred(all)) {
    for (auto& e : sup.Poll(std::chrono::steady_clock::now(), actors_may_finish)) all.push_back(e);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return all;
}

size_t Count(const std::vector<Supervisor::Event>& events, Kind kind) {
  size_t n = 0;
  for (const auto& e : events) n += e.kind == kind;
  return n;
}

TEST(Supervisor, ACrashedChildIsRestartedUntilItsRetriesAreSpent) {
  fs::path logs = LogDir("crash");
  Supervisor sup(logs.string(), 2);
  // each start appends a line to the log, then the process dies of SIGKILL
  ASSERT_TRUE(sup.Start(Shell("learner", "echo started; kill -9 $$")).ok());
  auto events = PollUntil(sup, false, [](const auto& e) { return Count(e, Kind::kFailed) > 0; });
  EXPECT_EQ(Count(events, Kind::kRestarting), 2u);
  EXPECT_EQ(Count(events, Kind::kRestarted), 2u);
  ASSERT_EQ(Count(events, Kind::kFailed), 1u);
  EXPECT_NE(events.back().line.find("was killed by signal 9"), std::string::npos) << events.back().line;
  EXPECT_NE(events.back().line.find("restarts exhausted (2/2)"), std::string::npos) << events.back().line;
  EXPECT_NE(events.front().line.find("restarting (1/2)"), std::string::npos) << events.front().line;
  EXPECT_EQ(sup.restarts(), 2);
  EXPECT_EQ(sup.RestartSummary(), "learner 2");
  EXPECT_TRUE(sup.failed());
  // the restarted processes wrote into the same log: three starts
  EXPECT_EQ(ReadLog(logs / "learner.log"), "started\nstarted\nstarted\n");
}

TEST(Supervisor, FirstStartArgumentsAreLeftOutOfARestart) {
  fs::path logs = LogDir("first");
  Supervisor sup(logs.string(), 1);
  ChildSpec spec = Shell("replay-0", "echo \"args: $*\"; exit 1");
  spec.first_start = {"--resume-epoch", "4"};
  ASSERT_TRUE(sup.Start(spec).ok());
  PollUntil(sup, false, [](const auto& e) { return Count(e, Kind::kFailed) > 0; });
  EXPECT_EQ(ReadLog(logs / "replay-0.log"), "args: --resume-epoch 4\nargs: \n");
}

TEST(Supervisor, RestartArgumentsAreAskedForAtEachRestart) {
  fs::path logs = LogDir("restart-args");
  Supervisor sup(logs.string(), 2);
  ChildSpec spec = Shell("actor-0", "echo \"args: $*\"; exit 1", true);
  spec.first_start = {"--first-step", "10"};
  int asked = 0;
  spec.restart_args = [&asked] { return std::vector<std::string>{"--first-step", std::to_string(100 * ++asked)}; };
  ASSERT_TRUE(sup.Start(spec).ok());
  PollUntil(sup, false, [](const auto& e) { return Count(e, Kind::kFailed) > 0; });
  EXPECT_EQ(ReadLog(logs / "actor-0.log"), "args: --first-step 10\nargs: --first-step 100\nargs: --first-step 200\n");
  EXPECT_EQ(asked, 2);
}

TEST(Supervisor, BadConfigIsNotRetriedAndFinishedActorsAreNotRestarted) {
  Supervisor sup(LogDir("norestart").string(), 3);
  ASSERT_TRUE(sup.Start(Shell("actor-0", "exit 0", true)).ok());
  auto events = PollUntil(sup, true, [](const auto& e) { return Count(e, Kind::kFinished) > 0; });
  EXPECT_EQ(Count(events, Kind::kRestarting), 0u);
  EXPECT_TRUE(sup.actors_done());
  EXPECT_FALSE(sup.failed());
  ASSERT_TRUE(sup.Start(Shell("orchestrator", "exit 2")).ok());
  events = PollUntil(sup, true, [](const auto& e) { return Count(e, Kind::kFailed) > 0; });
  EXPECT_EQ(Count(events, Kind::kRestarting), 0u);
  ASSERT_EQ(Count(events, Kind::kFailed), 1u);
  EXPECT_NE(events.back().line.find("exited with code 2"), std::string::npos) << events.back().line;
  EXPECT_NE(events.back().line.find("not restarted"), std::string::npos) << events.back().line;
  EXPECT_EQ(sup.restarts(), 0);
}

TEST(Supervisor, AnActorThatEndsBeforeItsBudgetIsACrash) {
  Supervisor sup(LogDir("actor").string(), 1);
  ASSERT_TRUE(sup.Start(Shell("actor-0", "exit 0", true)).ok());
  // with no step budget (run.steps 0) an actor never finishes on its own
  auto events = PollUntil(sup, false, [](const auto& e) { return Count(e, Kind::kRestarted) > 0; });
  EXPECT_EQ(Count(events, Kind::kRestarting), 1u);
  EXPECT_FALSE(sup.actors_done());
}

}  // namespace
}  // namespace coins
