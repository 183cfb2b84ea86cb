#pragma once
/// The IMU reading between samples, shared by the dead reckoning (imu_integrator.cpp) and the
/// coasting covariance (coasting_covariance.cpp): both integrate over the same knots with the
/// midpoint rule (paper section III-A), so they must see the same measurement at a frame time.
#include <algorithm>
#include <cstdint>
#include <span>

#include "core/common/types.hpp"

namespace seavio::imu {

/// Gyro and accelerometer reading at `t_ns`: linear between the neighbouring samples of `s`
/// (sorted by time), held constant beyond the ends; zero when `s` is empty.
inline ImuSample sampleAt(std::span<const ImuSample> s, int64_t t_ns) {
  // Explicit zeros: an Eigen vector initialised from {} is left uninitialised.
  if (s.empty()) return ImuSample{t_ns, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  if (t_ns <= s.front().t_ns) return ImuSample{t_ns, s.front().gyro_rad_s, s.front().accel_m_s2};
  if (t_ns >= s.back().t_ns) return ImuSample{t_ns, s.back().gyro_rad_s, s.back().accel_m_s2};
  const auto it = std::lower_bound(s.begin(), s.end(), t_ns,
                                   [](const ImuSample& a, int64_t t) { return a.t_ns < t; });
  const ImuSample& b = *it;
  const ImuSample& a = *(it - 1);
  const double span = static_cast<double>(b.t_ns - a.t_ns);
  const double w = span > 0 ? static_cast<double>(t_ns - a.t_ns) / span : 0.0;
  return ImuSample{t_ns, (1 - w) * a.gyro_rad_s + w * b.gyro_rad_s, (1 - w) * a.accel_m_s2 + w * b.accel_m_s2};
}

}  // namespace seavio::imu
