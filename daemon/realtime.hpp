#pragma once
/// Scheduling of seaviod's threads (end-to-end latency tail).
///
/// Two roles. The frame path (camera, IMU, estimator, its feature worker, pose publisher)
/// must never wait for a core behind anything else; the background (the global map ICP
/// thread, the status thread) may always wait. Two ways to get the frame path real-time:
///  - systemd sets SCHED_FIFO for the whole service before dropping privileges
///    (`CPUSchedulingPolicy=fifo` in systemd/seaviod.service, no capability needed), or
///    `chrt -f N seaviod ...` by hand; every thread inherits it;
///  - `daemon.realtime.priority: N` makes each frame-path thread SCHED_FIFO N itself, which
///    needs CAP_SYS_NICE or RLIMIT_RTPRIO >= N; refused otherwise, and said so.
/// Either way the background threads demote themselves to SCHED_BATCH at nice
/// `background_nice` (a thread may always lower its own priority), so the global ICP
/// never takes a core from a frame, whatever the process inherited.
///
/// Within the frame path the roles are ordered: the IMU reader above the camera reader above
/// the estimator (and its workers) above the pose publisher, so on two cores a reader never
/// waits a whole estimator stage for its sample and the estimator never waits behind a
/// publish. With `priority` P they get P+2, P+1, P and P-1 (at least 1); under an inherited
/// real-time priority Q (systemd) they lower themselves to Q, Q-1, Q-2 and Q-3, which needs
/// no privilege. Below the frame path: the global ICP thread (SCHED_BATCH at
/// `background_nice`), then status publishing and recording (SCHED_BATCH, 5 nicer).
#include <string>
#include <vector>

namespace seavio::daemon {

struct RealtimeConfig {
  /// SCHED_FIFO priority of the frame-path threads, 1..98; 0 = keep the inherited policy.
  int priority = 0;
  /// Nice value of the background threads (SCHED_BATCH), 0..19.
  int background_nice = 10;
  /// mlockall(MCL_CURRENT | MCL_FUTURE) at start: no page fault on the frame path after
  /// warm-up (needs RLIMIT_MEMLOCK, `LimitMEMLOCK=` in the unit, or CAP_IPC_LOCK). Off in
  /// the struct (tests, tools); the shipped config/seavio.yaml, which the unit runs, sets it.
  bool lock_memory = false;
  /// CPUs the frame-path threads may run on (e.g. {1}: a core kept free of other work);
  /// empty = any.
  std::vector<int> frame_cpus;
  /// CPUs of the ICP, status and recording threads; empty = any.
  std::vector<int> background_cpus;
};

/// kFramePath is the estimator and its workers; the readers rank above it, the publisher
/// below; kBackground is the global ICP thread, kStatus status publishing and recording.
enum class ThreadRole { kImuReader, kCameraReader, kFramePath, kPublisher, kBackground, kStatus };

/// What applying a role or locking memory did; `message` says it either way.
struct SchedulingOutcome {
  bool ok = false;
  std::string message;
};

/// Applies `role` to the calling thread: frame path = SCHED_FIFO `priority` if > 0 (else
/// nothing), background = SCHED_BATCH at `background_nice`. `thread` names it in messages.
SchedulingOutcome applyThreadRole(ThreadRole role, const RealtimeConfig& config, const std::string& thread);

/// mlockall(MCL_CURRENT | MCL_FUTURE); the message names the limit when refused.
SchedulingOutcome lockAllMemory();

/// The calling thread's policy, priority and nice, e.g. "SCHED_FIFO 10" or "SCHED_BATCH nice 10".
std::string describeThreadScheduling();

}  // namespace seavio::daemon
