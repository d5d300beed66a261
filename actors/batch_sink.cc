#include "actors/batch_sink.h"

#include <thread>

#include <spdlog/spdlog.h>

namespace coins {

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

DdsBatchSink::DdsBatchSink(dds::Writer<msg::TransitionBatch> writer, std::function<bool()> stopping)
    : writer_(writer), stopping_(std::move(stopping)) {}

msg::TransitionBatch* DdsBatchSink::Acquire() { return stopping_() ? nullptr : pool_.Acquire(); }

bool DdsBatchSink::Publish(msg::TransitionBatch* batch) {
  // volatile topic: a batch written before the shard matched would be lost, so wait for it
  bool warned = false;
  auto since = std::chrono::steady_clock::now();
  while (writer_.matched() == 0) {
    if (stopping_()) {
      pool_.Release(batch);
      return false;
    }
    if (!warned && std::chrono::steady_clock::now() - since > std::chrono::seconds(5)) {
      spdlog::warn("no replay shard matched on the transition topic yet; holding batches");
      warned = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  // a full keep-all history makes write() time out after max_blocking_time: try again
  while (!writer_.Write(*batch)) {
    if (stopping_()) {
      pool_.Release(batch);
      return false;
    }
    ++retries_;
  }
  pool_.Release(batch);
  return true;
}

void DdsBatchSink::Release(msg::TransitionBatch* batch) { pool_.Release(batch); }

bool DdsBatchSink::Flush(std::chrono::milliseconds timeout) { return writer_.WaitAcked(timeout); }

}  // namespace coins
