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

/// Fills the version-2 timing fields of `m`: `recv_t_ns` and the per-stage
/// latencies [ms] named in seavio_pose_t.lcm. All stamps on the daemon's monotonic clock [ns];
/// `times` is the odometry's own split (StageTimes, total 0 = not measured: those stages are
/// left out). "acquisition" is added only when m.t_ns is on the same clock (0..10 s before
/// receipt), which holds for live drivers, not for replayed datasets with their own epoch.
void setPoseTiming(seavio_lcm::pose_t& m, const StageTimes& times, int64_t recv_t_ns, int64_t proc_end_t_ns,
                   int64_t publish_t_ns);

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
