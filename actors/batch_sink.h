// BatchSink: where an actor's finished TransitionBatches go. The actor fills a buffer obtained
// from Acquire() in place and hands it to Publish(). Buffers are reused, so their sequences
// keep their capacity and filling allocates nothing after the first batches. DdsBatchSink
// writes them on the transition topic; MemoryBatchSink only counts them, which is how the
// standalone step rate is measured.
#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <vector>

#include "common/dds/node.h"
#include "idl/transition.h"

namespace coins {

class BatchSink {
 public:
  virtual ~BatchSink() = default;
  // a buffer to fill; nullptr when the sink is stopping
  virtual msg::TransitionBatch* Acquire() = 0;
  // publishes a filled buffer (from Acquire) and takes it back; false if stopping cut it short
  virtual bool Publish(msg::TransitionBatch* batch) = 0;
  // takes back an acquired buffer that will not be published
  virtual void Release(msg::TransitionBatch* batch) = 0;
  // waits for every published batch to be acknowledged; false on timeout
  virtual bool Flush(std::chrono::milliseconds timeout) = 0;
  // writes that had to wait for room in the writer history
  virtual uint64_t retries() const = 0;
};

// keeps a small pool of heap batches; Publish only counts
class MemoryBatchSink final : public BatchSink {
 public:
  msg::TransitionBatch* Acquire() override;
  bool Publish(msg::TransitionBatch* batch) override;
  void Release(msg::TransitionBatch* batch) override;
  bool Flush(std::chrono::milliseconds) override { return true; }
  uint64_t retries() const override { return 0; }
  uint64_t published() const { return published_; }

 private:
  std::vector<std::unique_ptr<msg::TransitionBatch>> free_;
  uint64_t published_ = 0;
};

// publishes on a DDS writer of the transition topic; waits (bounded, in slices) for a matched
// reader and for history room, giving up only when `stopping` returns true
class DdsBatchSink final : public BatchSink {
 public:
  DdsBatchSink(dds::Writer<msg::TransitionBatch> writer, std::function<bool()> stopping);
  msg::TransitionBatch* Acquire() override;
  bool Publish(msg::TransitionBatch* batch) override;
  void Release(msg::TransitionBatch* batch) override;
  bool Flush(std::chrono::milliseconds timeout) override;
  uint64_t retries() const override { return retries_; }

 private:
  dds::Writer<msg::TransitionBatch> writer_;
  std::function<bool()> stopping_;
  MemoryBatchSink pool_;
  uint64_t retries_ = 0;
};

}  // namespace coins
