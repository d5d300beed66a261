// pthread_mutex_clocklock for ThreadSanitizer builds (linked into every target only when
// COINS_SANITIZE=thread).
//
// Debian's libtsan intercepts pthread_mutex_timedlock but not pthread_mutex_clocklock, which
// glibc 2.30+ offers and which libstdc++'s timed mutexes (and through them Fast DDS) call. A
// mutex taken that way is invisible to the sanitizer, so it reports unlocks of unlocked mutexes,
// lock-order inversions and races on everything such a mutex guards. This definition comes
// before libc's in the symbol search order and takes the lock through pthread_mutex_timedlock,
// which the sanitizer does see. The deadline is moved from `clock` to CLOCK_REALTIME once; a
// jump of the real-time clock while waiting only lengthens or shortens that one wait.
#include <errno.h>
#include <pthread.h>
#include <time.h>

namespace {

constexpr long kNanosPerSecond = 1'000'000'000L;

timespec RealtimeDeadline(clockid_t clock, const timespec& deadline) {
  timespec now_clock{}, now_real{};
  clock_gettime(clock, &now_clock);
  clock_gettime(CLOCK_REALTIME, &now_real);
  long long left_ns = (static_cast<long long>(deadline.tv_sec) - now_clock.tv_sec) * kNanosPerSecond +
                      (deadline.tv_nsec - now_clock.tv_nsec);
  if (left_ns < 0) left_ns = 0;
  long long real_ns = static_cast<long long>(now_real.tv_nsec) + left_ns % kNanosPerSecond;
  timespec out{};
  out.tv_sec = now_real.tv_sec + static_cast<time_t>(left_ns / kNanosPerSecond + real_ns / kNanosPerSecond);
  out.tv_nsec = static_cast<long>(real_ns % kNanosPerSecond);
  return out;
}

}  // namespace

extern "C" int pthread_mutex_clocklock(pthread_mutex_t* mutex, clockid_t clock, const timespec* deadline) {
  if (deadline == nullptr || deadline->tv_nsec < 0 || deadline->tv_nsec >= kNanosPerSecond) return EINVAL;
  if (clock != CLOCK_REALTIME && clock != CLOCK_MONOTONIC) return EINVAL;
  if (clock == CLOCK_REALTIME) return pthread_mutex_timedlock(mutex, deadline);
  const timespec real = RealtimeDeadline(clock, *deadline);
  return pthread_mutex_timedlock(mutex, &real);
}
