#include "replay/rate_limiter.h"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>

namespace coins {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

TEST(RateLimiter, RefusesConfigurationsThatCouldDeadlock) {
  EXPECT_TRUE(RateLimiter::Check({100, 0, 0}, 1000, 1024, 4096).ok());
  EXPECT_TRUE(RateLimiter::Check({100, 2, 3100}, 1000, 1024, 4096).ok());  // 2 * 3100 >= 2 * 1024 + 4096
  Status s = RateLimiter::Check({100, 2, 3000}, 1000, 1024, 4096);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("error_buffer 3000 would deadlock"), std::string::npos) << s.message();
  s = RateLimiter::Check({5000, 0, 0}, 1000, 1024, 4096);
  EXPECT_NE(s.message().find("min_size 5000 exceeds capacity 1000"), std::string::npos) << s.message();
}

TEST(RateLimiter, FollowsTheRatioWithinTheErrorBuffer) {
  RateLimiter l({10, 1.0, 50});
  // below min_size: inserts proceed, samples do not
  EXPECT_FALSE(l.CanSample(1, 0));
  EXPECT_TRUE(l.AwaitInsert(10, 0, 0ms));
  // diff = I - S = 10; a sample of k proceeds while 10 - k >= 10 - 50
  EXPECT_TRUE(l.CanSample(50, 10));
  EXPECT_FALSE(l.CanSample(51, 10));
  // inserts proceed while diff + m <= 10 + 50
  EXPECT_TRUE(l.CanInsert(50, 10));
  EXPECT_FALSE(l.CanInsert(51, 10));
}

// the two-timeout idiom: a blocked call stays blocked for one timeout, and is released
// within another once the other side moves
TEST(RateLimiter, BlockedSamplerTimesOutAndIsReleasedByInserts) {
  RateLimiter l({100, 1.0, 600});
  std::atomic<int64_t> size{0};
  auto t0 = Clock::now();
  EXPECT_FALSE(l.AwaitSample(
      32, [&] { return size.load(); }, 200ms));
  auto blocked = Clock::now() - t0;
  EXPECT_GE(blocked, 190ms);
  EXPECT_LT(blocked, 1500ms);

  std::atomic<bool> released{false};
  std::thread sampler([&] {
    released = l.AwaitSample(
        32, [&] { return size.load(); }, 5s);
  });
  std::this_thread::sleep_for(100ms);
  EXPECT_FALSE(released.load());
  auto t1 = Clock::now();
  ASSERT_TRUE(l.AwaitInsert(100, 0, 0ms));
  size = 100;
  l.Notify();
  sampler.join();
  EXPECT_TRUE(released.load());
  EXPECT_LT(Clock::now() - t1, 1s);
}

TEST(RateLimiter, BlockedInserterIsReleasedBySamplesAndByClose) {
  RateLimiter l({10, 1.0, 600});
  ASSERT_TRUE(l.AwaitInsert(600, 0, 0ms));  // diff 600 = min_size * r + buffer - 10
  auto t0 = Clock::now();
  EXPECT_FALSE(l.AwaitInsert(100, 600, 150ms));
  EXPECT_GE(Clock::now() - t0, 140ms);
  std::atomic<bool> done{false};
  std::thread inserter([&] { done = l.AwaitInsert(100, 600, 5s); });
  std::this_thread::sleep_for(50ms);
  EXPECT_FALSE(done.load());
  ASSERT_TRUE(l.AwaitSample(
      200, [] { return int64_t(600); }, 0ms));
  inserter.join();
  EXPECT_TRUE(done.load());
  // Close releases a waiter at once, without counting
  std::thread stuck([&] {
    EXPECT_FALSE(l.AwaitSample(
        100000, [] { return int64_t(0); }, 10s));
  });
  auto t1 = Clock::now();
  std::this_thread::sleep_for(20ms);
  l.Close();
  stuck.join();
  EXPECT_LT(Clock::now() - t1, 1s);
}

TEST(RateLimiter, ReleasedInsertsProceedWhileSamplesAreStillServed) {
  RateLimiter l({10, 1.0, 600});
  ASSERT_TRUE(l.AwaitInsert(600, 0, 0ms));
  ASSERT_FALSE(l.CanInsert(100, 600));
  std::atomic<bool> done{false};
  std::thread inserter([&] { done = l.AwaitInsert(100, 600, 10s); });
  std::this_thread::sleep_for(30ms);
  EXPECT_FALSE(done.load());
  l.ReleaseInserts();
  inserter.join();
  EXPECT_TRUE(done.load());
  EXPECT_TRUE(l.AwaitInsert(5000, 700, 0ms));
  EXPECT_TRUE(l.AwaitSample(
      200, [] { return int64_t(5700); }, 0ms));
  EXPECT_EQ(l.counters().inserted, 5700u);
  EXPECT_EQ(l.counters().sampled, 200u);
}

TEST(RateLimiter, AfterCloseInsertsProceedAndSamplesAreRefused) {
  RateLimiter l({10, 1.0, 600});
  ASSERT_TRUE(l.AwaitInsert(600, 0, 0ms));
  ASSERT_FALSE(l.CanInsert(100, 600));  // the ratio holds inserts back
  // an inserter blocked on the ratio when the shard stops is let through and counted
  std::atomic<bool> done{false};
  std::thread inserter([&] { done = l.AwaitInsert(100, 600, 10s); });
  std::this_thread::sleep_for(30ms);
  EXPECT_FALSE(done.load());
  auto t0 = Clock::now();
  l.Close();
  inserter.join();
  EXPECT_TRUE(done.load());
  EXPECT_LT(Clock::now() - t0, 1s);
  // later inserts (batches drained from DDS after the stop) do not wait either
  EXPECT_TRUE(l.AwaitInsert(100, 700, 0ms));
  EXPECT_EQ(l.counters().inserted, 800u);
  EXPECT_FALSE(l.AwaitSample(
      1, [] { return int64_t(800); }, 0ms));
  EXPECT_EQ(l.counters().sampled, 0u);
}

TEST(RateLimiter, RestoreClampsCountersIntoANewWindow) {
  RateLimiter l({10, 1.0, 100});
  l.Restore({1'000'000, 0});  // an old run that inserted far ahead
  EXPECT_TRUE(l.CanSample(1, 1000));
  EXPECT_TRUE(l.CanInsert(1, 1000) || l.CanSample(100, 1000));  // one side can always move
  RateLimiterCounters c = l.counters();
  EXPECT_LE(double(c.inserted) - double(c.sampled), 110.0);
}

}  // namespace
}  // namespace coins
