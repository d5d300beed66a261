// EpochCutter: when the orchestrator cuts a checkpoint epoch and when the epoch is complete.
// Pure: the caller passes the clock and the acknowledgements it has seen.
//
//   - an epoch is cut every `period`, and as soon as possible after RequestCut() (a phase
//     change); one epoch is pending at a time, numbered above every epoch cut before
//   - it is complete when every shard 0..shards-1 reports last_snapshot_command >= its command id
//     and the learner reports checkpoint_command >= it (ids grow with the epoch, and a process
//     keeps the largest id it completed)
//   - while pending, the Control is resent every `resend` (volatile topic: a process that joined
//     or restarted since needs it again; processes act on a command id once)
//   - not complete after `timeout`: abandoned, with who is missing; the next period cuts a new one
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>

namespace coins {

struct EpochAcks {
  std::map<uint32_t, uint64_t> shards;  // shard id -> ReplayStats.last_snapshot_command
  uint64_t learner = 0;                 // LearnerStatus.checkpoint_command (0: no report)
};

class EpochCutter {
 public:
  using Clock = std::chrono::steady_clock;
  using Seconds = std::chrono::duration<double>;
  enum class Outcome { kIdle, kPending, kComplete, kAbandoned };

  // last_cut: the newest epoch cut before (the first cut is last_cut + 1)
  EpochCutter(int64_t shards, Seconds period, Seconds timeout, uint64_t last_cut, Clock::time_point now,
              Seconds resend = Seconds(1.0));

  void RequestCut() { requested_ = true; }
  // the epoch to cut now, marked pending; nullopt when one is pending or none is due
  std::optional<uint64_t> Due(Clock::time_point now);
  // true when the pending epoch's Control should be sent again
  bool ShouldResend(Clock::time_point now);
  // checks the pending epoch; kComplete and kAbandoned clear it. `missing` names who has not
  // acknowledged yet ("replay-1, learner")
  Outcome Check(Clock::time_point now, const EpochAcks& acks, std::string* missing);

  bool pending() const { return pending_.has_value(); }
  uint64_t pending_epoch() const { return pending_.value_or(0); }
  uint64_t last_cut() const { return last_cut_; }

 private:
  std::string Missing(uint64_t command_id, const EpochAcks& acks) const;

  int64_t shards_;
  Seconds period_, timeout_, resend_;
  uint64_t last_cut_;
  Clock::time_point next_due_, sent_at_, last_send_;
  bool requested_ = false;
  std::optional<uint64_t> pending_;
};

}  // namespace coins
