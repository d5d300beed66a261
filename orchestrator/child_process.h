// ChildProcess: a coins process started by the launcher (fork + exec), with its output sent
// to a log file. The child gets SIGTERM if the launcher dies. Poll() reaps it without blocking.
#pragma once

#include <sys/types.h>
#include <sys/wait.h>

#include <chrono>
#include <string>
#include <vector>

#include "common/status.h"

namespace coins {

class ChildProcess {
 public:
  // starts argv[0] with the arguments; stdout and stderr go to log_path (truncated, or
  // appended to with append: a restarted child keeps its predecessor's log)
  static Result<ChildProcess> Spawn(std::string name, const std::vector<std::string>& argv, const std::string& log_path,
                                    bool append = false);

  const std::string& name() const { return name_; }
  pid_t pid() const { return pid_; }
  // reaps the child if it has exited; true once it has
  bool Poll();
  bool exited() const { return exited_; }
  bool succeeded() const { return exited_ && WIFEXITED(status_) && WEXITSTATUS(status_) == 0; }
  // the wait status once exited (WIFEXITED / WEXITSTATUS / WIFSIGNALED apply)
  int status() const { return status_; }
  // "exited with code 3", "was killed by signal 9 (Killed)"
  std::string Describe() const;
  void Signal(int sig) const;
  // waits up to timeout for the exit; true when it exited
  bool WaitFor(std::chrono::milliseconds timeout);

 private:
  std::string name_;
  pid_t pid_ = -1;
  bool exited_ = false;
  int status_ = 0;
};

// SIGTERM to every live child, then SIGKILL to those still alive after `grace`
void StopAll(std::vector<ChildProcess>& children, std::chrono::milliseconds grace);

// directory holding this executable (where the other coins binaries are)
std::string SelfDirectory();

// the first executable `name` on PATH, "" when there is none
std::string FindInPath(const std::string& name);
// runs argv to its end within timeout (killed after it), output to log; the wait status or an error
Result<int> RunBounded(const std::vector<std::string>& argv, const std::string& log, std::chrono::seconds timeout);
// the process ran and exited with code 0
bool Succeeded(const Result<int>& r);

}  // namespace coins
