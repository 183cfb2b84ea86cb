#pragma once
/// The calibration a log carries (seavio_lcm::calibration_t on SEAVIO_CALIBRATION): written
/// first in every recorded or converted log, read back by `seavio replay`, so a log needs no
/// other file.
#include <optional>
#include <string>

#include "core/camera/camera_model.hpp"
#include "core/imu/imu_noise.hpp"
#include "seavio_lcm/calibration_t.hpp"

namespace seavio::drivers {

/// What a log needs to be replayed: the raw stereo calibration and the IMU noise model.
struct LogCalibration {
  camera::StereoCalibration stereo;
  imu::ImuNoise imu_noise;
  /// The log's events are in the order seaviod's estimator consumed them (calibration_t
  /// IMU_ORDER_CONSUMED), not in stamp order.
  bool consumed_order = false;
};

seavio_lcm::calibration_t toCalibrationMsg(const LogCalibration& c);
/// Empty with `error` set when the message is inconsistent (unknown distortion model,
/// non-finite or non-positive intrinsics, image size <= 0).
std::optional<LogCalibration> fromCalibrationMsg(const seavio_lcm::calibration_t& m, std::string* error);

/// The first calibration message on `channel` in the LCM log `path`. Empty with `error`
/// naming the file when it cannot be read, has none, or the first one does not decode.
std::optional<LogCalibration> readLogCalibration(const std::string& path, const std::string& channel,
                                                 std::string* error);

}  // namespace seavio::drivers
