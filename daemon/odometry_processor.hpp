#pragma once
/// The production estimator stage: core's stereo visual odometry (paper Sec. III) behind the
/// daemon's FrameProcessor interface.
#include <memory>
#include <optional>
#include <string>

#include "core/camera/camera_model.hpp"
#include "core/odometry/odometry.hpp"
#include "daemon/frame_processor.hpp"

namespace seavio::daemon {

class OdometryProcessor : public FrameProcessor {
 public:
  /// Empty optional and `error` set if the calibration cannot be rectified.
  static std::unique_ptr<OdometryProcessor> create(const camera::StereoCalibration& calib,
                                                   const imu::ImuNoise& noise,
                                                   const odometry::OdometryParams& params,
                                                   std::string* error);
  OdometryResult process(const StereoFrame& frame, std::span<const ImuSample> imu) override {
    return odo_.process(frame, imu);
  }
  std::string name() const override { return "stereo-odometry"; }

  explicit OdometryProcessor(odometry::Odometry odo) : odo_(std::move(odo)) {}

 private:
  odometry::Odometry odo_;
};

}  // namespace seavio::daemon
