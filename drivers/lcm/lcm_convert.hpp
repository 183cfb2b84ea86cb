#pragma once
/// Conversions between pipeline value types and the generated seavio_lcm messages.
#include <optional>
#include <string>

#include "core/common/types.hpp"
#include "seavio_lcm/imu_t.hpp"
#include "seavio_lcm/pose_t.hpp"
#include "seavio_lcm/stereo_t.hpp"

namespace seavio::drivers {

/// Pose message of one odometry result; `publish_t_ns` is the publication time on the
/// daemon's monotonic clock [ns]. Non-finite values are never published: they are replaced
/// by the identity pose, zero velocity and a huge covariance, and the IMU-only flag is set.
seavio_lcm::pose_t toPoseMsg(const OdometryResult& r, int64_t publish_t_ns);

/// Inverse of toPoseMsg for the fields an OdometryResult holds (quality partly).
OdometryResult fromPoseMsg(const seavio_lcm::pose_t& m);

/// Raw stereo message; both images must be CV_8UC1 of equal size.
/// @param exposure_us exposure [us], 0 when unknown
seavio_lcm::stereo_t toStereoMsg(const StereoFrame& f, double exposure_us = 0.0);

/// Frame from a stereo message (images are deep copies). Empty optional and `error` set
/// when sizes are inconsistent.
std::optional<StereoFrame> fromStereoMsg(const seavio_lcm::stereo_t& m, std::string* error = nullptr);

seavio_lcm::imu_t toImuMsg(const ImuSample& s);
ImuSample fromImuMsg(const seavio_lcm::imu_t& m);

}  // namespace seavio::drivers
