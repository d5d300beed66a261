// PrefetchingSource over a scripted source: order, overlap, spec changes, errors, bounded
// waits, updates sent from the background thread, shutdown with a call in flight.
#include "learner/replay_client/prefetcher.h"

#include <gtest/gtest.h>

#include <atomic>
#include <mutex>
#include <thread>

namespace coins {
namespace {

using namespace std::chrono_literals;

// sample number k fills key[0] = k and reward[0] = spec.n_step; calls take `delay`
class ScriptedSource final : public SampleSource {
 public:
  std::chrono::milliseconds delay{0};
  int fail_call = -1;  // this call number fails
  Status Sample(const SampleSpec& spec, int batch, SampleColumns* out) override {
    std::this_thread::sleep_for(delay);
    int k = calls++;
    if (k == fail_call) return Errorf("scripted failure {}", k);
    out->Resize(uint32_t(batch), 1, 1, 0);
    out->key[0] = uint64_t(k);
    out->reward[0] = float(spec.n_step);
    return Status::Ok();
  }
  void UpdatePriorities(std::span<const uint64_t> keys, std::span<const float> values) override {
    std::lock_guard lock(mu);
    updated.insert(updated.end(), keys.begin(), keys.end());
    update_thread = std::this_thread::get_id();
  }
  void UpdateWeights(std::span<const uint64_t> keys, std::span<const float>) override {
    std::lock_guard lock(mu);
    weighted += keys.size();
  }
  size_t updates() {
    std::lock_guard lock(mu);
    return updated.size();
  }
  std::atomic<int> calls{0};
  std::mutex mu;
  std::vector<uint64_t> updated;
  size_t weighted = 0;
  std::thread::id update_thread;
};

std::unique_ptr<PrefetchingSource> Make(SampleSource* s, PrefetchOptions o = {}) {
  auto p = PrefetchingSource::Create(s, o);
  EXPECT_TRUE(p.ok()) << p.status().message();
  return std::move(*p);
}

TEST(Prefetcher, DeliversInOrderAndIsReadyWhenTheCallerWorks) {
  ScriptedSource src;
  src.delay = 2ms;
  auto p = Make(&src, {.depth = 2});
  SampleSpec spec;
  SampleColumns c;
  for (uint64_t k = 0; k < 10; ++k) {
    ASSERT_TRUE(p->Sample(spec, 4, &c).ok());
    EXPECT_EQ(c.key[0], k);
    EXPECT_EQ(c.n, 4u);
    std::this_thread::sleep_for(30ms);  // the caller's update
  }
  PrefetchStats st = p->stats();
  EXPECT_EQ(st.batches, 10u);
  EXPECT_GE(st.ready, 8u);  // all but the first, on a quiet machine
  // never more than depth batches ahead, plus the one in flight
  EXPECT_LE(src.calls.load(), 10 + 2 + 1);
}

TEST(Prefetcher, ANewSpecDropsWhatWasSampledForTheOldOne) {
  ScriptedSource src;
  auto p = Make(&src, {.depth = 2});
  SampleSpec one, three;
  three.n_step = 3;
  SampleColumns c;
  ASSERT_TRUE(p->Sample(one, 4, &c).ok());
  EXPECT_EQ(c.reward[0], 1.0f);
  std::this_thread::sleep_for(50ms);  // two more of `one` get ready
  ASSERT_TRUE(p->Sample(three, 4, &c).ok());
  EXPECT_EQ(c.reward[0], 3.0f);
  ASSERT_TRUE(p->Sample(three, 8, &c).ok());  // the batch size counts too
  EXPECT_EQ(c.n, 8u);
  EXPECT_GE(p->stats().discarded, 2u);
}

TEST(Prefetcher, ErrorsArriveInOrderThenSamplingGoesOn) {
  ScriptedSource src;
  src.fail_call = 1;
  auto p = Make(&src);
  SampleSpec spec;
  SampleColumns c;
  ASSERT_TRUE(p->Sample(spec, 2, &c).ok());
  Status s = p->Sample(spec, 2, &c);
  EXPECT_NE(s.message().find("scripted failure 1"), std::string::npos) << s.message();
  ASSERT_TRUE(p->Sample(spec, 2, &c).ok());
  EXPECT_EQ(c.key[0], 2u);
}

TEST(Prefetcher, WaitsAreBoundedAndShutdownJoinsACallInFlight) {
  ScriptedSource src;
  src.delay = 300ms;
  auto t0 = std::chrono::steady_clock::now();
  {
    auto p = Make(&src, {.depth = 1, .wait = 50ms});
    SampleColumns c;
    Status s = p->Sample(SampleSpec{}, 2, &c);
    EXPECT_NE(s.message().find("no batch within 50 ms"), std::string::npos) << s.message();
    EXPECT_LT(std::chrono::steady_clock::now() - t0, 250ms);
  }  // the destructor waits for the call in flight (300 ms) and joins
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 2s);
}

TEST(Prefetcher, UpdatesGoThroughTheBackgroundThread) {
  ScriptedSource src;
  auto p = Make(&src);
  SampleColumns c;
  ASSERT_TRUE(p->Sample(SampleSpec{}, 2, &c).ok());
  const uint64_t keys[] = {5, 6, 7};
  const float values[] = {1, 2, 3};
  p->UpdatePriorities(keys, values);
  p->UpdateWeights(keys, values);
  auto end = std::chrono::steady_clock::now() + 2s;
  while (src.updates() < 3 && std::chrono::steady_clock::now() < end) std::this_thread::sleep_for(1ms);
  {
    std::lock_guard lock(src.mu);
    EXPECT_EQ(src.updated, (std::vector<uint64_t>{5, 6, 7}));
    EXPECT_NE(src.update_thread, std::this_thread::get_id());
  }
  p->UpdateWeights(keys, values);
  p.reset();  // queued updates are sent before the thread ends
  EXPECT_EQ(src.weighted, 6u);
}

TEST(Prefetcher, OptionsAreChecked) {
  ScriptedSource src;
  auto p = PrefetchingSource::Create(&src, {.depth = 3});
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.status().message().find("depth 3"), std::string::npos);
}

}  // namespace
}  // namespace coins
