#include "core/imu/coasting_covariance.hpp"

#include <algorithm>
#include <cmath>

#include "core/common/se3.hpp"
#include "core/imu/imu_interpolation.hpp"

namespace seavio::imu {
void CoastingCovariance::start(const CoastingStart& s) {
  P_.setZero();
  P_.block<3, 3>(0, 0).diagonal().setConstant(s.attitude_sigma_rad * s.attitude_sigma_rad);
  P_.block<3, 3>(3, 3).diagonal().setConstant(s.velocity_sigma_m_s * s.velocity_sigma_m_s);
  P_.block<3, 3>(9, 9).diagonal().setConstant(s.gyro_bias_sigma_rad_s * s.gyro_bias_sigma_rad_s);
  P_.block<3, 3>(12, 12).diagonal().setConstant(s.accel_bias_sigma_m_s2 * s.accel_bias_sigma_m_s2);
  accel_correction_W_.setZero();
  active_ = true;
}

void CoastingCovariance::setMeasuredVelocity(const Eigen::Matrix3d& velocity_covariance, double age_s,
                                             const Eigen::Matrix3d& R_W_B, const Eigen::Vector3d& specific_force_B) {
  P_.block<3, 3>(3, 3) = 0.5 * (velocity_covariance + velocity_covariance.transpose());
  // Over age_s the IMU increments carried the same tilt and accelerometer-bias errors that the
  // coasting will carry (the transition of propagate() with the attitude held): the velocity
  // error gains -R [f]x dtheta age_s - R dba age_s, correlated with those states.
  Matrix18d A = Matrix18d::Identity();
  A.block<3, 3>(3, 0) = -R_W_B * se3::skew(specific_force_B) * age_s;
  A.block<3, 3>(3, 12) = -R_W_B * age_s;
  P_ = A * P_ * A.transpose();
  P_ = 0.5 * (P_ + P_.transpose());
}

void CoastingCovariance::setMeasuredMotion(const Eigen::Matrix3d& velocity_covariance,
                                           const Eigen::Matrix3d& velocity_acceleration_covariance,
                                           const Eigen::Matrix3d& acceleration_covariance,
                                           const Eigen::Vector3d& acceleration_error, const Eigen::Matrix3d& R_W_B) {
  P_.block<3, 3>(3, 3) = 0.5 * (velocity_covariance + velocity_covariance.transpose());
  // The fit measured the acceleration the IMU missed, what the tilt and bias errors
  // x = (dtheta, dba) do to the velocity, plus its own error e. The correction is a constant in
  // W, so its error is c = -H x + e, with H the part of propagate()'s transition [-R [f]x, -R]
  // (f the reaction to gravity: the fit averages over seconds of near-constant velocity) whose
  // effect stays constant in W while the vehicle turns about the vertical, as AUVs do: the
  // tilt's (an attitude error is a fixed rotation of the estimate in W) and the vertical
  // component of the bias's (the bias is fixed in the body, so its horizontal components turn
  // with the heading and keep their prior). At the hand-over the acceleration error is then e
  // plus the horizontal bias prior. Carrying the fit's error on top of the full tilt prior
  // counted the tilt twice (3 sigma / error ~20 once the gravity-referenced tilt had
  // made the tilt itself small). Cancelling the horizontal bias too is exact only until the
  // first turn, and left 2 of 24 CoastingConsistency errors just above 3 sigma.
  const Eigen::Matrix3d vertical = Eigen::Vector3d::UnitZ() * Eigen::Vector3d::UnitZ().transpose();
  Eigen::Matrix<double, 3, 18> H = Eigen::Matrix<double, 3, 18>::Zero();
  H.block<3, 3>(0, 0) = -R_W_B * se3::skew(R_W_B.transpose() * Eigen::Vector3d(0, 0, kGravity_m_s2));
  H.block<3, 3>(0, 12) = -vertical * R_W_B;
  // cov(s, c) = -cov(s, x) H^T + cov(s, e) for every state s; only the velocity shares e.
  Eigen::Matrix<double, 18, 3> Psc = -P_ * H.transpose();
  Psc.block<3, 3>(3, 0) += velocity_acceleration_covariance;
  Psc.block<3, 3>(15, 0) = H * P_ * H.transpose() + acceleration_covariance;
  P_.block<18, 3>(0, 15) = Psc;
  P_.block<3, 18>(15, 0) = Psc.transpose();
  P_ = 0.5 * (P_ + P_.transpose());
  accel_correction_W_ = acceleration_error;
}

void CoastingCovariance::propagate(const Eigen::Matrix3d& R_W_B, const Eigen::Vector3d& gyro_bias,
                                   const Eigen::Vector3d& accel_bias, std::span<const ImuSample> samples,
                                   int64_t t0_ns, int64_t t1_ns, const ImuNoise& noise) {
  if (t1_ns <= t0_ns) return;
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d R = R_W_B;
  // Without samples the specific force is taken as the reaction to gravity (level, unaccelerated):
  // the tilt error still couples into velocity through it.
  auto reading = [&](int64_t t) -> std::pair<Eigen::Vector3d, Eigen::Vector3d> {
    if (samples.empty()) return {gyro_bias, accel_bias + R_W_B.transpose() * Eigen::Vector3d(0, 0, kGravity_m_s2)};
    const ImuSample m = sampleAt(samples, t);
    return {m.gyro_rad_s, m.accel_m_s2};
  };
  int64_t t_prev = t0_ns;
  auto prev = reading(t0_ns);
  auto step = [&](int64_t t) {
    const auto next = reading(t);
    const double dt = 1e-9 * static_cast<double>(t - t_prev);
    const Eigen::Vector3d w = 0.5 * (prev.first + next.first) - gyro_bias;
    const Eigen::Vector3d a = 0.5 * (prev.second + next.second) - accel_bias;
    const Eigen::Vector3d dtheta = w * dt;
    const Eigen::Matrix3d dR = se3::expSO3(dtheta);
    const Eigen::Matrix3d R_mid = R * se3::expSO3(0.5 * dtheta);
    const Eigen::Matrix3d Jr = se3::rightJacobianSO3(dtheta);
    const Eigen::Matrix3d Ra = R_mid * se3::skew(a);
    // First-order error-state transition (body attitude error; a gyro bias error rotates the
    // attitude, an accelerometer bias error adds an acceleration in W; the tilt error couples
    // through the specific force, i.e. mostly gravity's reaction).
    Matrix18d F = Matrix18d::Identity();
    F.block<3, 3>(0, 0) = dR.transpose();
    F.block<3, 3>(0, 9) = -Jr * dt;
    F.block<3, 3>(3, 0) = -Ra * dt;
    F.block<3, 3>(3, 12) = -R_mid * dt;
    F.block<3, 3>(6, 0) = -0.5 * Ra * dt * dt;
    F.block<3, 3>(6, 3) = I * dt;
    F.block<3, 3>(6, 12) = -0.5 * R_mid * dt * dt;
    F.block<3, 3>(3, 15) = I * dt;  // the correction's error, constant in W
    F.block<3, 3>(6, 15) = 0.5 * I * dt * dt;
    // White measurement noise over dt (variance density^2 / dt of the mean) and the biases'
    // random walks (variance rw^2 * dt).
    const double sg2 = noise.gyroscope_noise_density * noise.gyroscope_noise_density / dt;
    const double sa2 = noise.accelerometer_noise_density * noise.accelerometer_noise_density / dt;
    Eigen::Matrix<double, 18, 12> G = Eigen::Matrix<double, 18, 12>::Zero();
    G.block<3, 3>(0, 0) = Jr * dt;
    G.block<3, 3>(3, 3) = R_mid * dt;
    G.block<3, 3>(6, 3) = 0.5 * R_mid * dt * dt;
    G.block<3, 3>(9, 6) = I;
    G.block<3, 3>(12, 9) = I;
    Eigen::Matrix<double, 12, 1> q;
    q << sg2, sg2, sg2, sa2, sa2, sa2, Eigen::Vector3d::Constant(std::pow(noise.gyroscope_random_walk, 2) * dt),
        Eigen::Vector3d::Constant(std::pow(noise.accelerometer_random_walk, 2) * dt);
    P_ = F * P_ * F.transpose() + G * q.asDiagonal() * G.transpose();
    R = R * dR;
    prev = next;
    t_prev = t;
  };
  for (const ImuSample& s : samples)
    if (s.t_ns > t0_ns && s.t_ns < t1_ns) step(s.t_ns);
  if (samples.empty()) {
    // Steps of at most 10 ms, so the quadratic terms stay first-order accurate.
    const int64_t n = std::max<int64_t>(1, (t1_ns - t0_ns + 9'999'999) / 10'000'000);
    for (int64_t k = 1; k < n; ++k) step(t0_ns + (t1_ns - t0_ns) * k / n);
  }
  step(t1_ns);
  P_ = 0.5 * (P_ + P_.transpose());
}

Eigen::Matrix<double, 6, 6> CoastingCovariance::poseCovariance(const Eigen::Matrix3d& R_W_B) const {
  Eigen::Matrix<double, 6, 6> C = Eigen::Matrix<double, 6, 6>::Zero();
  C.topLeftCorner<3, 3>() = R_W_B * P_.topLeftCorner<3, 3>() * R_W_B.transpose();
  C.bottomRightCorner<3, 3>() = P_.block<3, 3>(6, 6);
  const Eigen::Matrix3d cross = R_W_B * P_.block<3, 3>(0, 6);
  C.topRightCorner<3, 3>() = cross;
  C.bottomLeftCorner<3, 3>() = cross.transpose();
  return C;
}

}  // namespace seavio::imu
