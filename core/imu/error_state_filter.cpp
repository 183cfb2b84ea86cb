#include "core/imu/error_state_filter.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include "core/common/se3.hpp"
#include "core/imu/imu_integrator.hpp"

namespace seavio::imu {
namespace {

using Matrix3d = Eigen::Matrix3d;
using Vector3d = Eigen::Vector3d;

/// Tilt covariance in the body frame: `sigma` about W's x and y, nothing about gravity (yaw
/// is the world frame's definition at start-up, unobservable after).
Matrix3d tiltCovarianceBody(const Matrix3d& R_W_B, double sigma) {
  Matrix3d C = Matrix3d::Zero();
  C(0, 0) = C(1, 1) = sigma * sigma;
  return R_W_B.transpose() * C * R_W_B;
}

ImuSample lerp(const ImuSample& a, const ImuSample& b, int64_t t_ns) {
  const double span = static_cast<double>(b.t_ns - a.t_ns);
  const double u = span > 0 ? static_cast<double>(t_ns - a.t_ns) / span : 0.0;
  return ImuSample{t_ns, a.gyro_rad_s + u * (b.gyro_rad_s - a.gyro_rad_s),
                   a.accel_m_s2 + u * (b.accel_m_s2 - a.accel_m_s2)};
}

}  // namespace

bool ErrorStateFilter::plausible(const ImuSample& s) const {
  return s.gyro_rad_s.allFinite() && s.accel_m_s2.allFinite() &&
         s.gyro_rad_s.cwiseAbs().maxCoeff() <= params_.gyro_range_rad_s &&
         s.accel_m_s2.cwiseAbs().maxCoeff() <= params_.accel_range_m_s2;
}

StartKind ErrorStateFilter::start(int64_t t_ns, std::span<const ImuSample> recent) {
  *this = ErrorStateFilter(params_);
  started_ = true;
  t_ns_ = t_ns;
  Vector3d f_mean = Vector3d::Zero(), w_mean = Vector3d::Zero();
  int n = 0;
  for (const ImuSample& s : recent)
    if (s.t_ns <= t_ns && plausible(s)) {
      f_mean += s.accel_m_s2;
      w_mean += s.gyro_rad_s;
      ++n;
      last_ = s;
      have_last_ = true;
    }
  P_.block<3, 3>(kEsVel, kEsVel) = Matrix3d::Identity() * std::pow(params_.initial_velocity_sigma_m_s, 2);
  P_.block<3, 3>(kEsBg, kEsBg) = Matrix3d::Identity() * std::pow(params_.gyro_bias_sigma_rad_s, 2);
  P_.block<3, 3>(kEsBa, kEsBa) = Matrix3d::Identity() * std::pow(params_.accel_bias_sigma_m_s2, 2);
  StartKind kind = StartKind::kNone;
  if (n > 0) {
    f_mean /= n;
    w_mean /= n;
    const ImuSample mean{t_ns, w_mean, f_mean};
    if (const auto R = attitudeFromAccelerometer(std::span<const ImuSample>(&mean, 1), 0.05)) {
      R_ = *R;
      kind = StartKind::kLevelled;
    }
  }
  if (kind == StartKind::kLevelled && n >= 2) {
    // Still: every sample within 3 sigma of the sensor's white noise around the means, and
    // the mean rate within the bias spread. The mean rate is then the gyro bias.
    const double span_s = 1e-9 * static_cast<double>(last_.t_ns - recent.front().t_ns);
    const double rate_hz = span_s > 0 ? (n - 1) / span_s : params_.noise.rate_hz;
    const double sg = params_.noise.gyroscope_noise_density * std::sqrt(rate_hz);
    const double sa = params_.noise.accelerometer_noise_density * std::sqrt(rate_hz);
    bool still = span_s >= 0.3 && w_mean.norm() < 3 * std::sqrt(3.0) * params_.gyro_bias_sigma_rad_s;
    for (const ImuSample& s : recent)
      if (still && s.t_ns <= t_ns && plausible(s))
        still = (s.gyro_rad_s - w_mean).cwiseAbs().maxCoeff() < 4 * sg &&
                (s.accel_m_s2 - f_mean).cwiseAbs().maxCoeff() < 4 * sa;
    if (still) {
      bg_ = w_mean;
      const double sigma = params_.noise.gyroscope_noise_density / std::sqrt(span_s) +
                           params_.noise.gyroscope_random_walk * std::sqrt(span_s);
      P_.block<3, 3>(kEsBg, kEsBg) = Matrix3d::Identity() * sigma * sigma;
      kind = StartKind::kRest;
    }
  }
  P_.block<3, 3>(kEsTheta, kEsTheta) = tiltCovarianceBody(R_, params_.moving_tilt_sigma_rad);
  clonePose();
  if (have_last_) last_.t_ns = t_ns;
  return kind;
}

void ErrorStateFilter::startFrom(const NavState& state) {
  start(state.t_ns, {});
  R_ = R_clone_ = state.T_W_B.rotation();
  p_ = p_clone_ = state.T_W_B.translation();
  v_ = state.v_W;
  bg_ = state.gyro_bias_rad_s;
  ba_ = state.accel_bias_m_s2;
  P_.block<3, 3>(kEsTheta, kEsTheta) = tiltCovarianceBody(R_, params_.moving_tilt_sigma_rad);
  clonePose();
}

void ErrorStateFilter::step(const Vector3d& w_meas, const Vector3d& a_meas, double dt) {
  // Nominal state (Sola 5.3, midpoint attitude for the specific force).
  const Vector3d w = w_meas - bg_, a = a_meas - ba_;
  const Vector3d dtheta = w * dt;
  const Matrix3d dR = se3::expSO3(dtheta);
  const Matrix3d R_mid = R_ * se3::expSO3(0.5 * dtheta);
  const Vector3d acc_W = R_mid * a + gravityW();
  // Error state (Sola 5.4.3): transition and noise, on the 15 inertial states; the clone
  // does not move, so its rows of F are the identity and only its cross terms change.
  Eigen::Matrix<double, 15, 15> F = Eigen::Matrix<double, 15, 15>::Identity();
  const Matrix3d Ra = R_mid * se3::skew(a);
  F.block<3, 3>(kEsTheta, kEsTheta) = dR.transpose();
  F.block<3, 3>(kEsTheta, kEsBg) = -se3::rightJacobianSO3(dtheta) * dt;
  F.block<3, 3>(kEsVel, kEsTheta) = -Ra * dt;
  F.block<3, 3>(kEsVel, kEsBa) = -R_mid * dt;
  F.block<3, 3>(kEsPos, kEsTheta) = -0.5 * Ra * dt * dt;
  F.block<3, 3>(kEsPos, kEsVel) = Matrix3d::Identity() * dt;
  F.block<3, 3>(kEsPos, kEsBa) = -0.5 * R_mid * dt * dt;
  const ImuNoise& n = params_.noise;
  Eigen::Matrix<double, 15, 1> q = Eigen::Matrix<double, 15, 1>::Zero();
  q.segment<3>(kEsTheta).setConstant(noise_scale_ * n.gyroscope_noise_density * n.gyroscope_noise_density * dt);
  q.segment<3>(kEsVel).setConstant(noise_scale_ * n.accelerometer_noise_density * n.accelerometer_noise_density * dt);
  q.segment<3>(kEsBg).setConstant(n.gyroscope_random_walk * n.gyroscope_random_walk * dt);
  q.segment<3>(kEsBa).setConstant(n.accelerometer_random_walk * n.accelerometer_random_walk * dt);
  const Eigen::Matrix<double, 15, 15> Pii = P_.topLeftCorner<15, 15>();
  P_.topLeftCorner<15, 15>() = F * Pii * F.transpose();
  P_.topLeftCorner<15, 15>().diagonal() += q;
  P_.block<15, 6>(0, 15) = F * P_.block<15, 6>(0, 15);
  P_.block<6, 15>(15, 0) = P_.block<15, 6>(0, 15).transpose();

  p_ += v_ * dt + 0.5 * acc_W * dt * dt;
  v_ += acc_W * dt;
  R_ = R_ * dR;
}

int ErrorStateFilter::propagate(std::span<const ImuSample> samples, int64_t t_end_ns) {
  int used = 0;
  if (!started_ || t_end_ns <= t_ns_) return used;
  for (const ImuSample& s : samples) {
    if (s.t_ns <= t_ns_) continue;
    if (!plausible(s)) {
      // A spike is not integrated: the last good measurement holds over its gap. Counted
      // once, when its time is reached (a later one only interpolates the end).
      if (s.t_ns <= t_end_ns) ++spikes_;
      continue;
    }
    if (!have_last_) {
      last_ = s;
      last_.t_ns = t_ns_;
      have_last_ = true;
    }
    const ImuSample end = s.t_ns <= t_end_ns ? s : lerp(last_, s, t_end_ns);
    step(0.5 * (last_.gyro_rad_s + end.gyro_rad_s), 0.5 * (last_.accel_m_s2 + end.accel_m_s2),
         1e-9 * static_cast<double>(end.t_ns - t_ns_));
    last_ = end;
    t_ns_ = end.t_ns;
    if (s.t_ns > t_end_ns) break;
    ++used;
  }
  if (t_ns_ < t_end_ns) {
    // No sample reaches the end yet: the last measurement is held to it.
    if (have_last_) step(last_.gyro_rad_s, last_.accel_m_s2, 1e-9 * static_cast<double>(t_end_ns - t_ns_));
    t_ns_ = t_end_ns;
    last_.t_ns = t_end_ns;
  }
  P_ = 0.5 * (P_ + P_.transpose());
  return used;
}

RelativeMotion ErrorStateFilter::predictedMotion() const {
  RelativeMotion m;
  m.R_prev_curr = R_clone_.transpose() * R_;
  const Vector3d d_W = p_ - p_clone_;
  m.p_prev_curr = R_clone_.transpose() * d_W;
  Eigen::Matrix<double, 6, kEsDim> H = Eigen::Matrix<double, 6, kEsDim>::Zero();
  H.block<3, 3>(0, kEsTheta) = Matrix3d::Identity();
  H.block<3, 3>(0, kEsCloneTheta) = -m.R_prev_curr.transpose();
  H.block<3, 3>(3, kEsPos) = R_clone_.transpose();
  H.block<3, 3>(3, kEsClonePos) = -R_clone_.transpose();
  H.block<3, 3>(3, kEsCloneTheta) = se3::skew(m.p_prev_curr);
  m.covariance = H * P_ * H.transpose();
  m.covariance = 0.5 * (m.covariance + m.covariance.transpose());
  return m;
}

UpdateOutcome ErrorStateFilter::update(const RelativeMotion& z, double* mahalanobis2) {
  if (!z.R_prev_curr.allFinite() || !z.p_prev_curr.allFinite() || !z.covariance.allFinite())
    return UpdateOutcome::kInvalid;
  const auto residualAndH = [&](Eigen::Matrix<double, 6, 1>& r, Eigen::Matrix<double, 6, kEsDim>& H) {
    const Matrix3d R_pred = R_clone_.transpose() * R_;
    const Vector3d p_pred = R_clone_.transpose() * (p_ - p_clone_);
    r.head<3>() = se3::logSO3(R_pred.transpose() * z.R_prev_curr);
    r.tail<3>() = z.p_prev_curr - p_pred;
    H.setZero();
    H.block<3, 3>(0, kEsTheta) = Matrix3d::Identity();
    H.block<3, 3>(0, kEsCloneTheta) = -R_pred.transpose();
    H.block<3, 3>(3, kEsPos) = R_clone_.transpose();
    H.block<3, 3>(3, kEsClonePos) = -R_clone_.transpose();
    H.block<3, 3>(3, kEsCloneTheta) = se3::skew(p_pred);
  };
  Eigen::Matrix<double, 6, 1> r;
  Eigen::Matrix<double, 6, kEsDim> H;
  residualAndH(r, H);
  Matrix6d S = H * P_ * H.transpose() + z.covariance;
  Eigen::LDLT<Matrix6d> ldlt(S);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return UpdateOutcome::kInvalid;
  const double d2 = r.dot(ldlt.solve(r));
  if (mahalanobis2) *mahalanobis2 = d2;
  UpdateOutcome outcome = UpdateOutcome::kAccepted;
  adaptNoise(d2);
  if (!(d2 <= params_.gate_chi2)) {
    agreed_in_a_row_ = 0;
    // Until the IMU has agreed with vision for imu_fault_refusals frames in a row (start-up,
    // after a fault) the gate does not refuse: a filter with nothing to show yet follows vision.
    if (trusted_) {
      ++refused_;
      ++refused_in_a_row_;
      if (params_.imu_fault_refusals <= 0 || refused_in_a_row_ < params_.imu_fault_refusals)
        return UpdateOutcome::kRefused;
      // Vision has disagreed for imu_fault_refusals frames in a row, each motion passing its
      // own checks: one glitch of vision is refused once, a lasting disagreement is the IMU's.
      ++imu_faults_;
      trusted_ = false;
      reopenInertial();
      outcome = UpdateOutcome::kImuFault;
      S = H * P_ * H.transpose() + z.covariance;
      ldlt.compute(S);
    }
  } else if (params_.imu_fault_refusals > 0 && ++agreed_in_a_row_ >= params_.imu_fault_refusals) {
    trusted_ = true;
  }
  refused_in_a_row_ = 0;
  const Eigen::Matrix<double, kEsDim, 6> K = (ldlt.solve(H * P_)).transpose();
  const EsVector dx = K * r;
  // Joseph form: stays symmetric positive over thousands of updates.
  const EsMatrix IKH = EsMatrix::Identity() - K * H;
  P_ = IKH * P_ * IKH.transpose() + K * z.covariance * K.transpose();
  keepPositive();
  inject(dx);
  return outcome;
}

void ErrorStateFilter::adaptNoise(double d2) {
  // Covariance matching: the squared Mahalanobis distance of a consistent 6-dof innovation has
  // a median of 5.35. An IMU noisier than its datasheet (or integrated from too few samples,
  // KITTI's 10 Hz) keeps it well above that; the white noise is then scaled up until it fits,
  // and back down when it is too pessimistic. The median of the last kNoiseWindow distances
  // is robust to single vision outliers; one step per full window.
  recent_d2_[static_cast<std::size_t>(recent_count_ % kNoiseWindow)] = d2;
  if (++recent_count_ < kNoiseWindow) return;
  std::array<double, kNoiseWindow> sorted = recent_d2_;
  std::nth_element(sorted.begin(), sorted.begin() + kNoiseWindow / 2, sorted.end());
  const double median = sorted[kNoiseWindow / 2];
  constexpr double kChi2Median6 = 5.35;
  if (median > 2.0 * kChi2Median6) {
    noise_scale_ = std::min(2.0 * noise_scale_, kMaxNoiseScale);
  } else if (median < 0.5 * kChi2Median6) {
    noise_scale_ = std::max(0.5 * noise_scale_, 1.0);
  } else {
    return;
  }
  recent_count_ = 0;
}

void ErrorStateFilter::keepPositive() {
  // A visual rotation is known to ~1e-5 rad while the velocity spreads over ~1e-2 m/s: the gain
  // spans ten orders of magnitude and the Joseph form's products, positive in exact
  // arithmetic, round to small negative eigenvalues that propagation then amplifies.
  P_ = positivePart(P_);
  P_ = 0.5 * (P_ + P_.transpose());
}

void ErrorStateFilter::inject(const EsVector& dx) {
  R_ = R_ * se3::expSO3(dx.segment<3>(kEsTheta));
  v_ += dx.segment<3>(kEsVel);
  p_ += dx.segment<3>(kEsPos);
  bg_ += dx.segment<3>(kEsBg);
  ba_ += dx.segment<3>(kEsBa);
  R_clone_ = R_clone_ * se3::expSO3(dx.segment<3>(kEsCloneTheta));
  p_clone_ += dx.segment<3>(kEsClonePos);
  // Re-orthonormalise against round-off.
  R_ = Eigen::Quaterniond(R_).normalized().toRotationMatrix();
  R_clone_ = Eigen::Quaterniond(R_clone_).normalized().toRotationMatrix();
}

void ErrorStateFilter::reopenInertial() {
  const auto reopen = [&](int i, const Matrix3d& C) {
    P_.block<3, kEsDim>(i, 0).setZero();
    P_.block<kEsDim, 3>(0, i).setZero();
    P_.block<3, 3>(i, i) = C;
  };
  reopen(kEsVel, Matrix3d::Identity() * std::pow(params_.initial_velocity_sigma_m_s, 2));
  reopen(kEsBg, Matrix3d::Identity() * std::pow(params_.gyro_bias_sigma_rad_s, 2));
  reopen(kEsBa, Matrix3d::Identity() * std::pow(params_.accel_bias_sigma_m_s2, 2));
  P_.block<3, 3>(kEsTheta, kEsTheta) += tiltCovarianceBody(R_, params_.moving_tilt_sigma_rad);
  // The current pose is whatever the faulty IMU made of the interval: only the clone holds.
  P_.block<3, 3>(kEsTheta, kEsTheta) += Matrix3d::Identity() * 1e-2;
  P_.block<3, 3>(kEsPos, kEsPos) += Matrix3d::Identity() * std::pow(params_.initial_velocity_sigma_m_s, 2);
}

void ErrorStateFilter::clonePose(bool anchor_position) {
  if (anchor_position) {
    P_.block<3, kEsDim>(kEsPos, 0).setZero();
    P_.block<kEsDim, 3>(0, kEsPos).setZero();
  }
  R_clone_ = R_;
  p_clone_ = p_;
  // The clone's error is the pose's: copy the rows and columns (Sola 7: augmentation).
  P_.block<3, kEsDim>(kEsCloneTheta, 0) = P_.block<3, kEsDim>(kEsTheta, 0);
  P_.block<3, kEsDim>(kEsClonePos, 0) = P_.block<3, kEsDim>(kEsPos, 0);
  P_.block<kEsDim, 3>(0, kEsCloneTheta) = P_.block<kEsDim, 3>(0, kEsTheta);
  P_.block<kEsDim, 3>(0, kEsClonePos) = P_.block<kEsDim, 3>(0, kEsPos);
  P_.block<3, 3>(kEsCloneTheta, kEsCloneTheta) = P_.block<3, 3>(kEsTheta, kEsTheta);
  P_.block<3, 3>(kEsCloneTheta, kEsClonePos) = P_.block<3, 3>(kEsTheta, kEsPos);
  P_.block<3, 3>(kEsClonePos, kEsCloneTheta) = P_.block<3, 3>(kEsPos, kEsTheta);
  P_.block<3, 3>(kEsClonePos, kEsClonePos) = P_.block<3, 3>(kEsPos, kEsPos);
}

NavState ErrorStateFilter::state() const {
  NavState s;
  s.t_ns = t_ns_;
  s.T_W_B.linear() = R_;
  s.T_W_B.translation() = p_;
  s.v_W = v_;
  s.gyro_bias_rad_s = bg_;
  s.accel_bias_m_s2 = ba_;
  return s;
}

Matrix6d ErrorStateFilter::poseCovarianceW() const {
  Eigen::Matrix<double, 6, kEsDim> J = Eigen::Matrix<double, 6, kEsDim>::Zero();
  J.block<3, 3>(0, kEsTheta) = R_;
  J.block<3, 3>(3, kEsPos) = Matrix3d::Identity();
  return J * P_ * J.transpose();
}

namespace {

/// The Jacobian from a camera motion's error (left perturbation in the reference camera) to
/// RelativeMotion's body-frame error. Camera motion T = Exp(xi) T_hat: phi, and a translation
/// error rho - [t]x phi. Body motion X T X^-1 (X = T_B_C): its translation moves by
/// R_x dt + [R_B t_x]x R_x phi, its rotation (right, current body) by R_B^T R_x phi.
Matrix6d cameraToBodyJacobian(const Eigen::Isometry3d& T_ref_curr_C, const Eigen::Isometry3d& T_B_C) {
  const Matrix3d Rx = T_B_C.rotation();
  const Vector3d tx = T_B_C.translation();
  const Matrix3d R_B = Rx * T_ref_curr_C.rotation() * Rx.transpose();
  Matrix6d J = Matrix6d::Zero();
  J.topLeftCorner<3, 3>() = R_B.transpose() * Rx;
  J.bottomLeftCorner<3, 3>() = -Rx * se3::skew(T_ref_curr_C.translation()) + se3::skew(R_B * tx) * Rx;
  J.bottomRightCorner<3, 3>() = Rx;
  return J;
}

}  // namespace

Matrix6d cameraToBodyMotionCovariance(const Matrix6d& C, const Eigen::Isometry3d& T_ref_curr_C,
                                      const Eigen::Isometry3d& T_B_C) {
  const Matrix6d J = cameraToBodyJacobian(T_ref_curr_C, T_B_C);
  return J * C * J.transpose();
}

Matrix6d bodyToCameraMotionCovariance(const Matrix6d& B, const Eigen::Isometry3d& T_ref_curr_C,
                                      const Eigen::Isometry3d& T_B_C) {
  const Matrix6d Ji = cameraToBodyJacobian(T_ref_curr_C, T_B_C).inverse();
  return Ji * B * Ji.transpose();
}

}  // namespace seavio::imu
