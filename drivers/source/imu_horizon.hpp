#pragma once
/// A replayed camera that knows which IMU samples the recording estimator held for each
/// frame (a log in consumption order, seavio_calibration_t.lcm): the daemon then hands the
/// odometry exactly those samples, so a replay gives the poses the recorded run published.
#include <cstdint>
#include <limits>

namespace seavio::drivers {

class ImuHorizonReporter {
 public:
  /// `horizon_ns` when none was held yet.
  static constexpr int64_t kNoImu = std::numeric_limits<int64_t>::min();
  virtual ~ImuHorizonReporter() = default;
  /// For the frame last read: true with the stamp of the newest IMU sample the recording
  /// estimator held when it processed that frame [ns] (kNoImu if none); false when the log
  /// does not say (stamp order: wait for the first sample after the frame).
  virtual bool imuHorizon(int64_t& horizon_ns) const = 0;
};

}  // namespace seavio::drivers
