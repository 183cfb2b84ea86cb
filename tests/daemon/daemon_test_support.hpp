#pragma once
// Small helpers the daemon tests share (daemon_test, daemon_faults_test, global_thread_test,
// latency_imu_hold_test, latency_realtime_test): polling for a condition with a deadline, and
// the pose an identity frame processor returns. One copy, so the tests agree on what they wait
// for and what "processed" means.
#include <chrono>
#include <functional>
#include <thread>

#include "core/common/types.hpp"
#include "daemon/daemon.hpp"

namespace seavio::test {

/// True when `pred` held within `timeout`, checked every `poll` and once more at the end.
inline bool waitFor(const std::function<bool()>& pred, std::chrono::milliseconds timeout,
                    std::chrono::milliseconds poll = std::chrono::milliseconds(5)) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < until) {
    if (pred()) return true;
    std::this_thread::sleep_for(poll);
  }
  return pred();
}

/// True when the daemon finished (every source ended and every frame went through) within
/// `timeout`.
inline bool waitFinished(const daemon::Daemon& d, std::chrono::milliseconds timeout) {
  return waitFor([&] { return d.finished(); }, timeout, std::chrono::milliseconds(10));
}

/// What a processor that only records its input returns for `f`: a vision pose at the
/// frame's stamp and sequence number, identity transform.
inline OdometryResult visionResultFor(const StereoFrame& f) {
  OdometryResult r;
  r.t_ns = f.t_ns;
  r.seq = f.seq;
  r.source = PoseSource::kVision;
  return r;
}

}  // namespace seavio::test
