#include "learner/replay_client/prefetcher.h"

#include <utility>

namespace coins {

namespace {
using Clock = std::chrono::steady_clock;
// how often an idle thread looks at its flags without being woken (a safety net)
constexpr auto kIdlePoll = std::chrono::milliseconds(100);
}  // namespace

Status PrefetchOptions::Validate() const {
  if (depth < 1 || depth > 2) return Errorf("prefetch: depth {} not in [1, 2]", depth);
  if (wait.count() <= 0) return Errorf("prefetch: wait {} ms must be positive", wait.count());
  if (flush_period.count() < 0)
    return Errorf("prefetch: flush_period {} ms must not be negative", flush_period.count());
  return Status::Ok();
}

void PrefetchingSource::Updates::clear() {
  priority_keys.clear();
  priorities.clear();
  weight_keys.clear();
  weights.clear();
}

Result<std::unique_ptr<PrefetchingSource>> PrefetchingSource::Create(SampleSource* source, PrefetchOptions options) {
  if (!source) return Errorf("prefetch: no source");
  COINS_RETURN_IF_ERROR(options.Validate());
  return std::unique_ptr<PrefetchingSource>(new PrefetchingSource(source, options));
}

PrefetchingSource::PrefetchingSource(SampleSource* source, PrefetchOptions options)
    : source_(source), options_(options) {
  thread_ = std::thread([this] { Run(); });
}

PrefetchingSource::~PrefetchingSource() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  worker_cv_.notify_all();
  caller_cv_.notify_all();
  thread_.join();
}

std::unique_ptr<PrefetchingSource::Item> PrefetchingSource::TakeFree() {
  if (free_.empty()) return std::make_unique<Item>();
  auto item = std::move(free_.back());
  free_.pop_back();
  return item;
}

void PrefetchingSource::SendUpdates() {
  if (!sending_.priority_keys.empty()) source_->UpdatePriorities(sending_.priority_keys, sending_.priorities);
  if (!sending_.weight_keys.empty()) source_->UpdateWeights(sending_.weight_keys, sending_.weights);
  sending_.clear();
}

void PrefetchingSource::Run() {
  std::unique_lock lock(mu_);
  for (;;) {
    const auto now = Clock::now();
    const bool room = have_spec_ && !stop_ && ready_.size() < size_t(options_.depth);
    const bool flush = !queued_.empty() &&
                       (stop_ || queued_.keys() >= options_.flush_keys || now >= queued_since_ + options_.flush_period);
    if (!room && !flush) {
      if (stop_) return;
      auto wake = now + kIdlePoll;
      if (!queued_.empty()) wake = std::min(wake, queued_since_ + options_.flush_period);
      worker_cv_.wait_until(lock, wake);
      continue;
    }
    // take the updates that are due and, when there is room, what to sample
    if (flush) std::swap(queued_, sending_);
    std::unique_ptr<Item> item = room ? TakeFree() : nullptr;
    const uint64_t generation = generation_;
    const int batch = batch_;
    if (item && thread_generation_ != generation) {
      thread_spec_ = spec_;  // vector assignments reuse capacity
      thread_generation_ = generation;
    }
    lock.unlock();
    SendUpdates();
    if (item) {
      item->status = source_->Sample(thread_spec_, batch, &item->columns);
      item->generation = generation;
    }
    lock.lock();
    if (!item) continue;
    if (generation == generation_ && !stop_) {
      ready_.push_back(std::move(item));
      caller_cv_.notify_all();
    } else {
      stats_.discarded++;
      free_.push_back(std::move(item));
    }
  }
}

Status PrefetchingSource::Sample(const SampleSpec& spec, int batch, SampleColumns* out) {
  const auto start = Clock::now();
  std::unique_lock lock(mu_);
  if (!have_spec_ || batch != batch_ || !(spec == spec_)) {
    // a new kind of batch: what is ready was sampled for the old one
    spec_ = spec;
    batch_ = batch;
    have_spec_ = true;
    ++generation_;
    stats_.discarded += ready_.size();
    while (!ready_.empty()) {
      free_.push_back(std::move(ready_.front()));
      ready_.pop_front();
    }
    worker_cv_.notify_all();
  }
  const bool was_ready = !ready_.empty();
  if (!caller_cv_.wait_until(lock, start + options_.wait, [&] { return !ready_.empty() || stop_; }))
    return Errorf("prefetch: no batch within {} ms", options_.wait.count());
  if (ready_.empty()) return Errorf("prefetch: stopped");
  std::unique_ptr<Item> item = std::move(ready_.front());
  ready_.pop_front();
  worker_cv_.notify_all();  // room for the next one
  stats_.batches++;
  stats_.ready += was_ready;
  stats_.wait_s += std::chrono::duration<double>(Clock::now() - start).count();
  lock.unlock();
  // hand the columns over by swapping buffers; out's old buffers go back to the pool
  Status status = item->status;
  if (status.ok()) std::swap(*out, item->columns);
  lock.lock();
  free_.push_back(std::move(item));
  return status;
}

void PrefetchingSource::Queue(std::span<const uint64_t> keys, std::span<const float> values,
                              std::vector<uint64_t>* to_keys, std::vector<float>* to_values) {
  if (queued_.empty()) {
    // the thread's next wake-up comes from the oldest update
    queued_since_ = Clock::now();
    worker_cv_.notify_all();
  }
  const size_t n = std::min(keys.size(), values.size());
  to_keys->insert(to_keys->end(), keys.begin(), keys.begin() + ptrdiff_t(n));
  to_values->insert(to_values->end(), values.begin(), values.begin() + ptrdiff_t(n));
}

void PrefetchingSource::UpdatePriorities(std::span<const uint64_t> keys, std::span<const float> priorities) {
  std::lock_guard lock(mu_);
  Queue(keys, priorities, &queued_.priority_keys, &queued_.priorities);
  if (queued_.keys() >= options_.flush_keys) worker_cv_.notify_all();
}

void PrefetchingSource::UpdateWeights(std::span<const uint64_t> keys, std::span<const float> weights) {
  std::lock_guard lock(mu_);
  Queue(keys, weights, &queued_.weight_keys, &queued_.weights);
  if (queued_.keys() >= options_.flush_keys) worker_cv_.notify_all();
}

PrefetchStats PrefetchingSource::stats() const {
  std::lock_guard lock(mu_);
  return stats_;
}

}  // namespace coins
