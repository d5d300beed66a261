// DomainLease: a DDS domain held exclusively, for tests and benchmarks that start processes of
// their own on a private domain.
//
// Two live holders never share a domain: a lease is an exclusive flock() on the file
// <dir>/domain-<d>.lock (dir: $COINS_DOMAIN_LOCK_DIR or /tmp/coins-dds-domains), taken without
// blocking, and released when the lease is destroyed or the process ends (the kernel drops the
// lock, so a crashed holder never leaks a domain). The descriptor is inherited by children
// (no close-on-exec): a child that outlives its test keeps the domain locked while it can still
// talk on it. Leases come from kLeaseFirst..kLeaseLast, a range kept apart from the domains
// users run on (0 .. kLeaseFirst - 1; the default is 0).
#pragma once

#include <string>

#include "common/status.h"

namespace coins::dds {

inline constexpr int kLeaseFirst = 120;
inline constexpr int kLeaseLast = 219;

// Fast DDS's well-known ports: domain d owns [kPortBase + kDomainGain * d, ... + kDomainGain)
inline constexpr int kPortBase = 7400;
inline constexpr int kDomainGain = 250;
inline constexpr const char* kSharedMemoryDir = "/dev/shm";

// the files of shared-memory port `port`: its segment, its lock file (held while a participant
// listens on it) and its mutex
struct SharedMemoryPortFiles {
  explicit SharedMemoryPortFiles(int port);
  std::string segment, lock, mutex;
};

// Removes the shared-memory port files of `domain`'s ports (fastrtps_portN, its _el lock and
// its sem.fastrtps_portN_mutex) and returns how many files went. A process killed -9 leaves
// its ports behind, sometimes with their mutex held; Fast DDS 2.9 then lets a later participant
// that takes over such a port hang or go unheard (seen: a test's actors matched with nobody, or
// the orchestrator's commands reaching no one, for the whole test). Only safe while no live
// process uses the domain: a lease calls it when it takes the domain, since every process that
// used the domain under an earlier lease has ended (the lock is held by them all until then).
int RemoveStaleSharedMemoryPorts(int domain);

class DomainLease {
 public:
  // the least recently leased free domain of [first, last] (ties: from a per-process starting point);
  // an error names the lock directory when none is free or it cannot be used
  static Result<DomainLease> Acquire(int first = kLeaseFirst, int last = kLeaseLast);
  // takes one given domain; an error when another process holds it
  static Result<DomainLease> AcquireExactly(int domain);
  // for a tool that starts processes of its own (the benchmarks): `requested` < 0 leases a free
  // domain; a requested domain in the lease range is leased exactly (an error when held); any
  // other is used as given, without a lock (the user's own domains)
  static Result<DomainLease> Choose(int requested);

  DomainLease(DomainLease&& o) noexcept : domain_(o.domain_), fd_(o.fd_) { o.fd_ = -1; }
  DomainLease& operator=(DomainLease&& o) noexcept;
  DomainLease(const DomainLease&) = delete;
  DomainLease& operator=(const DomainLease&) = delete;
  ~DomainLease();

  int domain() const { return domain_; }
  // the directory holding the lock files
  static std::string LockDir();

 private:
  DomainLease(int domain, int fd) : domain_(domain), fd_(fd) {}
  int domain_ = -1;
  int fd_ = -1;
};

}  // namespace coins::dds
