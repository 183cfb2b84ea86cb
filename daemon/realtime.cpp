#include "daemon/realtime.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <exception>
#include <string>
#include <vector>

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

namespace {

bool isFramePath(ThreadRole role) {
  return role == ThreadRole::kImuReader || role == ThreadRole::kCameraReader || role == ThreadRole::kFramePath ||
         role == ThreadRole::kPublisher;
}

/// Priority offset from the estimator's: IMU reader +2, camera reader +1, publisher -1.
int frameRank(ThreadRole role) {
  switch (role) {
    case ThreadRole::kImuReader: return 2;
    case ThreadRole::kCameraReader: return 1;
    case ThreadRole::kPublisher: return -1;
    default: return 0;
  }
}

SchedulingOutcome applyFramePath(ThreadRole role, const RealtimeConfig& config, const std::string& thread) {
  SchedulingOutcome out;
  const int rank = frameRank(role);
  if (config.priority <= 0) {
    int policy = 0;
    sched_param cur{};
    pthread_getschedparam(pthread_self(), &policy, &cur);
    if (policy != SCHED_FIFO && policy != SCHED_RR) {
      out.ok = true;
      out.message = thread + ": " + describeThreadScheduling() + " (inherited; daemon.realtime.priority 0)";
      return out;
    }
    // Inherited real-time priority Q (the IMU reader's): the others lower themselves below
    // it by role, which needs no privilege (sched_setparam, not a policy change).
    const int target = std::max(1, cur.sched_priority - (2 - rank));
    const int err = target == cur.sched_priority ? 0 : pthread_setschedprio(pthread_self(), target);
    out.ok = err == 0;
    out.message = thread + ": " + describeThreadScheduling() +
                  (out.ok ? " (inherited " + std::to_string(cur.sched_priority) + ", by role)"
                          : " (lowering to " + std::to_string(target) + " refused: " + std::strerror(err) + ")");
    return out;
  }
  const int priority = std::clamp(config.priority + rank, 1, 98);
  sched_param p{};
  p.sched_priority = priority;
  const int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &p);
  out.ok = err == 0;
  out.message = out.ok ? thread + ": " + describeThreadScheduling()
                       : thread + ": SCHED_FIFO " + std::to_string(priority) + " refused (" + std::strerror(err) +
                             "): needs CAP_SYS_NICE or RLIMIT_RTPRIO >= " + std::to_string(priority) + " (now " +
                             limitText(RLIMIT_RTPRIO) +
                             "); under systemd set CPUSchedulingPolicy=fifo instead; thread stays " +
                             describeThreadScheduling();
  return out;
}

SchedulingOutcome applyBackground(ThreadRole role, const RealtimeConfig& config, const std::string& thread) {
  // Leave any real-time policy inherited from the process (systemd, chrt) and give way to
  // everything else. Lowering one's own priority needs no privilege.
  SchedulingOutcome out;
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
  // Status and recording give way to the ICP thread too.
  const int wanted = role == ThreadRole::kStatus ? std::min(19, config.background_nice + 5) : config.background_nice;
  // Never raise a nice value the process was started with (that would need privilege).
  const int nice = std::max(errno == 0 ? current : 0, wanted);
  if (setpriority(PRIO_PROCESS, tid, nice) != 0) {
    out.message = thread + ": nice " + std::to_string(nice) + " refused (" + std::strerror(errno) + "); thread is " +
                  describeThreadScheduling();
    return out;
  }
  out.ok = true;
  out.message = thread + ": " + describeThreadScheduling();
  return out;
}

/// Pins the calling thread to `cpus`; empty string, or why not.
std::string pinTo(const std::vector<int>& cpus) {
  cpu_set_t set;
  CPU_ZERO(&set);
  for (int c : cpus)
    if (c >= 0 && c < CPU_SETSIZE) CPU_SET(c, &set);
  const int err = pthread_setaffinity_np(pthread_self(), sizeof set, &set);
  return err == 0 ? std::string() : std::string("CPU affinity refused (") + std::strerror(err) + ")";
}

std::string cpuText(const std::vector<int>& cpus) {
  std::string s;
  for (int c : cpus) {
    if (!s.empty()) s += ',';
    s += std::to_string(c);
  }
  return s;
}

}  // namespace

SchedulingOutcome applyThreadRole(ThreadRole role, const RealtimeConfig& config, const std::string& thread) {
  const bool frame = isFramePath(role);
  SchedulingOutcome out = frame ? applyFramePath(role, config, thread) : applyBackground(role, config, thread);
  const std::vector<int>& cpus = frame ? config.frame_cpus : config.background_cpus;
  if (!cpus.empty()) {
    const std::string err = pinTo(cpus);
    out.ok = out.ok && err.empty();
    out.message += err.empty() ? ", CPUs " + cpuText(cpus) : "; " + err;
  }
  return out;
}

SchedulingOutcome lockAllMemory() {
  SchedulingOutcome out;
  // MCL_ONFAULT: a page is locked when first touched instead of every mapping being faulted
  // in at once; locking the 8 MB stack of each thread up front made the first frame late.
  int rc = mlockall(MCL_CURRENT | MCL_FUTURE | MCL_ONFAULT);
  if (rc != 0 && errno == EINVAL) rc = mlockall(MCL_CURRENT | MCL_FUTURE);  // kernel before 4.4
  if (rc == 0) {
    out.ok = true;
    out.message = "memory locked (mlockall, on fault): no page faults on the frame path after warm-up";
    return out;
  }
  out.message = std::string("mlockall refused (") + std::strerror(errno) + "): needs RLIMIT_MEMLOCK (now " +
                limitText(RLIMIT_MEMLOCK) + " bytes; LimitMEMLOCK=infinity in the unit) or CAP_IPC_LOCK; memory stays pageable";
  return out;
}

}  // namespace seavio::daemon
