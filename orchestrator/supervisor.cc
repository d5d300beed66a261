#include "orchestrator/supervisor.h"

#include <algorithm>

#include <fmt/format.h>

namespace coins {

namespace {

Supervisor::Clock::duration Backoff(int64_t restarts) {
  const int64_t ms = std::min<int64_t>(10'000, int64_t(1000) << std::min<int64_t>(restarts, 4));
  return std::chrono::milliseconds(ms);
}

}  // namespace

Status Supervisor::Start(ChildSpec spec) {
  Slot slot;
  slot.spec = std::move(spec);
  slots_.push_back(std::move(slot));
  children_.emplace_back();
  Status s = Spawn(slots_.size() - 1, true);
  if (!s.ok()) {
    slots_.pop_back();
    children_.pop_back();
  }
  return s;
}

Status Supervisor::Spawn(size_t i, bool first) {
  const ChildSpec& spec = slots_[i].spec;
  std::vector<std::string> argv = spec.argv;
  if (first) argv.insert(argv.end(), spec.first_start.begin(), spec.first_start.end());
  if (!first && spec.restart_args) {
    const std::vector<std::string> more = spec.restart_args();
    argv.insert(argv.end(), more.begin(), more.end());
  }
  auto child = ChildProcess::Spawn(spec.name, argv, log_dir_ + "/" + spec.name + ".log", !first);
  if (!child.ok()) return child.status();
  children_[i] = std::move(*child);
  return Status::Ok();
}

std::vector<Supervisor::Event> Supervisor::Poll(Clock::time_point now, bool actors_may_finish) {
  std::vector<Event> events;
  for (size_t i = 0; i < slots_.size(); ++i) {
    Slot& slot = slots_[i];
    if (slot.finished) continue;
    if (slot.waiting) {
      if (now < slot.restart_at) continue;
      slot.waiting = false;
      Status s = Spawn(i, false);
      if (s.ok()) {
        events.push_back({Event::Kind::kRestarted, slot.spec.name,
                          fmt::format("{} restarted (pid {})", slot.spec.name, children_[i].pid())});
      } else {
        slot.finished = failed_ = true;
        events.push_back({Event::Kind::kFailed, slot.spec.name, s.message()});
      }
      continue;
    }
    if (children_[i].Poll()) events.push_back(Ended(i, now, actors_may_finish));
  }
  return events;
}

Supervisor::Event Supervisor::Ended(size_t i, Clock::time_point now, bool actors_may_finish) {
  Slot& slot = slots_[i];
  const ChildProcess& c = children_[i];
  const std::string what = fmt::format("{} (pid {}) {}", slot.spec.name, c.pid(), c.Describe());
  if (slot.spec.actor && actors_may_finish && c.succeeded()) {
    slot.finished = true;
    return {Event::Kind::kFinished, slot.spec.name, what};
  }
  const bool usage_error = WIFEXITED(c.status()) && WEXITSTATUS(c.status()) == 2;
  if (usage_error || slot.restarts >= max_restarts_) {
    slot.finished = failed_ = true;
    std::string why = usage_error ? "bad flags or config, not restarted"
                                  : fmt::format("restarts exhausted ({}/{})", slot.restarts, max_restarts_);
    return {Event::Kind::kFailed, slot.spec.name, fmt::format("{}; {}", what, why)};
  }
  slot.waiting = true;
  slot.restart_at = now + Backoff(slot.restarts);
  slot.restarts++;
  return {Event::Kind::kRestarting, slot.spec.name,
          fmt::format("{}; restarting ({}/{})", what, slot.restarts, max_restarts_)};
}

int64_t Supervisor::restarts() const {
  int64_t n = 0;
  for (const Slot& s : slots_) n += s.restarts;
  return n;
}

std::string Supervisor::RestartSummary() const {
  std::string out;
  for (const Slot& s : slots_)
    if (s.restarts) out += fmt::format("{}{} {}", out.empty() ? "" : ", ", s.spec.name, s.restarts);
  return out;
}

bool Supervisor::actors_done() const {
  for (size_t i = 0; i < slots_.size(); ++i)
    if (slots_[i].spec.actor && (slots_[i].waiting || !children_[i].exited())) return false;
  return true;
}

}  // namespace coins
