// PrefetchingSource: a SampleSource that samples ahead on a background thread, so that the
// next batch's round trip (over DDS, or the in-process sampler) overlaps the caller's update.
//
// The first Sample(spec, batch) call starts the thread sampling (spec, batch); it keeps up to
// `depth` batches ready (a bounded queue) and refills as the caller takes them. A call with a
// different spec or batch size drops the batches ready and the one in flight (counted as
// discarded) and waits for one of the new kind. Batches are therefore up to depth + 1 updates
// older than the caller's newest priorities, as in Ape-X / Reverb style prefetching.
//
// The wrapped source is used from the background thread only, from Create until destruction:
// UpdatePriorities / UpdateWeights are queued and the thread sends them in groups (once
// flush_keys are queued or the oldest has waited flush_period; all of them at shutdown), so a
// learner's per-update priorities cost one message per shard every few updates.
// A sample that fails is delivered in order as the error of one Sample() call; the thread then
// tries again. Every wait is bounded: Sample() waits at most options.wait; the destructor stops
// the thread and joins it (at most the wrapped source's own timeout for a call in flight).
// Sample() is for one caller thread; the update calls may come from any thread.
#pragma once

#include <chrono>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "learner/replay_client/sample_source.h"

namespace coins {

struct PrefetchOptions {
  int depth = 1;                               // batches kept ready: 1 or 2
  std::chrono::milliseconds wait{10000};       // the longest one Sample() call waits for a batch
  size_t flush_keys = 512;                     // updates are sent once this many keys are queued,
  std::chrono::milliseconds flush_period{20};  // or when the oldest has waited this long
  Status Validate() const;
};

struct PrefetchStats {
  uint64_t batches = 0;    // handed to the caller
  uint64_t ready = 0;      // of them, ready when asked (no wait)
  uint64_t discarded = 0;  // sampled for a spec no longer asked for
  double wait_s = 0;       // total time callers waited
};

class PrefetchingSource final : public SampleSource {
 public:
  // source must outlive the prefetcher
  static Result<std::unique_ptr<PrefetchingSource>> Create(SampleSource* source, PrefetchOptions options = {});
  ~PrefetchingSource() override;
  PrefetchingSource(const PrefetchingSource&) = delete;
  PrefetchingSource& operator=(const PrefetchingSource&) = delete;

  Status Sample(const SampleSpec& spec, int batch, SampleColumns* out) override;
  void UpdatePriorities(std::span<const uint64_t> keys, std::span<const float> priorities) override;
  void UpdateWeights(std::span<const uint64_t> keys, std::span<const float> weights) override;
  PrefetchStats stats() const;

 private:
  struct Item {
    SampleColumns columns;
    Status status;
    uint64_t generation = 0;
  };
  struct Updates {
    std::vector<uint64_t> priority_keys, weight_keys;
    std::vector<float> priorities, weights;
    bool empty() const { return priority_keys.empty() && weight_keys.empty(); }
    size_t keys() const { return priority_keys.size() + weight_keys.size(); }
    void clear();
  };
  PrefetchingSource(SampleSource* source, PrefetchOptions options);
  void Run();
  // sends the updates queued so far (thread only)
  void SendUpdates();
  // under mu_: a pooled item for the next sample
  std::unique_ptr<Item> TakeFree();
  // under mu_: appends to the queued updates
  void Queue(std::span<const uint64_t> keys, std::span<const float> values, std::vector<uint64_t>* to_keys,
             std::vector<float>* to_values);

  SampleSource* source_;
  PrefetchOptions options_;
  mutable std::mutex mu_;
  std::condition_variable worker_cv_, caller_cv_;
  bool stop_ = false;
  // what to sample (guarded by mu_), and the thread's copy of it
  bool have_spec_ = false;
  SampleSpec spec_;
  int batch_ = 0;
  uint64_t generation_ = 0;
  SampleSpec thread_spec_;
  uint64_t thread_generation_ = ~uint64_t(0);
  std::deque<std::unique_ptr<Item>> ready_;
  std::vector<std::unique_ptr<Item>> free_;
  Updates queued_;                                      // guarded by mu_
  std::chrono::steady_clock::time_point queued_since_;  // when the oldest queued update came
  Updates sending_;                                     // the thread's
  PrefetchStats stats_;
  std::thread thread_;
};

}  // namespace coins
