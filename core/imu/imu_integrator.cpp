#include "core/imu/imu_integrator.hpp"

#include <algorithm>
#include <cmath>

#include "core/common/se3.hpp"
#include "core/imu/imu_interpolation.hpp"

namespace seavio::imu {
ImuPropagation propagate(const NavState& start, const Matrix9d& start_covariance,
                         std::span<const ImuSample> samples, int64_t t_end_ns, const ImuNoise& noise) {
  ImuPropagation out;
  out.state = start;
  out.covariance = start_covariance;
  const int64_t t0 = start.t_ns;
  if (t_end_ns <= t0) return out;

  // Knots: start, every sample strictly inside, end. Walked in place rather than collected
  // (this runs every frame: no allocation on the per-frame path).
  const auto inside = [&](const ImuSample& s) { return s.t_ns > t0 && s.t_ns < t_end_ns; };
  {
    int64_t last = t0;
    for (const ImuSample& s : samples) {
      if (!inside(s)) continue;
      out.largest_gap_s = std::max(out.largest_gap_s, 1e-9 * static_cast<double>(s.t_ns - last));
      last = s.t_ns;
      ++out.samples_used;
    }
    out.largest_gap_s = std::max(out.largest_gap_s, 1e-9 * static_cast<double>(t_end_ns - last));
  }

  Eigen::Matrix3d R = start.T_W_B.rotation();
  Eigen::Vector3d v = start.v_W;
  Eigen::Vector3d p = start.T_W_B.translation();
  const Eigen::Vector3d g = gravityW();
  Matrix9d P = start_covariance;

  if (samples.empty()) {
    const double dt = 1e-9 * static_cast<double>(t_end_ns - t0);
    p += v * dt;
    // Without measurements the velocity and attitude are unknown: grow as a random walk of 1 g.
    P.block<3, 3>(3, 3) += Eigen::Matrix3d::Identity() * std::pow(kGravity_m_s2 * dt, 2);
    P.block<3, 3>(6, 6) += Eigen::Matrix3d::Identity() * std::pow(0.5 * kGravity_m_s2 * dt * dt, 2);
  } else {
    ImuSample prev = sampleAt(samples, t0);
    int64_t knot_prev = t0;
    std::size_t next_sample = 0;  // first sample not yet taken as a knot
    for (bool end = false; !end;) {
      while (next_sample < samples.size() && !inside(samples[next_sample])) ++next_sample;
      end = next_sample == samples.size();
      const int64_t knot = end ? t_end_ns : samples[next_sample++].t_ns;
      const ImuSample next = sampleAt(samples, knot);
      const double dt = 1e-9 * static_cast<double>(knot - knot_prev);
      const Eigen::Vector3d w = 0.5 * (prev.gyro_rad_s + next.gyro_rad_s) - start.gyro_bias_rad_s;
      const Eigen::Vector3d a = 0.5 * (prev.accel_m_s2 + next.accel_m_s2) - start.accel_bias_m_s2;
      const Eigen::Vector3d dtheta = w * dt;
      const Eigen::Matrix3d dR = se3::expSO3(dtheta);
      const Eigen::Matrix3d R_mid = R * se3::expSO3(0.5 * dtheta);
      const Eigen::Vector3d acc_W = R_mid * a + g;

      // Error-state transition (body-frame rotation error, W velocity/position errors).
      Eigen::Matrix<double, 9, 9> F = Eigen::Matrix<double, 9, 9>::Identity();
      F.block<3, 3>(0, 0) = dR.transpose();
      F.block<3, 3>(3, 0) = -R_mid * se3::skew(a) * dt;
      F.block<3, 3>(6, 0) = -0.5 * R_mid * se3::skew(a) * dt * dt;
      F.block<3, 3>(6, 3) = Eigen::Matrix3d::Identity() * dt;
      Eigen::Matrix<double, 9, 6> G = Eigen::Matrix<double, 9, 6>::Zero();
      G.block<3, 3>(0, 0) = se3::rightJacobianSO3(dtheta) * dt;
      G.block<3, 3>(3, 3) = R_mid * dt;
      G.block<3, 3>(6, 3) = 0.5 * R_mid * dt * dt;
      // Continuous white noise -> discrete; the bias random walk over the interval adds to it.
      const double elapsed_s = 1e-9 * static_cast<double>(knot - t0);
      const double sg2 = noise.gyroscope_noise_density * noise.gyroscope_noise_density / dt +
                         std::pow(noise.gyroscope_random_walk, 2) * elapsed_s;
      const double sa2 = noise.accelerometer_noise_density * noise.accelerometer_noise_density / dt +
                         std::pow(noise.accelerometer_random_walk, 2) * elapsed_s;
      Eigen::Matrix<double, 6, 6> Q = Eigen::Matrix<double, 6, 6>::Zero();
      Q.diagonal() << sg2, sg2, sg2, sa2, sa2, sa2;
      P = F * P * F.transpose() + G * Q * G.transpose();

      p += v * dt + 0.5 * acc_W * dt * dt;
      v += acc_W * dt;
      R = R * dR;
      prev = next;
      knot_prev = knot;
    }
  }
  // Re-orthonormalise against round-off over long propagations.
  const Eigen::Quaterniond q(R);
  out.state.T_W_B.linear() = q.normalized().toRotationMatrix();
  out.state.T_W_B.translation() = p;
  out.state.v_W = v;
  out.state.t_ns = t_end_ns;
  out.covariance = 0.5 * (P + P.transpose());
  return out;
}

std::optional<Eigen::Matrix3d> attitudeFromAccelerometer(std::span<const ImuSample> samples,
                                                         double max_g_deviation) {
  if (samples.empty()) return std::nullopt;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const ImuSample& s : samples) mean += s.accel_m_s2;
  mean /= static_cast<double>(samples.size());
  if (!mean.allFinite() || std::abs(mean.norm() - kGravity_m_s2) > max_g_deviation * kGravity_m_s2)
    return std::nullopt;
  // At rest the accelerometer measures -g in B, i.e. +z of W expressed in B.
  const Eigen::Vector3d z_B = mean.normalized();
  const Eigen::Quaterniond q_W_B = Eigen::Quaterniond::FromTwoVectors(z_B, Eigen::Vector3d::UnitZ());
  Eigen::Matrix3d R = q_W_B.toRotationMatrix();
  // Remove the yaw that FromTwoVectors may introduce: yaw is unobservable, start at 0.
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  R = Eigen::AngleAxisd(-yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * R;
  return R;
}

std::optional<Eigen::Vector3d> gyroBiasAtRest(std::span<const ImuSample> samples, double min_duration_s,
                                              double max_accel_deviation, double max_rate_rad_s) {
  if (samples.size() < 2 ||
      1e-9 * static_cast<double>(samples.back().t_ns - samples.front().t_ns) < min_duration_s)
    return std::nullopt;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const ImuSample& s : samples) {
    if (!s.gyro_rad_s.allFinite() || !s.accel_m_s2.allFinite()) return std::nullopt;
    if (std::abs(s.accel_m_s2.norm() - kGravity_m_s2) > max_accel_deviation * kGravity_m_s2 * 3) return std::nullopt;
    if (s.gyro_rad_s.norm() > max_rate_rad_s) return std::nullopt;
    mean += s.gyro_rad_s;
  }
  mean /= static_cast<double>(samples.size());
  Eigen::Vector3d accel_mean = Eigen::Vector3d::Zero();
  for (const ImuSample& s : samples) accel_mean += s.accel_m_s2;
  accel_mean /= static_cast<double>(samples.size());
  if (std::abs(accel_mean.norm() - kGravity_m_s2) > max_accel_deviation * kGravity_m_s2) return std::nullopt;
  return mean;
}

}  // namespace seavio::imu
