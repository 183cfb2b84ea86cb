#pragma once
/// IMU measurements and ground truth from a trajectory: gyro = omega_B + b_g + n_g,
/// accel = R_W_B^T (a_W - g_W) + b_a + n_a, g_W = (0, 0, -9.81); white noise sigma =
/// density * sqrt(rate), bias random walk sigma = rw * sqrt(dt) (EuRoC / Kalibr convention).
#include <cstdint>
#include <random>
#include <vector>

#include "core/common/types.hpp"
#include "core/imu/imu_noise.hpp"
#include "tools/simulate/trajectory.hpp"

namespace seavio::simulate {

/// First timestamp of every simulated stream [ns], so all stamps are positive.
inline constexpr int64_t kStartTimeNs = 1000000000;

/// Timestamp [ns] of sample k at `rate_hz`.
int64_t sampleTimeNs(int64_t k, double rate_hz);
/// Trajectory time [s] of a timestamp.
inline double trajectoryTime(int64_t t_ns) { return static_cast<double>(t_ns - kStartTimeNs) * 1e-9; }

struct ImuSequence {
  std::vector<ImuSample> samples;
  std::vector<NavState> ground_truth;  ///< same timestamps as `samples`, biases included
};

class ImuSimulator {
 public:
  /// @param initial_gyro_bias_sigma [rad/s], @param initial_accel_bias_sigma [m/s^2]
  /// @param time_offset_s the sample stamped t measures the motion at t + time_offset_s
  /// (a camera-IMU offset the calibration does not state); ground truth stays at t.
  ImuSimulator(const imu::ImuNoise& noise, double initial_gyro_bias_sigma, double initial_accel_bias_sigma,
               double time_offset_s = 0.0);
  /// Samples from t = 0 to `end_s` inclusive at noise.rate_hz. `noiseless` keeps biases at zero
  /// and adds no noise (used to check consistency).
  ImuSequence simulate(const Trajectory& trajectory, double end_s, std::mt19937& rng, bool noiseless = false) const;
  /// Prepends `lead_s` of samples before t = 0 with the vehicle parked where the trajectory
  /// starts (or, when it moves before t = 0, as the trajectory moves), as a real IMU streams before the camera's first frame (the odometry levels itself
  /// on the second before it). The biases walk back from the sequence's first; the noise comes
  /// from its own generator (`seed`), so the samples from t = 0 on are unchanged. The ground
  /// truth gets the lead too; the sequence writer writes it from the first frame on.
  void prependLead(ImuSequence& sequence, const Trajectory& trajectory, double lead_s, uint32_t seed,
                   bool noiseless = false) const;
  /// The noiseless measurement at one state.
  static ImuSample idealSample(const BodyState& s, int64_t t_ns);

 private:
  imu::ImuNoise noise_;
  double bg0_, ba0_;
  double time_offset_s_;
};

}  // namespace seavio::simulate
