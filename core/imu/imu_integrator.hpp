#pragma once
/// IMU dead reckoning (paper section III-A): bias-corrected, gravity-compensated double
/// integration of gyro and accelerometer, with first-order propagation of the error
/// covariance so the prediction can size the matching windows (section III-C).
#include <optional>
#include <span>

#include <Eigen/Core>

#include "core/common/types.hpp"
#include "core/imu/imu_noise.hpp"

namespace seavio::imu {

/// Error-state covariance, order (dtheta [rad] in body, dv [m/s] in W, dp [m] in W).
using Matrix9d = Eigen::Matrix<double, 9, 9>;

struct ImuPropagation {
  NavState state;                             ///< state at the requested end time
  Matrix9d covariance = Matrix9d::Zero();     ///< grown from the start covariance
  int samples_used = 0;
  double largest_gap_s = 0;                   ///< longest interval without a sample [s]
};

/// Gravity vector in W [m/s^2] (z up).
inline Eigen::Vector3d gravityW() { return {0.0, 0.0, -kGravity_m_s2}; }

/// Propagates `start` to `t_end_ns` through `samples` (sorted by time; samples outside
/// [start.t_ns, t_end_ns] are used only to interpolate the boundary values). The measurement
/// over each sub-interval is the mean of its two end values (midpoint rule), which halves the
/// error of the usual zero-order hold at the same rate. With no sample at all the state is
/// extrapolated at constant velocity and the gap is reported.
ImuPropagation propagate(const NavState& start, const Matrix9d& start_covariance,
                         std::span<const ImuSample> samples, int64_t t_end_ns, const ImuNoise& noise);

/// Roll and pitch from the mean specific force of (near-)unaccelerated samples, yaw = 0:
/// the rotation R_W_B that makes the mean accelerometer reading point along +z of W.
/// nullopt when there are no samples or the mean is far from 1 g (vehicle accelerating).
std::optional<Eigen::Matrix3d> attitudeFromAccelerometer(std::span<const ImuSample> samples,
                                                         double max_g_deviation = 0.05);

/// Gyro bias from samples taken while the vehicle holds still (the mean rate; Earth's
/// rotation, 7.3e-5 rad/s, is below the bias scale of the IMUs this serves). nullopt unless the
/// samples span at least `min_duration_s` and look still: accelerometer norm within
/// `max_accel_deviation` of 1 g and no rate beyond `max_rate_rad_s`.
std::optional<Eigen::Vector3d> gyroBiasAtRest(std::span<const ImuSample> samples, double min_duration_s = 0.3,
                                              double max_accel_deviation = 0.01, double max_rate_rad_s = 0.02);

}  // namespace seavio::imu
