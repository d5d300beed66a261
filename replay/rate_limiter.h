// RateLimiter: how a shard keeps the learner's sampling and the actors' inserting in step.
//
// Counters: I = transitions inserted, S = transitions sampled, size = transitions held.
// With r = samples_per_insert and B = error_buffer, let diff = r * I - S. Then
//   an insert of m transitions may proceed  iff  size < min_size  or  diff + r * m <= r * min_size + B
//   a sample of k transitions may proceed   iff  size >= min_size and diff - k >= r * min_size - B
// r = 0 turns the ratio off: inserts always proceed and samples only wait for min_size.
// A configuration can deadlock (neither side may move) unless
//   2 * B >= r * max_insert + max_sample     (max_insert: largest batch, max_sample: largest request)
// Check() refuses such a configuration, and min_size > capacity, when they are given.
//
// Blocking calls wait on a condition variable for at most their timeout and return false when
// it passed (never deadlock). A stopping shard first calls ReleaseInserts(): inserts proceed at
// once from then on (and are counted), so that it stores every batch it has taken from DDS (and
// acknowledged) and its actors can flush; samples are still served. Close() then releases every
// waiter and refuses samples; inserts still proceed. Thread-safe.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>

#include "common/status.h"

namespace coins {

struct RateLimiterConfig {
  int64_t min_size = 1;
  double samples_per_insert = 0;  // 0: no ratio
  double error_buffer = 0;
};

struct RateLimiterCounters {
  uint64_t inserted = 0;  // I
  uint64_t sampled = 0;   // S
};

class RateLimiter {
 public:
  // refuses a configuration that could deadlock (formula above) or never allow sampling
  static Status Check(const RateLimiterConfig& c, int64_t capacity, int64_t max_insert, int64_t max_sample);

  explicit RateLimiter(const RateLimiterConfig& config) : config_(config) {}

  // waits until an insert of m transitions may proceed (size: transitions held now), then
  // counts it; false on timeout (nothing counted). After ReleaseInserts() or Close() it
  // proceeds at once.
  bool AwaitInsert(int64_t m, int64_t size, std::chrono::milliseconds timeout);
  // waits until a sample of k may proceed, then counts it; false on timeout or Close()
  // (nothing counted)
  bool AwaitSample(int64_t k, std::function<int64_t()> size, std::chrono::milliseconds timeout);
  // non-blocking forms of the two tests
  bool CanInsert(int64_t m, int64_t size) const;
  bool CanSample(int64_t k, int64_t size) const;
  // takes back a counted insert that was not stored (duplicate or rejected batch)
  void CancelInsert(int64_t m);
  // counts an insert that did not wait (a held batch stored when a later one confirmed it)
  void AddInserted(int64_t m);
  // tells waiters that the size changed (an insert happened elsewhere)
  void Notify() { cv_.notify_all(); }
  // inserts no longer wait (a stop is under way); samples go on as before
  void ReleaseInserts();
  void Close();

  RateLimiterCounters counters() const;
  // restores counters from a snapshot; when the config changed since, the difference is
  // clamped into the new window so that neither side stays blocked forever
  void Restore(const RateLimiterCounters& c);
  const RateLimiterConfig& config() const { return config_; }

 private:
  bool InsertOk(int64_t m, int64_t size) const;
  bool SampleOk(int64_t k, int64_t size) const;

  const RateLimiterConfig config_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  RateLimiterCounters c_;
  bool closed_ = false;
  bool inserts_released_ = false;
};

}  // namespace coins
