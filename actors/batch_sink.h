// BatchSink: where an actor's finished TransitionBatches go. The actor fills a buffer obtained
// from Acquire() in place and hands it to Publish(). Buffers are reused, so their sequences
// keep their capacity and filling allocates nothing after the first batches. DdsBatchSink
// writes them on the transition topic; MemoryBatchSink only counts them, which is how the
// standalone step rate is measured.
#pragma once

#include <atomic>
#include <chrono>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/dds/node.h"
#include "idl/status.h"
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

// DdsBatchSink: publishes to replay shard `shard` on a DDS participant of its own, waiting
// (bounded, in slices) for a matched shard and for history room, giving up only when
// `stopping` returns true.
//
// Recovery from a stalled stream. A shard killed -9 stays matched until its participant lease
// ends, and the reliable writer waits for its acknowledgements meanwhile; a participant that once
// wrote to a killed process's shared-memory port may also never reach its successor (the
// participant ids of common/dds/participant_ids.h avoid that). The sink calls the stream stalled
// when a reader is matched, its writes have found the history full (nothing acknowledged) for
// dds.writer_stall_s, and the shard's ReplayStats meanwhile show no progress: neither batches of
// this actor stored nor inserts held back by its rate limiter (a shard that is merely full of
// work is not stalled). It then replaces its participant (fresh transports, a new writer) and
// resends the batches it retained (the last dds.transition_history ones): the shard drops those
// it holds as duplicates and stores the rest, so nothing acknowledged to the actor is lost twice.
// Without any ReplayStats, a stream blocked for 10 x writer_stall_s is replaced as well.
class DdsBatchSink final : public BatchSink {
 public:
  // name: the participant's name (e.g. "actor-3.transitions")
  static Result<std::unique_ptr<DdsBatchSink>> Create(const DdsOptions& dds, std::string name, int64_t shard,
                                                      std::function<bool()> stopping);
  ~DdsBatchSink() override;

  msg::TransitionBatch* Acquire() override;
  bool Publish(msg::TransitionBatch* batch) override;
  void Release(msg::TransitionBatch* batch) override;
  // waits for the acknowledgements, recovering a stalled stream on the way
  bool Flush(std::chrono::milliseconds timeout) override;
  uint64_t retries() const override { return retries_; }
  // times the stream was replaced
  uint64_t recoveries() const { return recoveries_; }

 private:
  DdsBatchSink(const DdsOptions& dds, std::string name, int64_t shard, std::function<bool()> stopping);
  // (re)creates the participant, the writer and the ReplayStats reader
  Status Open();
  // waits for a matched shard; false when stopping
  bool WaitForReader();
  // keeps a copy of the batch for resending (the newest last)
  void Retain(const msg::TransitionBatch& b);
  // writes the retained batches from next_ on; false when stopping cut it short
  bool Deliver();
  // called while blocked: true when the stream counts as stalled (see above)
  bool Stalled();
  // replaces the participant and rewinds next_ to resend every retained batch
  bool Recover();
  void NoteProgress() { blocked_since_.reset(); }

  DdsOptions dds_;
  std::string name_;
  int64_t shard_;
  std::function<bool()> stopping_;
  std::unique_ptr<dds::Node> node_;
  dds::Writer<msg::TransitionBatch> writer_;
  dds::Reader<msg::ReplayStats> stats_;
  MemoryBatchSink pool_;
  std::deque<std::unique_ptr<msg::TransitionBatch>> retained_;
  std::vector<std::unique_ptr<msg::TransitionBatch>> spare_;  // retained buffers to reuse
  size_t next_ = 0;                                           // index in retained_ of the next batch to write
  uint64_t retries_ = 0, recoveries_ = 0;
  // stall detection
  std::optional<std::chrono::steady_clock::time_point> blocked_since_;
  int quiet_reports_ = 0;                                      // ReplayStats since blocked_since_ showing no progress
  std::pair<uint64_t, uint64_t> last_progress_{~0ull, ~0ull};  // (our batches stored, insert waits)
  uint32_t actor_id_ = ~0u;
};

}  // namespace coins
