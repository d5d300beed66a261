// Helpers for system tests that run the real coins binaries as separate processes on loopback.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/dds/domain_lease.h"
#include "orchestrator/child_process.h"

namespace coins::testing {

// how much longer than on a plain Release build the system tests wait (CMake's
// COINS_TEST_TIME_SCALE, passed to every test as the environment variable of that name; a
// sanitizer build defaults to 4). Every deadline a test sets on processes it runs goes through
// Scaled: WaitUntil and RunCommand scale their limits themselves. An unset variable is 1; a value
// that is not a positive integer stops the test with a message naming it.
inline int TestTimeScale() {
  static const int scale = [] {
    const char* text = std::getenv("COINS_TEST_TIME_SCALE");
    if (text == nullptr || *text == '\0') return 1;
    char* end = nullptr;
    const long value = std::strtol(text, &end, 10);
    if (*end != '\0' || value < 1 || value > 99) {
      std::fprintf(stderr, "COINS_TEST_TIME_SCALE=%s: expected a whole number from 1 to 99\n", text);
      std::abort();
    }
    return int(value);
  }();
  return scale;
}

template <typename Rep, typename Period>
std::chrono::duration<Rep, Period> Scaled(std::chrono::duration<Rep, Period> limit) {
  return limit * TestTimeScale();
}

// a whole number of seconds for a config key that bounds a wait (e.g. a checkpoint timeout)
inline std::string ScaledSeconds(int seconds) { return std::to_string(seconds * TestTimeScale()); }

// where the coins executables are (set by CMake)
inline std::string Bin(const std::string& name) { return std::string(COINS_BIN_DIR) + "/" + name; }

// a DDS domain no other live test or benchmark uses: each call takes a new lease (an exclusive
// lock, common/dds/domain_lease.h) held until this test process ends, and inherited by the
// processes it starts. `salt` is unused (kept for older callers).
inline int TestDomain(int salt = 0) {
  (void)salt;
  static std::vector<dds::DomainLease> leases;
  auto lease = dds::DomainLease::Acquire();
  if (!lease.ok()) {
    std::fprintf(stderr, "TestDomain: %s\n", lease.status().message().c_str());
    std::abort();
  }
  leases.push_back(std::move(*lease));
  return leases.back().domain();
}

// a fresh temporary directory for one test
inline std::filesystem::path TempDir(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() / ("coins-" + name + "-" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

inline nlohmann::json ReadJson(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) return nullptr;
  return nlohmann::json::parse(in, nullptr, false);
}

// runs a command, returning its exit code and its combined output
struct CommandResult {
  int code;
  std::string output;
};
// runs `command` through sh, output and errors together; after Scaled(limit) it is sent SIGTERM
// (and SIGKILL 10 s later) and the code is timeout's 124 (137 when killed)
inline CommandResult RunCommand(const std::string& command, std::chrono::seconds limit = std::chrono::seconds(240)) {
  limit = Scaled(limit);
  std::string quoted;
  for (char c : command) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  const std::string bounded = "timeout -k 10 " + std::to_string(limit.count()) + " sh -c '" + quoted + "'";
  std::string out;
  FILE* p = popen((bounded + " 2>&1").c_str(), "r");
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof(buf), p)) > 0) out.append(buf, n);
  int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

// waits until pred() is true or Scaled(timeout) passes; returns pred()
template <typename Pred>
bool WaitUntil(Pred pred, std::chrono::milliseconds timeout) {
  auto end = std::chrono::steady_clock::now() + Scaled(timeout);
  while (std::chrono::steady_clock::now() < end) {
    if (pred()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return pred();
}

// the whole text of a file ("" when it cannot be read)
inline std::string ReadText(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// the pid of the process of `binary` started with RUN_DIR/config.yaml (as `coins run` starts its
// children), or -1
// the lines of a text (without their newlines)
inline std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

inline pid_t PidOf(const std::string& binary, const std::filesystem::path& run) {
  auto r = RunCommand("pgrep -f '[" + binary.substr(0, 1) + "]" + binary.substr(1) + ".*" + run.string() + "/config'");
  return r.code == 0 ? pid_t(std::stol(r.output)) : -1;
}

// the persisted chain state of a run (RUN_DIR/chain/chain.json), or {} when there is none yet
inline nlohmann::json ChainState(const std::filesystem::path& run) {
  auto j = ReadJson(run / "chain" / "chain.json");
  return j.is_object() && j["state"].is_object() ? j["state"] : nlohmann::json::object();
}

// the newest complete learner checkpoint's state.json (null when none)
inline nlohmann::json NewestLearnerCheckpoint(const std::filesystem::path& run) {
  int64_t best = -1;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(run / "checkpoints", ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("learner-epoch-", 0) != 0 || !std::filesystem::exists(e.path() / "state.json")) continue;
    best = std::max<int64_t>(best, std::stoll(name.substr(14)));
  }
  if (best < 0) return nullptr;
  return ReadJson(run / "checkpoints" / ("learner-epoch-" + std::to_string(best)) / "state.json");
}

}  // namespace coins::testing
