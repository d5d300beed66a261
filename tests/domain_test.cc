// DDS domains of concurrent tests: two live tests (or two clusters of one test) never share a
// domain, and a domain stays taken while any process started on it is alive.
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include "tests/process_harness.h"

namespace coins {
namespace {

using namespace coins::testing;

TEST(TestDomains, TwoCallsOfOneProcessGetTwoDomains) {
  // the same salt twice: a domain derived from the pid and the salt was the same both times
  int a = TestDomain(3), b = TestDomain(3);
  EXPECT_NE(a, b);
  for (int d : {a, b}) {
    EXPECT_GE(d, dds::kLeaseFirst);
    EXPECT_LE(d, dds::kLeaseLast);
  }
}

// a child process that takes a lease, writes its domain to `report` and holds the lease until
// the write end of the `hold` pipe is closed
pid_t StartHolder(int report, const int hold[2]) {
  pid_t pid = fork();
  if (pid != 0) return pid;
  close(hold[1]);
  auto lease = dds::DomainLease::Acquire();
  int domain = lease.ok() ? lease->domain() : -1;
  if (write(report, &domain, sizeof(domain)) != sizeof(domain)) _exit(3);
  char c;
  while (read(hold[0], &c, 1) > 0) {
  }
  _exit(lease.ok() ? 0 : 2);
}

TEST(TestDomains, ConcurrentProcessesNeverShareADomain) {
  int report[2], hold[2];
  ASSERT_EQ(pipe(report), 0);
  ASSERT_EQ(pipe(hold), 0);
  const int n = 24;
  std::vector<pid_t> children;
  for (int i = 0; i < n; ++i) children.push_back(StartHolder(report[1], hold));
  close(hold[0]);
  std::multiset<int> domains;
  for (int i = 0; i < n; ++i) {
    int d = -1;
    ASSERT_EQ(read(report[0], &d, sizeof(d)), ssize_t(sizeof(d)));
    domains.insert(d);
  }
  close(hold[1]);  // the holders end
  for (pid_t p : children) {
    int status = 0;
    ASSERT_EQ(waitpid(p, &status, 0), p);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  }
  EXPECT_EQ(std::set<int>(domains.begin(), domains.end()).size(), size_t(n)) << "two live holders shared a domain";
  EXPECT_EQ(domains.count(-1), 0u);
}

TEST(TestDomains, AChildKeepsTheDomainAfterItsParentLetsGo) {
  auto lease = dds::DomainLease::Acquire();
  ASSERT_TRUE(lease.ok()) << lease.status().message();
  const int domain = lease->domain();
  int hold[2];
  ASSERT_EQ(pipe(hold), 0);
  pid_t child = fork();
  if (child == 0) {
    close(hold[1]);
    char c;
    while (read(hold[0], &c, 1) > 0) {
    }
    _exit(0);
  }
  close(hold[0]);
  { auto gone = std::move(*lease); }  // the parent lets go; the child still holds the descriptor
  auto again = dds::DomainLease::AcquireExactly(domain);
  EXPECT_FALSE(again.ok()) << "a domain was handed out while a process started on it was alive";
  if (!again.ok()) {
    EXPECT_NE(again.status().message().find("in use"), std::string::npos) << again.status().message();
  }
  close(hold[1]);
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  auto after = dds::DomainLease::AcquireExactly(domain);
  EXPECT_TRUE(after.ok()) << after.status().message();
}

// the shared-memory port files a killed process left on a domain are gone once the domain is
// leased again; a file whose name only starts like a port's stays
TEST(TestDomains, ALeaseRemovesTheSharedMemoryPortsKilledProcessesLeft) {
  auto first = dds::DomainLease::Acquire();
  ASSERT_TRUE(first.ok()) << first.status().message();
  const int domain = first->domain();
  const int base = dds::kPortBase + dds::kDomainGain * domain;
  const std::string dir = dds::kSharedMemoryDir;
  const std::vector<std::string> stale = {dir + "/fastrtps_port" + std::to_string(base),
                                          dir + "/fastrtps_port" + std::to_string(base + 12) + "_el",
                                          dir + "/sem.fastrtps_port" + std::to_string(base + 12) + "_mutex",
                                          dir + "/fastrtps_port" + std::to_string(base + dds::kDomainGain - 1)};
  // a name of the range's form that no domain's port has: stays
  const std::string other = dir + "/fastrtps_port" + std::to_string(base) + "x";
  for (const auto& f : stale) std::ofstream(f) << "left by a killed participant";
  std::ofstream(other) << "not a port";
  auto another = dds::DomainLease::Acquire();
  ASSERT_TRUE(another.ok()) << another.status().message();
  *first = std::move(*another);  // lets `domain` go; just leased, it is the last one others pick
  auto again = dds::DomainLease::AcquireExactly(domain);
  ASSERT_TRUE(again.ok()) << again.status().message();
  for (const auto& f : stale) EXPECT_FALSE(std::filesystem::exists(f)) << f;
  EXPECT_TRUE(std::filesystem::exists(other));
  std::filesystem::remove(other);
  EXPECT_EQ(dds::RemoveStaleSharedMemoryPorts(domain), 0);
}

}  // namespace
}  // namespace coins
