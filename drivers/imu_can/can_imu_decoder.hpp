#pragma once
/// Turns `struct can_frame`s into IMU measurements by a `CanProfile`; pure, no I/O.
#include <linux/can.h>

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>

#include "drivers/imu_can/can_profile.hpp"

namespace seavio::drivers {

/// One complete measurement (device time, if the profile has one, not yet host-mapped).
struct CanImuMeasurement {
  std::optional<int64_t> device_t_ns;
  Eigen::Vector3d gyro_rad_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_m_s2 = Eigen::Vector3d::Zero();
};

/// Counters of what the decoder saw (its fault cases).
struct CanDecoderStats {
  uint64_t frames = 0;              ///< data frames looked at
  uint64_t samples = 0;             ///< complete measurements produced
  uint64_t unknown_ids = 0;         ///< frames whose id is not in the profile
  uint64_t error_frames = 0;        ///< CAN_ERR_FLAG frames from the controller
  uint64_t bus_off = 0;             ///< error frames with CAN_ERR_BUSOFF
  uint64_t short_frames = 0;        ///< dlc too small for a field the profile places there
  uint64_t incomplete_samples = 0;  ///< emit frame arrived but some axis was not refreshed
  uint64_t remote_frames = 0;       ///< RTR frames (carry no data)
};

class CanImuDecoder {
 public:
  explicit CanImuDecoder(CanProfile profile) : profile_(std::move(profile)) {}
  /// Feeds one frame; returns a measurement when the profile's pairing rule completes one.
  std::optional<CanImuMeasurement> decode(const can_frame& f);
  const CanDecoderStats& stats() const { return stats_; }
  const CanProfile& profile() const { return profile_; }

 private:
  CanProfile profile_;
  CanDecoderStats stats_;
  std::array<double, 6> values_{};
  std::array<bool, 6> fresh_{};
  std::optional<int64_t> device_t_ns_;
  uint32_t last_raw_time_ = 0;
  int64_t time_wraps_ = 0;
  bool have_raw_time_ = false;
};

/// Encodes `values` (SI units) into frames per `profile`, emit frame last; for tests,
/// fuzz seeds and simulators. `device_t_ns` is ignored if the profile has no timestamp.
std::vector<can_frame> encodeCanImu(const CanProfile& profile, const Eigen::Vector3d& gyro_rad_s,
                                    const Eigen::Vector3d& accel_m_s2, int64_t device_t_ns);

}  // namespace seavio::drivers
