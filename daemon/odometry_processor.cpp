#include "daemon/odometry_processor.hpp"

#include "daemon/daemon.hpp"

namespace seavio::daemon {

std::unique_ptr<OdometryProcessor> OdometryProcessor::create(const camera::StereoCalibration& calib,
                                                             const imu::ImuNoise& noise,
                                                             const odometry::OdometryParams& params,
                                                             std::string* error) {
  std::optional<camera::StereoRectifier> rect = camera::StereoRectifier::create(calib, error);
  if (!rect) return nullptr;
  // The odometry times its stages with the daemon's monotonic clock (StageTimes).
  return std::make_unique<OdometryProcessor>(
      odometry::Odometry(std::move(*rect), noise, params, [] { return monotonicNowNs(); }));
}

}  // namespace seavio::daemon
