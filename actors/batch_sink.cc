#include "actors/batch_sink.h"

#include <thread>

#include <spdlog/spdlog.h>

#include "common/dds/qos.h"
#include "common/dds/topics.h"
#include "idl/statusPubSubTypes.h"
#include "idl/transitionPubSubTypes.h"

namespace coins {

using Clock = std::chrono::steady_clock;

msg::TransitionBatch* MemoryBatchSink::Acquire() {
  if (free_.empty()) return new msg::TransitionBatch();
  msg::TransitionBatch* b = free_.back().release();
  free_.pop_back();
  return b;
}

bool MemoryBatchSink::Publish(msg::TransitionBatch* batch) {
  ++published_;
  Release(batch);
  return true;
}

void MemoryBatchSink::Release(msg::TransitionBatch* batch) { free_.emplace_back(batch); }

DdsBatchSink::DdsBatchSink(const DdsOptions& dds, std::string name, int64_t shard, std::function<bool()> stopping)
    : dds_(dds), name_(std::move(name)), shard_(shard), stopping_(std::move(stopping)) {}

DdsBatchSink::~DdsBatchSink() = default;

Result<std::unique_ptr<DdsBatchSink>> DdsBatchSink::Create(const DdsOptions& dds, std::string name, int64_t shard,
                                                           std::function<bool()> stopping) {
  std::unique_ptr<DdsBatchSink> sink(new DdsBatchSink(dds, std::move(name), shard, std::move(stopping)));
  COINS_RETURN_IF_ERROR(sink->Open());
  return sink;
}

Status DdsBatchSink::Open() {
  // the old participant goes first: its writer and its shared-memory ports with it
  node_.reset();
  auto node = dds::Node::Create(dds_, name_);
  if (!node.ok()) return node.status();
  auto writer = (*node)->MakeWriter<msg::TransitionBatchPubSubType>(
      dds::kTransitionTopic, dds::TransitionWriterQos(dds_), dds::ShardPartition(shard_));
  if (!writer.ok()) return writer.status();
  auto stats = (*node)->MakeReader<msg::ReplayStatsPubSubType>(dds::kReplayStatsTopic, dds::StatusReaderQos());
  if (!stats.ok()) return stats.status();
  node_ = std::move(*node);
  writer_ = *writer;
  stats_ = *stats;
  blocked_since_.reset();
  return Status::Ok();
}

msg::TransitionBatch* DdsBatchSink::Acquire() { return stopping_() ? nullptr : pool_.Acquire(); }

void DdsBatchSink::Release(msg::TransitionBatch* batch) { pool_.Release(batch); }

void DdsBatchSink::Retain(const msg::TransitionBatch& b) {
  // as many as the writer history holds: what may still be unacknowledged
  const size_t keep = size_t(std::max<int64_t>(dds_.transition_history, 1));
  std::unique_ptr<msg::TransitionBatch> copy;
  if (retained_.size() >= keep) {
    copy = std::move(retained_.front());
    retained_.pop_front();
    if (next_ > 0) --next_;
  } else if (!spare_.empty()) {
    copy = std::move(spare_.back());
    spare_.pop_back();
  } else {
    copy = std::make_unique<msg::TransitionBatch>();
  }
  *copy = b;  // the sequences keep their capacity: no allocation once warm
  retained_.push_back(std::move(copy));
}

bool DdsBatchSink::WaitForReader() {
  // volatile topic: a batch written before the shard matched would be lost, so wait for it
  bool warned = false;
  auto since = Clock::now();
  while (writer_.matched() == 0) {
    if (stopping_()) return false;
    if (!warned && Clock::now() - since > std::chrono::seconds(5)) {
      spdlog::warn("no replay shard matched on the transition topic yet; holding batches");
      warned = true;
    }
    blocked_since_.reset();  // no reader: nothing can be stalled
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

bool DdsBatchSink::Deliver() {
  while (next_ < retained_.size()) {
    if (!WaitForReader()) return false;
    // a full keep-all history makes write() time out after max_blocking_time: try again
    if (writer_.Write(*retained_[next_])) {
      if (blocked_since_) NoteProgress();  // room again: something was acknowledged
      ++next_;
      continue;
    }
    if (stopping_()) return false;
    ++retries_;
    if (Stalled() && !Recover()) return false;
  }
  return true;
}

bool DdsBatchSink::Publish(msg::TransitionBatch* batch) {
  if (actor_id_ == ~0u) actor_id_ = batch->actor_id();
  Retain(*batch);
  pool_.Release(batch);
  if (Deliver()) return true;
  // cut short by a stop: the batch was not written and does not count as published
  if (!retained_.empty() && next_ < retained_.size()) {
    spare_.push_back(std::move(retained_.back()));
    retained_.pop_back();
  }
  return false;
}

bool DdsBatchSink::Stalled() {
  auto now = Clock::now();
  if (!blocked_since_) {
    blocked_since_ = now;
    quiet_reports_ = 0;
  }
  // the shard's reports: progress is our batches stored or inserts held back by its limiter
  msg::ReplayStats s;
  stats_.TakeAll(s, [&](const msg::ReplayStats& r, const auto&) {
    if (r.shard_id() != uint32_t(shard_)) return;
    uint64_t ours = 0;
    for (const auto& a : r.actors())
      if (a.actor_id() == actor_id_) ours = a.batches() + a.next_seq();
    std::pair<uint64_t, uint64_t> p{ours, r.insert_waits()};
    quiet_reports_ = p == last_progress_ ? quiet_reports_ + 1 : 0;
    last_progress_ = p;
  });
  const double blocked = std::chrono::duration<double>(now - *blocked_since_).count();
  if (blocked >= dds_.writer_stall_s && quiet_reports_ >= 2) return true;
  return blocked >= 10 * dds_.writer_stall_s;
}

bool DdsBatchSink::Recover() {
  const double blocked = std::chrono::duration<double>(Clock::now() - *blocked_since_).count();
  spdlog::warn(
      "transition stream to shard {} stalled: {} reader(s) matched, nothing acknowledged for {:.1f} s and "
      "no progress reported by the shard; replacing the writer and resending {} retained batches",
      shard_, writer_.matched(), blocked, retained_.size());
  // a stop cuts the wait for the new participant short
  for (;;) {
    Status s = Open();
    if (s.ok()) break;
    spdlog::warn("cannot replace the transition writer: {}", s.message());
    if (stopping_()) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  ++recoveries_;
  next_ = 0;
  quiet_reports_ = 0;
  last_progress_ = {~0ull, ~0ull};
  return true;
}

bool DdsBatchSink::Flush(std::chrono::milliseconds timeout) {
  auto end = Clock::now() + timeout;
  for (;;) {
    if (next_ < retained_.size() && !Deliver()) return false;  // a recovery left batches to resend
    if (writer_.matched() > 0 && writer_.WaitAcked(std::chrono::milliseconds(200))) return true;
    if (Clock::now() >= end) return false;
    if (writer_.matched() == 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      blocked_since_.reset();
      continue;
    }
    if (Stalled() && !Recover()) return false;
  }
}

}  // namespace coins
