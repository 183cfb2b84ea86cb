#pragma once
/// Every ring buffer capacity of seaviod in one place, overridable from the
/// `daemon.rings` section of the config.
#include <cstddef>

namespace seavio::daemon {

struct RingCapacities {
  /// Stereo frames between acquisition and estimator. Small on purpose: a frame older than
  /// a few periods (66 ms each at 15 fps) is worth less than the newest one.
  std::size_t camera_frames = 4;
  /// IMU samples between reader and estimator: 2 s at 1 kHz, far more than one frame.
  std::size_t imu_samples = 2048;
  /// Odometry results between estimator and LCM publisher.
  std::size_t poses = 32;
  /// Global-map requests between estimator and ICP thread (global mode with
  /// daemon.global_thread). Full policy: the new request is skipped and counted
  /// (global_skipped), the estimator never waits; that frame keeps its local pose and the map
  /// misses at most that keyframe (the next frame far enough becomes one). 4 frames = 266 ms
  /// at 15 fps: an ICP thread that far behind is better skipped than waited for.
  std::size_t global_requests = 4;
  /// Corrections back from the ICP thread, drained by the estimator before every frame. Its
  /// capacity is global_requests + 2 (one frame submits one request between two drains, one
  /// more may be in the ICP), so it cannot fill; if it ever did, the correction is counted
  /// as lost (global_lost) and its refined pose is still published.
  std::size_t globalCorrections() const { return global_requests + 2; }
};

}  // namespace seavio::daemon
