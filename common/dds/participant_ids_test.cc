// Participant ids and the shared-memory ports a killed process leaves behind: a new participant
// never takes an id whose ports carry a lock file, and the zombie cleanup removes unlocked ports
// only. The participants are real Fast DDS participants on a leased domain, so the port numbers
// are checked against the files Fast DDS itself creates.
#include "common/dds/participant_ids.h"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <set>
#include <string>
#include <vector>

#include "common/dds/domain_lease.h"
#include "common/dds/node.h"

namespace coins::dds {
namespace {

bool Exists(const std::string& path) { return ::access(path.c_str(), F_OK) == 0; }

// the lock file of participant `id`'s metatraffic (offset 10) or user (offset 11) unicast port
std::string PortLock(int domain, int id, int offset) {
  return SharedMemoryPortFiles(kPortBase + kDomainGain * domain + offset + 2 * id).lock;
}

// what a process killed -9 leaves: the lock file, unlocked
void LeaveZombie(const std::string& lock) {
  int fd = ::open(lock.c_str(), O_CREAT | O_RDWR, 0666);
  ASSERT_GE(fd, 0) << lock;
  ::close(fd);
}

std::unique_ptr<Node> MakeNode(int domain) {
  DdsOptions o;
  o.domain = domain;
  auto n = Node::Create(o, "participant-ids-test");
  EXPECT_TRUE(n.ok()) << n.status().message();
  return n.ok() ? std::move(*n) : nullptr;
}

// a child process: waits for `go` to close, creates a participant on `domain`, reports its id
// and keeps the participant until `hold` closes
[[noreturn]] void ParticipantChild(int domain, int go, int report, int hold) {
  char c;
  while (::read(go, &c, 1) > 0) {
  }
  DdsOptions o;
  o.domain = uint32_t(domain);
  auto node = Node::Create(o, "participant-ids-child");
  const int id = node.ok() ? (*node)->participant_id() : -2;
  if (::write(report, &id, sizeof(id)) != ssize_t(sizeof(id))) _exit(3);
  while (::read(hold, &c, 1) > 0) {
  }
  _exit(0);
}

// Processes that create their participants at the same moment (a launcher's children) get
// distinct ids (before the machine-wide lock they all took id 0 and regenerated each other's
// shared-memory ports). The test process must not have started Fast DDS's threads when it forks:
// ctest runs each test in a process of its own, and this one is the first of its file.
TEST(ParticipantIds, ProcessesStartingTogetherNeverShareAnId) {
  auto lease = DomainLease::Acquire();
  ASSERT_TRUE(lease.ok()) << lease.status().message();
  const int d = lease->domain();
  int go[2], report[2], hold[2];
  ASSERT_EQ(::pipe(go), 0);
  ASSERT_EQ(::pipe(report), 0);
  ASSERT_EQ(::pipe(hold), 0);
  const int n = 8;
  std::vector<pid_t> children;
  for (int i = 0; i < n; ++i) {
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      ::close(go[1]);
      ::close(report[0]);
      ::close(hold[1]);
      ParticipantChild(d, go[0], report[1], hold[0]);
    }
    children.push_back(pid);
  }
  ::close(go[0]);
  ::close(report[1]);
  ::close(hold[0]);
  ::close(go[1]);  // all of them start now
  std::multiset<int> ids;
  for (int i = 0; i < n; ++i) {
    int id = -1;
    ASSERT_EQ(::read(report[0], &id, sizeof(id)), ssize_t(sizeof(id)));
    ids.insert(id);
  }
  ::close(hold[1]);
  for (pid_t p : children) {
    int status = 0;
    ASSERT_EQ(::waitpid(p, &status, 0), p);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  }
  std::string all;
  for (int id : ids) all += std::to_string(id) + " ";
  EXPECT_EQ(std::set<int>(ids.begin(), ids.end()).size(), size_t(n)) << "ids: " << all;
  EXPECT_EQ(ids.count(-1) + ids.count(-2), 0u) << "ids: " << all;
}

TEST(ParticipantIds, ANewParticipantSkipsTheIdsOfKilledProcessesPorts) {
  auto lease = DomainLease::Acquire();
  ASSERT_TRUE(lease.ok()) << lease.status().message();
  const int d = lease->domain();
  LeaveZombie(PortLock(d, 0, 10));  // id 0: its metatraffic port
  LeaveZombie(PortLock(d, 1, 11));  // id 1: its user port

  auto first = MakeNode(d);
  ASSERT_TRUE(first);
  EXPECT_EQ(first->participant_id(), 2);
  // Fast DDS listens on exactly the port the id stands for (shared memory carries user data only;
  // local discovery is on a UDP port, common/dds/discovery.h)
  EXPECT_FALSE(Exists(PortLock(d, 2, 10)));
  EXPECT_TRUE(Exists(PortLock(d, 2, 11)));

  auto second = MakeNode(d);
  ASSERT_TRUE(second);
  EXPECT_EQ(second->participant_id(), 3);

  // a clean close removes the lock files, and the id is taken again
  first.reset();
  EXPECT_FALSE(Exists(PortLock(d, 2, 11)));
  auto third = MakeNode(d);
  ASSERT_TRUE(third);
  EXPECT_EQ(third->participant_id(), 2);
  RemoveStaleSharedMemoryPorts(d);
}

TEST(ParticipantIds, TheZombieCleanupLeavesLivePortsAlone) {
  auto lease = DomainLease::Acquire();
  ASSERT_TRUE(lease.ok()) << lease.status().message();
  const int d = lease->domain();
  auto live = MakeNode(d);
  ASSERT_TRUE(live);
  const int id = live->participant_id();
  ASSERT_GE(id, 0);
  LeaveZombie(PortLock(d, id + 1, 10));
  LeaveZombie(PortLock(d, id + 2, 11));

  EXPECT_EQ(RemoveZombieSharedMemoryPorts(d), 2);
  EXPECT_FALSE(Exists(PortLock(d, id + 1, 10)));
  EXPECT_FALSE(Exists(PortLock(d, id + 2, 11)));
  EXPECT_TRUE(Exists(PortLock(d, id, 11)));  // held by the live participant
  EXPECT_EQ(RemoveZombieSharedMemoryPorts(d), 0);
}

TEST(ParticipantIds, EveryIdTakenGivesMinusOne) {
  auto lease = DomainLease::Acquire();  // no port files on it: only the in-process bookkeeping counts
  ASSERT_TRUE(lease.ok()) << lease.status().message();
  const int d = lease->domain();
  std::vector<int> ids;
  for (int i = 0; i < 3; ++i) ids.push_back(TakeParticipantId(d, 3));
  EXPECT_EQ(TakeParticipantId(d, 3), -1);
  ReleaseParticipantId(d, ids[1]);
  EXPECT_EQ(TakeParticipantId(d, 3), ids[1]);
  for (int id : ids) ReleaseParticipantId(d, id);
}

}  // namespace
}  // namespace coins::dds
