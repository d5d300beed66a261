#include "orchestrator/run_queue.h"

#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <set>
#include <thread>

#include <gtest/gtest.h>

namespace coins {
namespace {

using namespace std::chrono_literals;

TEST(RunQueue, WithoutDomainsRunsEveryJobInOrderOnItsOwnDomain) {
  std::vector<size_t> order;
  Status s = RunQueue(4, {}, [&](size_t job, std::optional<int> domain) {
    EXPECT_FALSE(domain.has_value());
    order.push_back(job);
    return Status::Ok();
  });
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(order, (std::vector<size_t>{0, 1, 2, 3}));
}

// jobs that overlap in time: at most one per domain, never two on one domain at once
TEST(RunQueue, RunsOneJobPerDomainAtOnceAndEveryJobOnce) {
  std::mutex mu;
  std::map<int, int> live;  // domain -> jobs running on it
  int most_live = 0, running = 0;
  std::multiset<size_t> ran;
  Status s = RunQueue(7, {81, 82, 83}, [&](size_t job, std::optional<int> domain) {
    EXPECT_TRUE(domain.has_value());
    {
      std::lock_guard<std::mutex> lock(mu);
      EXPECT_EQ(++live[*domain], 1) << "two live runs on domain " << *domain;
      most_live = std::max(most_live, ++running);
      ran.insert(job);
    }
    std::this_thread::sleep_for(30ms);
    std::lock_guard<std::mutex> lock(mu);
    --live[*domain];
    --running;
    return Status::Ok();
  });
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(ran, (std::multiset<size_t>{0, 1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(most_live, 3) << "three domains: three runs at once";
}

// after a failure no new job starts; the one already running ends; the first error comes back
TEST(RunQueue, AFailureStartsNoNewJobButLetsRunningOnesEnd) {
  std::atomic<int> started{0}, finished{0};
  Status s = RunQueue(10, {1, 2}, [&](size_t job, std::optional<int>) -> Status {
    ++started;
    if (job == 0) {  // fails once job 1 runs
      for (int i = 0; i < 500 && started.load() < 2; ++i) std::this_thread::sleep_for(10ms);
      return Errorf("run 0 failed");
    }
    std::this_thread::sleep_for(100ms);  // job 1, already running when job 0 fails
    ++finished;
    return Status::Ok();
  });
  EXPECT_FALSE(s.ok());
  EXPECT_EQ(s.message(), "run 0 failed");
  EXPECT_EQ(started.load(), 2) << "jobs 0 and 1 only";
  EXPECT_EQ(finished.load(), 1) << "job 1 ran to its end";
}

TEST(RunQueue, FewerJobsThanDomains) {
  std::atomic<int> ran{0};
  ASSERT_TRUE(RunQueue(1, {5, 6, 7}, [&](size_t, std::optional<int>) { return ++ran, Status::Ok(); }).ok());
  EXPECT_EQ(ran.load(), 1);
  EXPECT_TRUE(RunQueue(0, {5}, [&](size_t, std::optional<int>) { return ++ran, Status::Ok(); }).ok());
  EXPECT_EQ(ran.load(), 1);
}

TEST(CheckDomains, NamesAnIdOutOfRangeOrListedTwice) {
  EXPECT_TRUE(CheckDomains({}).ok());
  EXPECT_TRUE(CheckDomains({0, 81, 232}).ok());
  Status high = CheckDomains({81, 233});
  ASSERT_FALSE(high.ok());
  EXPECT_NE(high.message().find("233"), std::string::npos) << high.message();
  Status twice = CheckDomains({81, 82, 81});
  ASSERT_FALSE(twice.ok());
  EXPECT_NE(twice.message().find("81 is listed twice"), std::string::npos) << twice.message();
  EXPECT_FALSE(CheckDomains({-1}).ok());
}

}  // namespace
}  // namespace coins
