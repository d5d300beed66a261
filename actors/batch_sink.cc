#include "actors/batch_sink.h"

#include <thread>

#include <spdlog/spdlog.h>

namespace coins {

using eprosima::fastrtps::types::ReturnCode_t;

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

DdsBatchSink::~DdsBatchSink() = default;

msg::TransitionBatch* DdsBatchSink::Acquire() {
  if (loans_) {
    void* sample = nullptr;
    // the loan pool can be momentarily empty while the history is full: wait for room
    for (int attempt = 0;; ++attempt) {
      ReturnCode_t rc = writer_.raw()->loan_sample(sample);
      if (rc == ReturnCode_t::RETCODE_OK) return static_cast<msg::TransitionBatch*>(sample);
      if (rc != ReturnCode_t::RETCODE_OUT_OF_RESOURCES) {
        spdlog::warn("transition writer cannot loan samples (code {}); publishing copies", rc());
        loans_ = false;
        break;
      }
      if (stopping_()) return nullptr;
      ++retries_;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }
  return heap_.Acquire();
}

bool DdsBatchSink::Publish(msg::TransitionBatch* batch) {
  // volatile topic: a batch written before the shard matched would be lost, so wait for it
  bool warned = false;
  auto since = std::chrono::steady_clock::now();
  while (writer_.matched() == 0) {
    if (stopping_()) {
      Release(batch);
      return false;
    }
    if (!warned && std::chrono::steady_clock::now() - since > std::chrono::seconds(5)) {
      spdlog::warn("no replay shard matched on the transition topic yet; holding batches");
      warned = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  // a full keep-all history makes write() time out after max_blocking_time: try again
  while (!writer_.raw()->write(batch)) {
    if (stopping_()) {
      Release(batch);
      return false;
    }
    ++retries_;
  }
  if (!loans_) heap_.Release(batch);
  return true;
}

void DdsBatchSink::Release(msg::TransitionBatch* batch) {
  if (loans_) {
    void* sample = batch;
    writer_.raw()->discard_loan(sample);
  } else {
    heap_.Release(batch);
  }
}

bool DdsBatchSink::Flush(std::chrono::milliseconds timeout) { return writer_.WaitAcked(timeout); }

}  // namespace coins
