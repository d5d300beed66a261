#include "common/dds/participant_ids.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <utility>

#include "common/dds/domain_lease.h"

namespace coins::dds {

namespace {

// Fast DDS's default port parameters: unicast offsets d1 (metatraffic) and d3 (user data), and
// the participant id gain
constexpr int kMetatrafficUnicastOffset = 10;
constexpr int kUserUnicastOffset = 11;
constexpr int kParticipantIdGain = 2;

std::mutex held_mu;
std::set<std::pair<int, int>> held;  // (domain, id) held by participants of this process

bool Exists(const std::string& path) { return ::access(path.c_str(), F_OK) == 0; }

bool PortsFree(int domain, int id) {
  const int base = kPortBase + kDomainGain * domain + kParticipantIdGain * id;
  return !Exists(SharedMemoryPortFiles(base + kMetatrafficUnicastOffset).lock) &&
         !Exists(SharedMemoryPortFiles(base + kUserUnicastOffset).lock);
}

// true when `path` exists and nobody holds its lock
bool Unlocked(const std::string& path) {
  int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) return false;
  const bool unlocked = ::flock(fd, LOCK_EX | LOCK_NB) == 0;
  ::close(fd);  // drops our lock too
  return unlocked;
}

}  // namespace

ParticipantIdLock::ParticipantIdLock(int domain, std::chrono::milliseconds wait) {
  const std::string path = std::string(kSharedMemoryDir) + "/coins_participant_ids_" + std::to_string(domain) + ".lock";
  const int fd = ::open(path.c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0666);
  if (fd < 0) return;
  const auto deadline = std::chrono::steady_clock::now() + wait;
  while (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    if (std::chrono::steady_clock::now() >= deadline) {
      ::close(fd);
      return;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  fd_ = fd;
}

ParticipantIdLock::~ParticipantIdLock() {
  if (fd_ >= 0) ::close(fd_);  // closing drops the lock
}

int TakeParticipantId(int domain, int limit) {
  std::lock_guard<std::mutex> lock(held_mu);
  for (int id = 0; id < limit; ++id) {
    if (held.count({domain, id}) || !PortsFree(domain, id)) continue;
    held.insert({domain, id});
    return id;
  }
  return -1;
}

void ReleaseParticipantId(int domain, int id) {
  std::lock_guard<std::mutex> lock(held_mu);
  held.erase({domain, id});
}

int RemoveZombieSharedMemoryPorts(int domain) {
  const int base = kPortBase + kDomainGain * domain;
  int removed = 0;
  for (int port = base; port < base + kDomainGain; ++port) {
    const SharedMemoryPortFiles files(port);
    if (!Unlocked(files.lock)) continue;
    ::unlink(files.segment.c_str());
    ::unlink(files.mutex.c_str());
    removed += ::unlink(files.lock.c_str()) == 0;
  }
  return removed;
}

}  // namespace coins::dds
