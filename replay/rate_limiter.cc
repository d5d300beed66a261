#include "replay/rate_limiter.h"

#include <algorithm>
#include <functional>

namespace coins {

Status RateLimiter::Check(const RateLimiterConfig& c, int64_t capacity, int64_t max_insert, int64_t max_sample) {
  if (c.min_size < 1) return Errorf("min_size {} must be at least 1", c.min_size);
  if (c.min_size > capacity)
    return Errorf("min_size {} exceeds capacity {}: sampling could never start", c.min_size, capacity);
  if (c.samples_per_insert < 0) return Errorf("samples_per_insert {} is negative", c.samples_per_insert);
  if (c.samples_per_insert > 0) {
    double need = c.samples_per_insert * double(max_insert) + double(max_sample);
    if (2 * c.error_buffer < need)
      return Errorf(
          "error_buffer {} would deadlock: with samples_per_insert {} it must be at least {} "
          "(2 * error_buffer >= samples_per_insert * {} + {})",
          c.error_buffer, c.samples_per_insert, need / 2, max_insert, max_sample);
  }
  return Status::Ok();
}

bool RateLimiter::InsertOk(int64_t m, int64_t size) const {
  if (closed_ || inserts_released_) return true;
  const double r = config_.samples_per_insert;
  if (r == 0 || size < config_.min_size) return true;
  double diff = r * double(c_.inserted) - double(c_.sampled);
  return diff + r * double(m) <= r * double(config_.min_size) + config_.error_buffer;
}

bool RateLimiter::SampleOk(int64_t k, int64_t size) const {
  if (closed_) return true;
  if (size < config_.min_size) return false;
  const double r = config_.samples_per_insert;
  if (r == 0) return true;
  double diff = r * double(c_.inserted) - double(c_.sampled);
  return diff - double(k) >= r * double(config_.min_size) - config_.error_buffer;
}

bool RateLimiter::CanInsert(int64_t m, int64_t size) const {
  std::lock_guard lock(mu_);
  return InsertOk(m, size);
}

bool RateLimiter::CanSample(int64_t k, int64_t size) const {
  std::lock_guard lock(mu_);
  return SampleOk(k, size);
}

bool RateLimiter::AwaitInsert(int64_t m, int64_t size, std::chrono::milliseconds timeout) {
  std::unique_lock lock(mu_);
  // InsertOk is true once inserts are released: a stopping shard stores what it took
  if (!cv_.wait_for(lock, timeout, [&] { return InsertOk(m, size); })) return false;
  c_.inserted += uint64_t(m);
  lock.unlock();
  cv_.notify_all();
  return true;
}

bool RateLimiter::AwaitSample(int64_t k, std::function<int64_t()> size, std::chrono::milliseconds timeout) {
  std::unique_lock lock(mu_);
  // the size is read outside the limiter's lock holder's control: poll it in short slices
  auto end = std::chrono::steady_clock::now() + timeout;
  while (!SampleOk(k, size())) {
    if (closed_) return false;
    auto now = std::chrono::steady_clock::now();
    if (now >= end) return false;
    cv_.wait_for(lock, std::min<std::chrono::nanoseconds>(end - now, std::chrono::milliseconds(20)));
  }
  if (closed_) return false;
  c_.sampled += uint64_t(k);
  lock.unlock();
  cv_.notify_all();
  return true;
}

void RateLimiter::CancelInsert(int64_t m) {
  {
    std::lock_guard lock(mu_);
    c_.inserted -= std::min<uint64_t>(c_.inserted, uint64_t(m));
  }
  cv_.notify_all();
}

void RateLimiter::AddInserted(int64_t m) {
  {
    std::lock_guard lock(mu_);
    c_.inserted += uint64_t(std::max<int64_t>(m, 0));
  }
  cv_.notify_all();
}

void RateLimiter::ReleaseInserts() {
  {
    std::lock_guard lock(mu_);
    inserts_released_ = true;
  }
  cv_.notify_all();
}

void RateLimiter::Close() {
  {
    std::lock_guard lock(mu_);
    closed_ = true;
  }
  cv_.notify_all();
}

RateLimiterCounters RateLimiter::counters() const {
  std::lock_guard lock(mu_);
  return c_;
}

void RateLimiter::Restore(const RateLimiterCounters& c) {
  std::lock_guard lock(mu_);
  c_ = c;
  const double r = config_.samples_per_insert;
  if (r == 0) return;
  // keep diff inside [r*min_size - B, r*min_size + B] by moving S
  double diff = r * double(c_.inserted) - double(c_.sampled);
  double lo = r * double(config_.min_size) - config_.error_buffer;
  double hi = r * double(config_.min_size) + config_.error_buffer;
  double clamped = std::clamp(diff, lo, hi);
  if (clamped != diff) c_.sampled = uint64_t(std::max(0.0, r * double(c_.inserted) - clamped));
}

}  // namespace coins
