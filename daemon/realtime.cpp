#include "daemon/realtime.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace seavio::daemon {

namespace {

std::string policyName(int policy) {
  switch (policy) {
    case SCHED_OTHER: return "SCHED_OTHER";
    case SCHED_BATCH: return "SCHED_BATCH";
    case SCHED_IDLE: return "SCHED_IDLE";
    case SCHED_FIFO: return "SCHED_FIFO";
    case SCHED_RR: return "SCHED_RR";
    default: return "policy " + std::to_string(policy);
  }
}

std::string limitText(int resource) {
  rlimit l{};
  if (getrlimit(resource, &l) != 0) return "unknown";
  if (l.rlim_cur == RLIM_INFINITY) return "unlimited";
  return std::to_string(static_cast<unsigned long long>(l.rlim_cur));
}

}  // namespace

std::string describeThreadScheduling() {
  int policy = 0;
  sched_param p{};
  if (pthread_getschedparam(pthread_self(), &policy, &p) != 0) return "unknown";
  if (policy == SCHED_FIFO || policy == SCHED_RR) return policyName(policy) + " " + std::to_string(p.sched_priority);
  errno = 0;
  const int nice = getpriority(PRIO_PROCESS, static_cast<id_t>(gettid()));
  return policyName(policy) + " nice " + std::to_string(errno == 0 ? nice : 0);
}

SchedulingOutcome applyThreadRole(ThreadRole role, const RealtimeConfig& config, const std::string& thread) {
  SchedulingOutcome out;
  if (role == ThreadRole::kFramePath) {
    if (config.priority <= 0) {
      out.ok = true;
      out.message = thread + ": " + describeThreadScheduling() + " (inherited; daemon.realtime.priority 0)";
      return out;
    }
    sched_param p{};
    p.sched_priority = config.priority;
    const int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &p);
    out.ok = err == 0;
    out.message = out.ok ? thread + ": " + describeThreadScheduling()
                         : thread + ": SCHED_FIFO " + std::to_string(config.priority) + " refused (" +
                               std::strerror(err) + "): needs CAP_SYS_NICE or RLIMIT_RTPRIO >= " +
                               std::to_string(config.priority) + " (now " + limitText(RLIMIT_RTPRIO) +
                               "); under systemd set CPUSchedulingPolicy=fifo instead; thread stays " +
                               describeThreadScheduling();
    return out;
  }
  // Background: leave any real-time policy inherited from the process (systemd, chrt) and
  // give way to everything else. Lowering one's own priority needs no privilege.
  sched_param p{};
  p.sched_priority = 0;
  const int err = pthread_setschedparam(pthread_self(), SCHED_BATCH, &p);
  if (err != 0) {
    out.message = thread + ": SCHED_BATCH refused (" + std::string(std::strerror(err)) + "); thread stays " +
                  describeThreadScheduling();
    return out;
  }
  const id_t tid = static_cast<id_t>(gettid());
  errno = 0;
  const int current = getpriority(PRIO_PROCESS, tid);
  // Never raise a nice value the process was started with (that would need privilege).
  const int nice = std::max(errno == 0 ? current : 0, config.background_nice);
  if (setpriority(PRIO_PROCESS, tid, nice) != 0) {
    out.message = thread + ": nice " + std::to_string(nice) + " refused (" + std::strerror(errno) + "); thread is " +
                  describeThreadScheduling();
    return out;
  }
  out.ok = true;
  out.message = thread + ": " + describeThreadScheduling();
  return out;
}

SchedulingOutcome lockAllMemory() {
  SchedulingOutcome out;
  if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
    out.ok = true;
    out.message = "memory locked (mlockall): no page faults on the frame path after warm-up";
    return out;
  }
  out.message = std::string("mlockall refused (") + std::strerror(errno) + "): needs RLIMIT_MEMLOCK (now " +
                limitText(RLIMIT_MEMLOCK) + " bytes; LimitMEMLOCK=infinity in the unit) or CAP_IPC_LOCK; memory stays pageable";
  return out;
}

}  // namespace seavio::daemon
