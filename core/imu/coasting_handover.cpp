#include "core/imu/coasting_handover.hpp"

#include <algorithm>

#include <Eigen/LU>

namespace seavio::imu {

void CoastingHandover::add(const VisualInterval& k) {
  if (anchored_ && k.t_ns > last_t_ns_ && k.displacement.allFinite() && k.imu_dv.allFinite() &&
      k.imu_dp.allFinite()) {
    ring_[static_cast<std::size_t>(head_)] = Slot{k, last_t_ns_};
    head_ = (head_ + 1) % kCapacity;
    count_ = std::min(count_ + 1, kCapacity);
  } else {
    // Not chained onto the previous fix (first after reset, or a bad interval): start again.
    count_ = 0;
  }
  anchored_ = true;
  last_t_ns_ = k.t_ns;
}

std::optional<HandoverVelocity> CoastingHandover::velocity(const HandoverParams& p) const {
  // Newest backwards: every interval whose start lies inside the window. The window is not
  // stretched to reach min_fixes at low frame rates: at 1 Hz (1.5 m per frame) a fit over
  // several seconds of a turn, from few and poorly localised fixes (marine snow), handed
  // over a worse velocity than the last frame's (paper-snow at scale 0.1, seed 23: 39
  // IMU-only frames and 6.6 % mean error against 9 and 0.35 % without it). Such rates keep
  // the caller's default.
  const int min_intervals = std::max(p.min_fixes - 1, 2);
  if (count_ < min_intervals) return std::nullopt;
  const auto slot = [&](int back) -> const Slot& {
    return ring_[static_cast<std::size_t>((head_ - 1 - back + 2 * kCapacity) % kCapacity)];
  };
  const int64_t window_ns = static_cast<int64_t>(std::max(p.window_s, 0.0) * 1e9);
  int n = 0;
  while (n < count_ && last_t_ns_ - slot(n).t0_ns <= window_ns) ++n;
  if (n < min_intervals) return std::nullopt;

  // Positions with the IMU's accelerations taken out lie on a straight line whose slope is
  // the velocity at the window's first fix (derivation: the velocity at the start of interval
  // k is u + sum of the IMU velocity changes before it, so Q_k = Q_{k-1} + displacement -
  // imu_dp - (those changes) x dt is u x time plus the position errors).
  constexpr int kMaxPoints = kCapacity + 1;
  std::array<double, kMaxPoints> tau{};
  std::array<Eigen::Vector3d, kMaxPoints> Q{};
  const int64_t t_first = slot(n - 1).t0_ns;
  tau[0] = 0;
  Q[0].setZero();
  Eigen::Vector3d dv_sum = Eigen::Vector3d::Zero();
  for (int j = 1; j <= n; ++j) {
    const Slot& s = slot(n - j);
    const double dt = 1e-9 * static_cast<double>(s.k.t_ns - s.t0_ns);
    Q[static_cast<std::size_t>(j)] = Q[static_cast<std::size_t>(j - 1)] + s.k.displacement - s.k.imu_dp - dv_sum * dt;
    dv_sum += s.k.imu_dv;
    tau[static_cast<std::size_t>(j)] = 1e-9 * static_cast<double>(s.k.t_ns - t_first);
  }
  const int points = n + 1;
  if (p.min_fixes_acceleration > 0 && points >= std::max(p.min_fixes_acceleration, 4)) {
    // Parabola in the time before the last fix, Q = c + u t + a t^2 / 2: u + the IMU's
    // velocity change is the velocity at the last fix, a the acceleration the IMU increments
    // missed (with v_N = u + dv_sum as for the line, see the derivation above).
    const double T = tau[static_cast<std::size_t>(n)];
    Eigen::Matrix3d XtX = Eigen::Matrix3d::Zero();
    Eigen::Matrix3d XtQ = Eigen::Matrix3d::Zero();  // row per parameter, column per axis
    for (int j = 0; j < points; ++j) {
      const double t = tau[static_cast<std::size_t>(j)] - T;
      const Eigen::Vector3d x(1.0, t, 0.5 * t * t);
      XtX += x * x.transpose();
      XtQ += x * Q[static_cast<std::size_t>(j)].transpose();
    }
    const Eigen::Matrix3d M = XtX.inverse();
    const Eigen::Matrix3d B = M * XtQ;  // rows c, u, a
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    for (int j = 0; j < points; ++j) {
      const double t = tau[static_cast<std::size_t>(j)] - T;
      const Eigen::Vector3d x(1.0, t, 0.5 * t * t);
      const Eigen::Vector3d r = Q[static_cast<std::size_t>(j)] - B.transpose() * x;
      scatter += r * r.transpose();
    }
    const Eigen::Matrix3d noise = scatter / (points - 3);
    HandoverVelocity out;
    out.v_W = B.row(1).transpose() + dv_sum;
    out.covariance = M(1, 1) * noise;
    out.has_acceleration = true;
    out.acceleration_error = B.row(2).transpose();
    out.acceleration_covariance = M(2, 2) * noise;
    out.velocity_acceleration_covariance = M(1, 2) * noise;
    out.fixes = points;
    if (!out.v_W.allFinite() || !out.covariance.allFinite() || !out.acceleration_error.allFinite() ||
        !out.acceleration_covariance.allFinite())
      return std::nullopt;
    return out;
  }
  double tau_mean = 0;
  Eigen::Vector3d Q_mean = Eigen::Vector3d::Zero();
  for (int j = 0; j < points; ++j) {
    tau_mean += tau[static_cast<std::size_t>(j)];
    Q_mean += Q[static_cast<std::size_t>(j)];
  }
  tau_mean /= points;
  Q_mean /= points;
  double Stt = 0;
  Eigen::Vector3d StQ = Eigen::Vector3d::Zero();
  for (int j = 0; j < points; ++j) {
    const double d = tau[static_cast<std::size_t>(j)] - tau_mean;
    Stt += d * d;
    StQ += d * (Q[static_cast<std::size_t>(j)] - Q_mean);
  }
  if (!(Stt > 0)) return std::nullopt;
  const Eigen::Vector3d u = StQ / Stt;
  // The scatter of the positions about the line is their noise; the slope's covariance is that
  // over the spread of the fix times (ordinary least squares, points - 2 degrees of freedom).
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (int j = 0; j < points; ++j) {
    const Eigen::Vector3d r =
        Q[static_cast<std::size_t>(j)] - Q_mean - u * (tau[static_cast<std::size_t>(j)] - tau_mean);
    scatter += r * r.transpose();
  }
  HandoverVelocity out;
  out.v_W = u + dv_sum;
  out.covariance = scatter / (std::max(points - 2, 1) * Stt);
  out.age_s = tau[static_cast<std::size_t>(n)] - tau_mean;
  out.fixes = points;
  if (!out.v_W.allFinite() || !out.covariance.allFinite()) return std::nullopt;
  return out;
}

}  // namespace seavio::imu
