#include "daemon/frame_processor.hpp"

#include <cmath>

namespace seavio::daemon {

OdometryResult ImuDeadReckoningProcessor::process(const StereoFrame& frame,
                                                  std::span<const ImuSample> imu) {
  OdometryResult r;
  r.t_ns = frame.t_ns;
  r.seq = frame.seq;
  if (!have_state_) {
    have_state_ = true;
    state_ = NavState{};
    state_.t_ns = frame.t_ns;
    r.source = PoseSource::kInit;
    r.covariance = Eigen::Matrix<double, 6, 6>::Identity() * 1e-6;
    return r;
  }
  const Eigen::Vector3d g_W(0, 0, -imu::kGravity_m_s2);
  for (const ImuSample& s : imu) {
    if (s.t_ns <= state_.t_ns) continue;
    const double dt = static_cast<double>(std::min(s.t_ns, frame.t_ns) - state_.t_ns) * 1e-9;
    const Eigen::Vector3d w = s.gyro_rad_s * dt;
    const Eigen::Matrix3d R = state_.T_W_B.linear();
    const Eigen::Vector3d a_W = R * s.accel_m_s2 + g_W;
    state_.T_W_B.translation() += state_.v_W * dt + 0.5 * a_W * dt * dt;
    state_.v_W += a_W * dt;
    if (w.norm() > 0) {
      state_.T_W_B.linear() = R * Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
    }
    state_.t_ns = std::min(s.t_ns, frame.t_ns);
    elapsed_s_ += dt;
  }
  r.T_W_B = state_.T_W_B;
  r.v_W = state_.v_W;
  // Random-walk growth: rotation ~ gyro noise * sqrt(t), position ~ accel noise * t^1.5.
  const double sg = noise_.gyroscope_noise_density * std::sqrt(elapsed_s_);
  const double sa = noise_.accelerometer_noise_density * std::pow(elapsed_s_, 1.5);
  r.covariance.setZero();
  r.covariance.diagonal() << sg * sg, sg * sg, sg * sg, sa * sa, sa * sa, sa * sa;
  r.covariance.diagonal().array() += 1e-9;
  r.source = PoseSource::kImuOnly;
  return r;
}

}  // namespace seavio::daemon
