#pragma once
/// A counting semaphore whose timed wait runs on CLOCK_MONOTONIC. The queue library's own
/// timed waits compute an absolute CLOCK_REALTIME deadline for sem_timedwait, so a step of the
/// wall clock during a wait (NTP or GPS correcting it when the vehicle surfaces) stretches the
/// wait by the step, or cuts it short. sem_clockwait (glibc 2.30) takes the monotonic clock.
#include <semaphore.h>
#include <time.h>

#include <cerrno>
#include <chrono>
#include <cstdint>

namespace seavio::daemon {

class MonotonicSemaphore {
 public:
  explicit MonotonicSemaphore(unsigned initial = 0) { sem_init(&sem_, 0, initial); }
  ~MonotonicSemaphore() { sem_destroy(&sem_); }
  MonotonicSemaphore(const MonotonicSemaphore&) = delete;
  MonotonicSemaphore& operator=(const MonotonicSemaphore&) = delete;

  void signal() { sem_post(&sem_); }

  /// Takes one count if there is one, without waiting.
  bool tryWait() {
    while (sem_trywait(&sem_) != 0) {
      if (errno != EINTR) return false;
    }
    return true;
  }

  /// Takes one count, waiting at most `timeout` of monotonic time. False on timeout.
  bool waitFor(std::chrono::nanoseconds timeout) {
    if (tryWait()) return true;
    if (timeout.count() <= 0) return false;
    timespec deadline{};
    clock_gettime(CLOCK_MONOTONIC, &deadline);
    const int64_t ns = static_cast<int64_t>(deadline.tv_nsec) + timeout.count() % 1'000'000'000;
    deadline.tv_sec += static_cast<time_t>(timeout.count() / 1'000'000'000 + ns / 1'000'000'000);
    deadline.tv_nsec = static_cast<long>(ns % 1'000'000'000);
    for (;;) {
      if (sem_clockwait(&sem_, CLOCK_MONOTONIC, &deadline) == 0) return true;
      if (errno != EINTR) return false;
    }
  }

 private:
  sem_t sem_;
};

}  // namespace seavio::daemon
