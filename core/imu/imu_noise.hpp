#pragma once
/// IMU noise model with EuRoC `sensor.yaml` names and units.
namespace seavio::imu {

struct ImuNoise {
  double gyroscope_noise_density = 1.6968e-04;      ///< [rad/s/sqrt(Hz)]
  double gyroscope_random_walk = 1.9393e-05;        ///< [rad/s^2/sqrt(Hz)]
  double accelerometer_noise_density = 2.0000e-3;   ///< [m/s^2/sqrt(Hz)]
  double accelerometer_random_walk = 3.0000e-3;     ///< [m/s^3/sqrt(Hz)]
  double rate_hz = 200.0;
};

/// Gravity magnitude used everywhere [m/s^2]; W has z up, so g_W = (0, 0, -kGravity).
inline constexpr double kGravity_m_s2 = 9.81;

}  // namespace seavio::imu
