// Participant ids that never land on a port a killed process left behind.
//
// A participant's id fixes its two unicast ports (metatraffic kPortBase + kDomainGain * d + 10 +
// 2 * id, user data + 11 + 2 * id) and with them its shared-memory port files
// /dev/shm/fastrtps_portN (the user data port's only, with local discovery, whose metatraffic is
// on UDP: common/dds/discovery.h). A live port holds a lock file fastrtps_portN_el; a clean close removes
// it, a process killed -9 leaves it behind unlocked (a "zombie" port).
//
// Fast DDS 2.9 gives a process's participants the lowest ids the process has not used, so a
// restarted process takes the killed one's id. Opening the zombie port then deletes its segment
// and creates a new one, while every live participant that wrote to the killed process keeps its
// mapping of the deleted segment and goes on writing there: the restarted process never hears
// them, discovery included (the actor's stalled transition stream of the replay tests, the
// upstream fix is not in 2.9). A participant that takes an id whose ports carry no lock file
// never meets that segment.
//
// Choosing an id and opening its ports must be one step across processes: processes started
// together (a launcher's children) would otherwise all see the same lowest id free, and the
// second to open that id's shared-memory port regenerates the first one's segment, which is
// then never heard (seen: a secured run whose two actors matched nobody for minutes, since a
// secured participant takes ~0.1 s from the choice to its ports). ParticipantIdLock makes it one.
#pragma once

#include <chrono>

namespace coins::dds {

// A machine-wide exclusive lock of one domain's participant ids (flock on a file in /dev/shm),
// to be held from TakeParticipantId until the new participant has opened its ports. Waits at
// most `wait` for another holder; without the lock after that (or without /dev/shm), held() is
// false and the caller goes on unlocked. Not inherited by child processes.
class ParticipantIdLock {
 public:
  explicit ParticipantIdLock(int domain, std::chrono::milliseconds wait = std::chrono::seconds(20));
  ~ParticipantIdLock();
  ParticipantIdLock(const ParticipantIdLock&) = delete;
  ParticipantIdLock& operator=(const ParticipantIdLock&) = delete;
  bool held() const { return fd_ >= 0; }

 private:
  int fd_ = -1;
};

// ids a participant may take: local and peers discovery announce to the ports of this many ids,
// and id 119's ports are the last inside a domain's port range (kDomainGain)
inline constexpr int kParticipantIdLimit = 120;

// the lowest id in [0, limit) whose two ports have no lock file on this machine (no live and no
// killed participant holds them) and that no participant of this process holds; the id is then
// held until ReleaseParticipantId. -1 when every id is taken (Fast DDS then picks one itself).
int TakeParticipantId(int domain, int limit = kParticipantIdLimit);
void ReleaseParticipantId(int domain, int id);

// Removes the port files of `domain` whose lock file is present but unlocked (ports of killed
// processes), so that killed processes do not use up the ids; live ports are left alone. Only
// safe when no live process keeps writing to a killed one's port: a launcher calls it before it
// starts the processes of a run (runs on one machine use distinct domains). Returns the number
// of ports removed.
int RemoveZombieSharedMemoryPorts(int domain);

}  // namespace coins::dds
