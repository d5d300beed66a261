#include "common/dds/domain_lease.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <utility>
#include <vector>

namespace coins::dds {

namespace {

// opens the lock file of `domain` (created world-writable, so users share the directory);
// -1 with errno on failure
int OpenLockFile(const std::string& dir, int domain) {
  std::string path = dir + "/domain-" + std::to_string(domain) + ".lock";
  // no O_CLOEXEC: children keep the lease (see the header)
  int fd = ::open(path.c_str(), O_RDONLY | O_CREAT, 0666);
  if (fd >= 0) ::fchmod(fd, 0666);
  return fd;
}

// an exclusive lock without waiting; false when another process holds it
bool TryLock(int fd) {
  while (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    if (errno != EINTR) return false;
  }
  return true;
}

Status EnsureDir(const std::string& dir) {
  if (::mkdir(dir.c_str(), 01777) == 0) {
    ::chmod(dir.c_str(), 01777);  // past the umask: every user may add lock files
    return Status::Ok();
  }
  if (errno == EEXIST) return Status::Ok();
  return Errorf("DDS domain locks: cannot create {}: {}", dir, std::strerror(errno));
}

}  // namespace

SharedMemoryPortFiles::SharedMemoryPortFiles(int port)
    : segment(std::string(kSharedMemoryDir) + "/fastrtps_port" + std::to_string(port)),
      lock(segment + "_el"),
      mutex(std::string(kSharedMemoryDir) + "/sem.fastrtps_port" + std::to_string(port) + "_mutex") {}

int RemoveStaleSharedMemoryPorts(int domain) {
  const int base = kPortBase + kDomainGain * domain;
  int removed = 0;
  for (int port = base; port < base + kDomainGain; ++port) {
    const SharedMemoryPortFiles files(port);
    for (const std::string* path : {&files.segment, &files.lock, &files.mutex}) removed += ::unlink(path->c_str()) == 0;
  }
  return removed;
}

std::string DomainLease::LockDir() {
  const char* env = std::getenv("COINS_DOMAIN_LOCK_DIR");
  return env && *env ? std::string(env) : std::string("/tmp/coins-dds-domains");
}

Result<DomainLease> DomainLease::Acquire(int first, int last) {
  if (first < 0 || last < first) return Errorf("DDS domain locks: empty range [{}, {}]", first, last);
  const std::string dir = LockDir();
  COINS_RETURN_IF_ERROR(EnsureDir(dir));
  const int n = last - first + 1;
  // the least recently leased domains first (a lease touches its lock file; the ports that
  // killed processes left behind are removed when a domain is leased, see the header). Among
  // equals, processes started together begin at different domains.
  const int start = int((uint64_t(::getpid()) * 7919u) % uint64_t(n));
  std::vector<std::pair<int64_t, int>> order;  // (last lease time, rotation index)
  for (int i = 0; i < n; ++i) {
    const int domain = first + (start + i) % n;
    struct stat st {};
    const std::string path = dir + "/domain-" + std::to_string(domain) + ".lock";
    const int64_t used = ::stat(path.c_str(), &st) == 0 ? int64_t(st.st_mtime) : 0;
    order.emplace_back(used, i);
  }
  std::stable_sort(order.begin(), order.end());
  for (const auto& [used, i] : order) {
    const int domain = first + (start + i) % n;
    int fd = OpenLockFile(dir, domain);
    if (fd < 0) continue;  // e.g. another user's file without write access: skip that domain
    if (TryLock(fd)) {
      ::futimens(fd, nullptr);  // leased now
      RemoveStaleSharedMemoryPorts(domain);
      return DomainLease(domain, fd);
    }
    ::close(fd);
  }
  return Errorf("DDS domain locks: all {} domains {}..{} are held (lock files in {})", n, first, last, dir);
}

Result<DomainLease> DomainLease::AcquireExactly(int domain) {
  const std::string dir = LockDir();
  COINS_RETURN_IF_ERROR(EnsureDir(dir));
  int fd = OpenLockFile(dir, domain);
  if (fd < 0)
    return Errorf("DDS domain locks: cannot open the lock of domain {} in {}: {}", domain, dir, std::strerror(errno));
  if (!TryLock(fd)) {
    ::close(fd);
    return Errorf("DDS domain {} is in use by another test or benchmark (lock {}/domain-{}.lock)", domain, dir, domain);
  }
  RemoveStaleSharedMemoryPorts(domain);
  return DomainLease(domain, fd);
}

Result<DomainLease> DomainLease::Choose(int requested) {
  if (requested < 0) return Acquire();
  if (requested >= kLeaseFirst && requested <= kLeaseLast) return AcquireExactly(requested);
  return DomainLease(requested, -1);
}

DomainLease& DomainLease::operator=(DomainLease&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) ::close(fd_);
    domain_ = o.domain_;
    fd_ = o.fd_;
    o.fd_ = -1;
  }
  return *this;
}

DomainLease::~DomainLease() {
  if (fd_ >= 0) ::close(fd_);
}

}  // namespace coins::dds
