#include "orchestrator/epoch_cutter.h"

#include "common/checkpoint.h"

namespace coins {

EpochCutter::EpochCutter(int64_t shards, Seconds period, Seconds timeout, uint64_t last_cut, Clock::time_point now,
                         Seconds resend)
    : shards_(shards), period_(period), timeout_(timeout), resend_(resend), last_cut_(last_cut) {
  next_due_ = now + std::chrono::duration_cast<Clock::duration>(period_);
}

std::optional<uint64_t> EpochCutter::Due(Clock::time_point now) {
  if (pending_ || (!requested_ && now < next_due_)) return std::nullopt;
  requested_ = false;
  pending_ = ++last_cut_;
  sent_at_ = last_send_ = now;
  next_due_ = now + std::chrono::duration_cast<Clock::duration>(period_);
  return pending_;
}

bool EpochCutter::ShouldResend(Clock::time_point now) {
  if (!pending_ || now - last_send_ < resend_) return false;
  last_send_ = now;
  return true;
}

std::string EpochCutter::Missing(uint64_t id, const EpochAcks& acks) const {
  std::string out;
  for (int64_t k = 0; k < shards_; ++k) {
    auto it = acks.shards.find(uint32_t(k));
    if (it == acks.shards.end() || it->second < id) out += (out.empty() ? "" : ", ") + ("replay-" + std::to_string(k));
  }
  if (acks.learner < id) out += (out.empty() ? "" : ", ") + std::string("learner");
  return out;
}

EpochCutter::Outcome EpochCutter::Check(Clock::time_point now, const EpochAcks& acks, std::string* missing) {
  if (!pending_) return Outcome::kIdle;
  *missing = Missing(CheckpointCommandId(*pending_), acks);
  if (missing->empty()) {
    pending_.reset();
    return Outcome::kComplete;
  }
  if (now - sent_at_ >= timeout_) {
    pending_.reset();
    return Outcome::kAbandoned;
  }
  return Outcome::kPending;
}

}  // namespace coins
