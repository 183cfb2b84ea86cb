#pragma once
/// Every ring buffer capacity of seaviod in one place (issue 6), overridable from the
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
};

}  // namespace seavio::daemon
