#include "core/imu/gravity_bias_observer.hpp"

#include <cmath>
#include <numbers>

#include "core/imu/imu_integrator.hpp"

namespace seavio::imu {
namespace {

/// Heading of the body's x axis in W's horizontal plane (body z is up when level).
double heading(const Eigen::Matrix3d& R_W_B) { return std::atan2(R_W_B(1, 0), R_W_B(0, 0)); }

double angleBetween(double a, double b) {
  return std::abs(std::remainder(a - b, 2.0 * std::numbers::pi));
}

}  // namespace

void GravityBiasObserver::reset() {
  open_.reset();
  last_closed_.reset();
  last_pair_.reset();
}

void GravityBiasObserver::moveChain(const Eigen::Isometry3d& delta_W) {
  const Eigen::Matrix3d dR = delta_W.linear();
  const double d_heading = heading(dR);
  auto move = [&](Window& w) {
    w.p0_W = delta_W * w.p0_W;
    w.p1_W = delta_W * w.p1_W;
    w.I1 = dR * w.I1;
    w.I2 = dR * w.I2;
    w.R1_W_B = dR * w.R1_W_B;
    w.heading0 += d_heading;
    w.heading1 = heading(w.R1_W_B);
  };
  if (open_) move(*open_);
  if (last_closed_) move(*last_closed_);
  if (last_pair_) {
    // m_B = R^T ((J - dV) / weight + g): J and dV turn with the frame, gravity does not.
    last_pair_->m_B += last_pair_->R_W_B.transpose() * (dR.transpose() - Eigen::Matrix3d::Identity()) * gravityW();
    last_pair_->R_W_B = dR * last_pair_->R_W_B;
    last_pair_->heading_first += d_heading;
  }
}

std::optional<Eigen::Vector3d> GravityBiasObserver::add(int64_t t0_ns, const Eigen::Vector3d& p0_W, int64_t t1_ns,
                                                        const Eigen::Vector3d& p1_W, const Eigen::Matrix3d& R_mid_W_B,
                                                        const Eigen::Vector3d& f_B, const Eigen::Matrix3d& R1_W_B) {
  if (t1_ns <= t0_ns || !f_B.allFinite() || !p0_W.allFinite() || !p1_W.allFinite()) {
    reset();
    return std::nullopt;
  }
  if (open_ && open_->t1_ns != t0_ns) reset();  // a gap: the windows no longer chain
  if (!open_) {
    open_ = Window{};
    open_->t0_ns = open_->t1_ns = t0_ns;
    open_->p0_W = p0_W;
    // The heading at the window's start: this interval's middle is the closest we have.
    open_->heading0 = heading(R_mid_W_B);
  }
  Window& w = *open_;
  const double dt = 1e-9 * static_cast<double>(t1_ns - t0_ns);
  const double t_mid = 1e-9 * static_cast<double>(t0_ns - w.t0_ns) + 0.5 * dt;
  const Eigen::Vector3d F = R_mid_W_B * f_B * dt;
  w.I1 += F;
  w.I2 += t_mid * F;
  w.t1_ns = t1_ns;
  w.p1_W = p1_W;
  w.heading1 = heading(R1_W_B);
  w.R1_W_B = R1_W_B;
  ++w.intervals;
  if (1e-9 * static_cast<double>(w.t1_ns - w.t0_ns) < params_.window_s || w.intervals < params_.min_intervals)
    return std::nullopt;

  // The window closes. With the one before it, it is a pair: the difference of their mean
  // velocities is the acceleration weighted by a triangle peaking at their boundary, and the
  // same triangle over R f is what the IMU says that acceleration was, minus gravity.
  Window closed = std::move(*open_);
  open_.reset();
  std::optional<Eigen::Vector3d> rate;
  if (last_closed_ && last_closed_->t1_ns == closed.t0_ns) {
    const Window& a = *last_closed_;
    const double Ta = 1e-9 * static_cast<double>(a.t1_ns - a.t0_ns);
    const double Tb = 1e-9 * static_cast<double>(closed.t1_ns - closed.t0_ns);
    const Eigen::Vector3d dV = (closed.p1_W - closed.p0_W) / Tb - (a.p1_W - a.p0_W) / Ta;
    // Triangle: rising (t - t0) / Ta over the first window, falling (t1 - t) / Tb over the
    // second; its integral is (Ta + Tb) / 2.
    const Eigen::Vector3d J = a.I2 / Ta + (Tb * closed.I1 - closed.I2) / Tb;
    const double weight = 0.5 * (Ta + Tb);
    const Eigen::Vector3d r_W = (J - dV) / weight + gravityW();
    PairResidual pair;
    pair.t_ns = closed.t0_ns;
    pair.m_B = a.R1_W_B.transpose() * r_W;
    pair.R_W_B = a.R1_W_B;
    pair.heading_first = a.heading0;
    if (last_pair_) {
      // Three windows: the previous pair's first start, and the ends of the three windows.
      const double h0 = last_pair_->heading_first;
      const bool straight = angleBetween(a.heading0, h0) <= params_.max_turn_rad &&
                            angleBetween(a.heading1, h0) <= params_.max_turn_rad &&
                            angleBetween(closed.heading1, h0) <= params_.max_turn_rad;
      const double dt_pairs = 1e-9 * static_cast<double>(pair.t_ns - last_pair_->t_ns);
      if (straight && dt_pairs > 0) {
        // m_B = (R^T tilt) x g z_B + b_acc: its change is (b_true - b_est) x z_B g over dt.
        const Eigen::Vector3d z_B = a.R1_W_B.transpose() * Eigen::Vector3d::UnitZ();
        const Eigen::Vector3d d = (pair.m_B - last_pair_->m_B) / (dt_pairs * kGravity_m_s2);
        const Eigen::Vector3d eps = z_B.cross(d);
        if (eps.allFinite() && eps.norm() <= params_.max_rate_rad_s) rate = eps;
      }
    }
    last_pair_ = pair;
  } else {
    last_pair_.reset();
  }
  last_closed_ = std::move(closed);
  return rate;
}

}  // namespace seavio::imu
