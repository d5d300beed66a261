// Supervisor: the child processes of `coins run`, restarted when they crash.
//
// A child that ends while the run goes on is restarted after a short backoff (1 s, doubling up
// to 10 s), at most max_restarts times per child; its log continues in the same file. Not
// restarted: an actor that finished its steps (exit 0 while actors may finish), and a child that
// exited with code 2 (bad flags or config: a restart cannot help). A restart leaves out the
// child's first-start-only arguments (`--resume-epoch N`): a restarted process resumes from its
// own newest files; it gets the arguments restart_args returns at that moment instead (an actor:
// `--first-step`, the step count it had reported). Poll() never blocks.
#pragma once

#include <chrono>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "orchestrator/child_process.h"

namespace coins {

struct ChildSpec {
  std::string name;                      // "replay-0", "learner", "actor-1"
  std::vector<std::string> argv;         // argv[0] is the executable
  std::vector<std::string> first_start;  // arguments of the first start only
  bool actor = false;
  std::function<std::vector<std::string>()> restart_args{};  // arguments of each restart (optional)
};

class Supervisor {
 public:
  using Clock = std::chrono::steady_clock;
  struct Event {
    enum class Kind { kRestarting, kRestarted, kFinished, kFailed } kind;
    std::string name;
    std::string line;  // one line for the user
  };

  Supervisor(std::string log_dir, int64_t max_restarts) : log_dir_(std::move(log_dir)), max_restarts_(max_restarts) {}
  Status Start(ChildSpec spec);
  // reaps and restarts; actors_may_finish: an actor's exit 0 is its budget done, not a crash
  std::vector<Event> Poll(Clock::time_point now, bool actors_may_finish);

  std::vector<ChildProcess>& children() { return children_; }
  int64_t restarts() const;
  // "learner 1, actor-0 2" (children restarted so far), or ""
  std::string RestartSummary() const;
  // every actor has exited and none is waiting for a restart
  bool actors_done() const;
  bool failed() const { return failed_; }

 private:
  struct Slot {
    ChildSpec spec;
    int64_t restarts = 0;
    bool waiting = false;   // a restart is due at restart_at
    bool finished = false;  // ended for good (success or failure)
    Clock::time_point restart_at;
  };
  Status Spawn(size_t i, bool first);
  Event Ended(size_t i, Clock::time_point now, bool actors_may_finish);

  std::string log_dir_;
  int64_t max_restarts_;
  std::vector<Slot> slots_;
  std::vector<ChildProcess> children_;  // children_[i] runs slots_[i]
  bool failed_ = false;
};

}  // namespace coins
