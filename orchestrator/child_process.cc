#include "orchestrator/child_process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <thread>

namespace coins {

Result<ChildProcess> ChildProcess::Spawn(std::string name, const std::vector<std::string>& argv,
                                         const std::string& log_path, bool append) {
  if (access(argv[0].c_str(), X_OK) != 0) return Errorf("{}: cannot execute {}", name, argv[0]);
  int log = open(log_path.c_str(), O_WRONLY | O_CREAT | (append ? O_APPEND : O_TRUNC) | O_CLOEXEC, 0644);
  if (log < 0) return Errorf("{}: cannot open log file {}: {}", name, log_path, std::strerror(errno));
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t parent = getpid();
  pid_t pid = fork();
  if (pid < 0) {
    close(log);
    return Errorf("{}: fork failed: {}", name, std::strerror(errno));
  }
  if (pid == 0) {
    // child: own process group (the launcher orders shutdown), dies with the launcher
    setpgid(0, 0);
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() != parent) _exit(127);
    dup2(log, STDOUT_FILENO);
    dup2(log, STDERR_FILENO);
    execv(args[0], args.data());
    _exit(127);
  }
  close(log);
  ChildProcess c;
  c.name_ = std::move(name);
  c.pid_ = pid;
  return c;
}

bool ChildProcess::Poll() {
  if (exited_) return true;
  int status = 0;
  if (waitpid(pid_, &status, WNOHANG) == pid_) {
    exited_ = true;
    status_ = status;
  }
  return exited_;
}

std::string ChildProcess::Describe() const {
  if (!exited_) return "is running";
  if (WIFEXITED(status_)) return fmt::format("exited with code {}", WEXITSTATUS(status_));
  if (WIFSIGNALED(status_))
    return fmt::format("was killed by signal {} ({})", WTERMSIG(status_), strsignal(WTERMSIG(status_)));
  return "ended";
}

void ChildProcess::Signal(int sig) const {
  if (!exited_) kill(pid_, sig);
}

bool ChildProcess::WaitFor(std::chrono::milliseconds timeout) {
  auto end = std::chrono::steady_clock::now() + timeout;
  while (!Poll()) {
    if (std::chrono::steady_clock::now() >= end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

void StopAll(std::vector<ChildProcess>& children, std::chrono::milliseconds grace) {
  for (auto& c : children)
    if (!c.Poll()) c.Signal(SIGTERM);
  auto end = std::chrono::steady_clock::now() + grace;
  for (auto& c : children) {
    auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now());
    if (!c.WaitFor(std::max(left, std::chrono::milliseconds(0)))) {
      c.Signal(SIGKILL);
      c.WaitFor(std::chrono::seconds(5));
    }
  }
}

std::string SelfDirectory() {
  std::error_code ec;
  auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? "." : exe.parent_path().string();
}

std::string FindInPath(const std::string& name) {
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path ? path : "/usr/bin:/bin");
  std::string d;
  while (std::getline(dirs, d, ':'))
    if (!d.empty() && access((d + "/" + name).c_str(), X_OK) == 0) return d + "/" + name;
  return "";
}

Result<int> RunBounded(const std::vector<std::string>& argv, const std::string& log, std::chrono::seconds timeout) {
  auto child = ChildProcess::Spawn(std::filesystem::path(argv[0]).filename().string(), argv, log);
  if (!child.ok()) return child.status();
  if (!child->WaitFor(timeout)) {
    child->Signal(SIGKILL);
    child->WaitFor(std::chrono::seconds(5));
    return Errorf("{} did not finish within {} s (killed); see {}", argv[0], timeout.count(), log);
  }
  return child->status();
}

bool Succeeded(const Result<int>& r) { return r.ok() && WIFEXITED(r.value()) && WEXITSTATUS(r.value()) == 0; }

}  // namespace coins
