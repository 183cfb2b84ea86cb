#pragma once
/// LCM channel names of seavio (one place, shared by daemon, tools and tests).
#include <string_view>

namespace seavio::drivers::lcm_channels {

inline constexpr std::string_view kPose = "SEAVIO_POSE";      ///< seavio_lcm::pose_t
inline constexpr std::string_view kStatus = "SEAVIO_STATUS";  ///< seavio_lcm::status_t
inline constexpr std::string_view kStereo = "SEAVIO_STEREO";  ///< seavio_lcm::stereo_t
inline constexpr std::string_view kImu = "SEAVIO_IMU";        ///< seavio_lcm::imu_t
inline constexpr std::string_view kCalibration = "SEAVIO_CALIBRATION";  ///< seavio_lcm::calibration_t

/// Default provider: UDP multicast with TTL 0, so nothing leaves the host unless configured.
inline constexpr std::string_view kDefaultUrl = "udpm://239.255.76.67:7667?ttl=0";

}  // namespace seavio::drivers::lcm_channels
