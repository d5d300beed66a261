// Participant ids and the shared-memory ports a killed process leaves behind: a new participant
// never takes an id whose ports carry a lock file, and the zombie cleanup removes unlocked ports
// only. The participants are real Fast DDS participants on a leased domain, so the port numbers
// are checked against the files Fast DDS itself creates.
#include "common/dds/participant_ids.h"

#include <fcntl.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <string>

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

TEST(ParticipantIds, ANewParticipantSkipsTheIdsOfKilledProcessesPorts) {
  auto lease = DomainLease::Acquire();
  ASSERT_TRUE(lease.ok()) << lease.status().message();
  const int d = lease->domain();
  LeaveZombie(PortLock(d, 0, 10));  // id 0: its metatraffic port
  LeaveZombie(PortLock(d, 1, 11));  // id 1: its user port

  auto first = MakeNode(d);
  ASSERT_TRUE(first);
  EXPECT_EQ(first->participant_id(), 2);
  // Fast DDS listens on exactly the ports the id stands for
  EXPECT_TRUE(Exists(PortLock(d, 2, 10)));
  EXPECT_TRUE(Exists(PortLock(d, 2, 11)));

  auto second = MakeNode(d);
  ASSERT_TRUE(second);
  EXPECT_EQ(second->participant_id(), 3);

  // a clean close removes the lock files, and the id is taken again
  first.reset();
  EXPECT_FALSE(Exists(PortLock(d, 2, 10)));
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
  EXPECT_TRUE(Exists(PortLock(d, id, 10)));  // held by the live participant
  EXPECT_TRUE(Exists(PortLock(d, id, 11)));
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
