#include "core/imu/accel_bias_estimator.hpp"

#include <cmath>

#include <Eigen/Dense>

#include "core/common/se3.hpp"
#include "core/imu/imu_integrator.hpp"
#include "core/imu/imu_interpolation.hpp"

namespace seavio::imu {

AccelBiasEstimator::AccelBiasEstimator(const AccelBiasParams& params) : params_(params) {
  reset(Eigen::Matrix3d::Identity(), true, 0.0, 0.0);
}

void AccelBiasEstimator::reset(const Eigen::Matrix3d& R_W_B, bool levelled_by_accelerometer, double tilt_sigma_rad,
                               double gyro_bias_sigma_rad_s) {
  bias_B_.setZero();
  tilt_correction_W_.setZero();
  gyro_bias_correction_B_.setZero();
  window_open_ = false;
  updates_ = refused_ = 0;
  last_nis_ = 0;
  P_.setZero();
  const double sb2 = params_.initial_bias_sigma_m_s2 * params_.initial_bias_sigma_m_s2;
  P_.block<3, 3>(2, 2) = Eigen::Matrix3d::Identity() * sb2;
  if (levelled_by_accelerometer) {
    // Levelling made R^ f = +g z exactly, so g [eps]x z = -R^ b: eps_x = (R^ b)_y / g,
    // eps_y = -(R^ b)_x / g. Without this correlation the first turn could not tell which of
    // the two moved.
    Eigen::Matrix<double, 2, 3> M;
    M << 0, 1, 0, -1, 0, 0;
    const Eigen::Matrix<double, 2, 3> J = M * R_W_B / kGravity_m_s2;
    P_.topLeftCorner<2, 2>() = J * P_.block<3, 3>(2, 2) * J.transpose();
    P_.block<2, 3>(0, 2) = J * P_.block<3, 3>(2, 2);
    P_.block<3, 2>(2, 0) = P_.block<2, 3>(0, 2).transpose();
  }
  P_.topLeftCorner<2, 2>() += Eigen::Matrix2d::Identity() * tilt_sigma_rad * tilt_sigma_rad;
  // The start-up tilt is the tilt now: the same state, exactly correlated, until the turns
  // and the chain's walk tell them apart.
  initial_tilt_W_.setZero();
  P_.block<2, 5>(5, 0) = P_.block<2, 5>(0, 0);
  P_.block<5, 2>(0, 5) = P_.block<5, 2>(0, 0);
  P_.block<2, 2>(5, 5) = P_.topLeftCorner<2, 2>();
  if (params_.gyro_bias_states)
    P_.block<2, 2>(7, 7) = Eigen::Matrix2d::Identity() * gyro_bias_sigma_rad_s * gyro_bias_sigma_rad_s;
}

void AccelBiasEstimator::startWindow(const Eigen::Vector3d& v_W) {
  window_open_ = true;
  v_start_W_ = v_W;
  sum_force_W_.setZero();
  sum_rotation_.setZero();
  window_s_ = 0;
}

void AccelBiasEstimator::addInterval(const Eigen::Matrix3d& R_W_B_start, const Eigen::Vector3d& gyro_bias_rad_s,
                                     std::span<const ImuSample> samples, int64_t t0_ns, int64_t t1_ns) {
  if (t1_ns <= t0_ns) return;
  const double dt_s = 1e-9 * static_cast<double>(t1_ns - t0_ns);
  P_.topLeftCorner<2, 2>().diagonal().array() += std::pow(params_.tilt_random_walk_rad_sqrt_s, 2) * dt_s;
  P_.block<3, 3>(2, 2).diagonal().array() += std::pow(params_.bias_random_walk_m_s2_sqrt_s, 2) * dt_s;
  if (params_.gyro_bias_states) {
    // The chain integrates the gyro minus the estimated bias, so a bias error turns it:
    // eps += (R dt)_xy dbg (R^ = exp([eps]x) R); the attitude at the interval's start will do
    // for a second's turn.
    StateMatrix F = StateMatrix::Identity();
    F.block<2, 2>(0, 7) = (R_W_B_start * dt_s).topLeftCorner<2, 2>();
    P_ = F * P_ * F.transpose();
    P_.block<2, 2>(7, 7).diagonal().array() += std::pow(params_.gyro_bias_random_walk_rad_s_sqrt_s, 2) * dt_s;
  }
  if (!window_open_) return;
  if (samples.empty()) {
    window_open_ = false;  // nothing measured the interval: the window cannot be closed
    return;
  }
  // Same knots as the dead reckoning: the interval's ends and every sample inside.
  Eigen::Matrix3d R = R_W_B_start;
  ImuSample prev = sampleAt(samples, t0_ns);
  int64_t t_prev = t0_ns;
  const auto step = [&](int64_t t) {
    const ImuSample next = sampleAt(samples, t);
    const double h = 1e-9 * static_cast<double>(t - t_prev);
    const Eigen::Vector3d dtheta = (0.5 * (prev.gyro_rad_s + next.gyro_rad_s) - gyro_bias_rad_s) * h;
    const Eigen::Matrix3d R_mid = R * se3::expSO3(0.5 * dtheta);
    sum_force_W_ += R_mid * (0.5 * (prev.accel_m_s2 + next.accel_m_s2) - bias_B_) * h;
    sum_rotation_ += R_mid * h;
    R = R * se3::expSO3(dtheta);
    prev = next;
    t_prev = t;
  };
  for (const ImuSample& s : samples)
    if (s.t_ns > t0_ns && s.t_ns < t1_ns) step(s.t_ns);
  step(t1_ns);
  window_s_ += dt_s;
}

AccelBiasEstimator::Outcome AccelBiasEstimator::close(const Eigen::Vector3d& v_W) {
  tilt_correction_W_.setZero();
  gyro_bias_correction_B_.setZero();
  if (!window_open_) return Outcome::kNoWindow;
  if (window_s_ < params_.window_s - 1e-6) return Outcome::kOpen;  // round-off of summed intervals
  window_open_ = false;
  const double T = window_s_;
  const Eigen::Vector3d m = sum_force_W_ / T;
  const Eigen::Vector3d z = (sum_force_W_ + gravityW() * T - (v_W - v_start_W_)) / T;
  Eigen::Matrix<double, 3, kStates> H = Eigen::Matrix<double, 3, kStates>::Zero();
  H.leftCols<2>() = -se3::skew(m).leftCols<2>();
  H.middleCols<3>(2) = sum_rotation_ / T;
  // Two velocities (the window's ends), and the accelerometer's white noise averaged over T.
  const double r2 = 2 * std::pow(params_.velocity_sigma_m_s / T, 2) + std::pow(params_.accel_noise_density, 2) / T;
  const Eigen::Matrix3d Rm = Eigen::Matrix3d::Identity() * r2;
  const Eigen::Matrix3d S = H * P_ * H.transpose() + Rm;
  const Eigen::LDLT<Eigen::Matrix3d> S_ldlt(S);
  last_nis_ = z.dot(S_ldlt.solve(z));
  if (!std::isfinite(last_nis_) || last_nis_ > params_.gate_sigmas * params_.gate_sigmas) {
    ++refused_;
    return Outcome::kRefused;
  }
  const Eigen::Matrix<double, kStates, 3> K = (S_ldlt.solve(H * P_)).transpose();
  const Eigen::Matrix<double, kStates, 1> dx = K * z;
  const StateMatrix I_KH = StateMatrix::Identity() - K * H;
  P_ = I_KH * P_ * I_KH.transpose() + K * Rm * K.transpose();
  P_ = 0.5 * (P_ + P_.transpose());
  bias_B_ += dx.segment<3>(2);
  // The start-up tilt is a constant, not fed back: only its estimate moves.
  initial_tilt_W_.head<2>() += dx.segment<2>(5);
  if (params_.gyro_bias_states) gyro_bias_correction_B_ = Eigen::Vector3d(dx(7), dx(8), 0.0);
  // Error-state feedback: R_true = exp(-[eps]x) R^, so the chain turns by -eps and the tilt
  // estimate is zero again (its uncertainty stays).
  tilt_correction_W_ = Eigen::Vector3d(-dx(0), -dx(1), 0.0);
  ++updates_;
  return Outcome::kUpdated;
}

}  // namespace seavio::imu
