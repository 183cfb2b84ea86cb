#include "tools/simulate/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace seavio::simulate {
namespace {

constexpr double kPi = std::numbers::pi;

/// Quintic smoothstep and its derivative and integral on [0, 1] (C2 joins).
double smooth(double u) { return u * u * u * (10 + u * (-15 + 6 * u)); }
double smoothDeriv(double u) { return 30 * u * u * (1 - u) * (1 - u); }
double smoothIntegral(double u) { return u * u * u * u * (2.5 + u * (-3 + u)); }

/// Yaw-rate profile of one pulse (up ramp, plateau, down ramp) and its integral.
void pulseProfile(double tau, double ramp, double plateau, double* f, double* F) {
  if (tau <= 0) {
    *f = 0, *F = 0;
  } else if (tau < ramp) {
    *f = smooth(tau / ramp), *F = ramp * smoothIntegral(tau / ramp);
  } else if (tau < ramp + plateau) {
    *f = 1, *F = 0.5 * ramp + (tau - ramp);
  } else if (tau < 2 * ramp + plateau) {
    const double u = (tau - ramp - plateau) / ramp;
    *f = smooth(1 - u);
    *F = 0.5 * ramp + plateau + ramp * (0.5 - smoothIntegral(1 - u));
  } else {
    *f = 0, *F = ramp + plateau;
  }
}

}  // namespace

Eigen::Isometry3d BodyState::T_W_B() const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R_W_B;
  T.translation() = p_W;
  return T;
}

Trajectory::Trajectory(const TrajectoryConfig& c, const ReliefField& relief, double duration_s)
    : config_(c), relief_(relief), duration_s_(duration_s), span_s_(duration_s - c.begin_s) {
  z_const_ = relief.eval(0, 0).h + c.altitude_m;
  const double V = c.speed_m_s;
  // Turn: two 90 deg pulses with a straight crossing between them. Start from the yaw rate
  // of a semicircle of one lane spacing and raise it (up to the limit) until pulse + pulse
  // fits in the spacing, since the ramps widen the turn.
  const double accel = c.unlimited_turn_rate ? 10.0 : c.max_yaw_accel_rad_s2;
  const double max_rate = c.unlimited_turn_rate ? 1.0 : c.max_yaw_rate_rad_s;
  // Unlimited (the paper's): pivot at 1 rad/s, cross straight, pivot again.
  double rate = c.unlimited_turn_rate ? max_rate : std::min(max_rate, 2 * V / c.leg_spacing_m);
  double ramp = 0, plateau = 0, fwd = 0, lat = 0;
  for (int attempt = 0; attempt < 200; ++attempt) {
    ramp = rate / accel;
    plateau = kPi / 2 / rate - ramp;
    if (plateau < 0) {
      ramp = std::sqrt(kPi / 2 / accel);
      rate = accel * ramp;
      plateau = 0;
    }
    // Forward and lateral displacement of one pulse at cruise speed (Simpson).
    fwd = lat = 0;
    const int n = 2000;
    const double h = (2 * ramp + plateau) / n;
    for (int i = 0; i <= n; ++i) {
      double f, F;
      pulseProfile(i * h, ramp, plateau, &f, &F);
      const double w = (i == 0 || i == n) ? 1 : (i % 2 ? 4 : 2);
      fwd += w * V * std::cos(rate * F) * h / 3;
      lat += w * V * std::sin(rate * F) * h / 3;
    }
    if (fwd + lat <= c.leg_spacing_m || rate >= max_rate || plateau == 0) break;
    rate = std::min(max_rate, rate * 1.03);
  }
  const double turn_time = 2 * ramp + plateau;
  const double crossing = std::max(0.0, c.leg_spacing_m - fwd - lat) / V;
  planLanes(V, ramp, plateau, rate, turn_time, crossing, fwd, lat);
  if (c.tie_lines || c.return_to_start) planTieAndReturn(V, ramp, plateau, rate, fwd, lat);
  if (c.hover_s > 0) {
    // The stop costs one ramp (two half-speed ramps) plus the hold: later turns move by it,
    // so the lanes keep their geometry.
    const double tau_h = c.hover_start_s - c.begin_s;
    for (auto& p : pulses_)
      if (p.t0 >= tau_h) p.t0 += c.hover_ramp_s + c.hover_s;
    hover_on_ = true;
  }
  const auto n = static_cast<size_t>(std::ceil(span_s_ / knot_dt_)) + 2;
  knots_.resize(n);
  knots_[0] = Eigen::Vector2d::Zero();
  for (size_t k = 1; k < n; ++k)
    knots_[k] = knots_[k - 1] + integrate((k - 1) * knot_dt_, k * knot_dt_);
}

void Trajectory::planLanes(double V, double ramp, double plateau, double rate, double turn_time, double crossing,
                           double fwd, double lat) {
  const auto& c = config_;
  const double radius = 0.5 * (fwd + lat);  // forward overshoot of a turn, roughly
  // Lanes bounce 0, 1, ..., legs-1, legs-2, ..., 0, 1, ... so the survey stays in its box;
  // with a tie line or a return the lanes are flown once and the plan continues from there.
  const bool once = c.tie_lines || c.return_to_start;
  double t = c.still_s + c.accel_s + (c.leg_length_m - 0.5 * V * c.accel_s - radius) / V;
  int lane = 0, dir = 1;
  bool heading_plus_x = true;
  while (once ? lane + 1 < c.legs : t < span_s_ + 1.0) {
    if (c.legs == 1) dir = (lane == 0) ? 1 : -1;
    else if (lane + dir < 0 || lane + dir >= c.legs) dir = -dir;
    const double sign = (heading_plus_x ? 1.0 : -1.0) * dir;
    pulses_.push_back({t, ramp, plateau, rate, sign});
    pulses_.push_back({t + turn_time + crossing, ramp, plateau, rate, sign});
    lane += dir;
    heading_plus_x = !heading_plus_x;
    t += 2 * turn_time + crossing + (c.leg_length_m - 2 * radius) / V;
  }
  plan_end_s_ = t;
}

void Trajectory::planTieAndReturn(double V, double ramp, double plateau, double rate, double fwd, double lat) {
  const auto& c = config_;
  // Where the last lane's turn would begin: exact pose from the lanes planned so far.
  double tau = plan_end_s_;
  Eigen::Vector2d P = integrate(0.0, tau);
  double psi, r;
  yaw(tau, &psi, &r);
  Eigen::Vector2d h(std::round(std::cos(psi)), std::round(std::sin(psi)));
  const double turn_time = 2 * ramp + plateau;
  // Turn 90 deg towards `to` so that the position along the old heading ends at `target`.
  auto turnAt = [&](const Eigen::Vector2d& to, double target) {
    const double dist = std::max(0.0, target - P.dot(h) - fwd);
    tau += dist / V;
    P += dist * h;
    const double side = h.x() * to.y() - h.y() * to.x();
    pulses_.push_back({tau, ramp, plateau, rate, side});
    P += fwd * h + lat * to;
    h = to;
    tau += turn_time;
  };
  const Eigen::Vector2d ex(1, 0), ey(0, 1);
  const double L = c.leg_length_m, s = c.leg_spacing_m, approach = lat + 2.0;
  if (c.tie_lines) {
    // Out to a lane beyond the block, back to its middle, then across every lane.
    const double hx = h.x();
    turnAt(ey, P.dot(h) + fwd);
    turnAt(-hx * ex, c.legs * s);
    turnAt(-ey, -hx * 0.5 * L);  // along -hx: coordinate -x, so target -L/2
    if (c.return_to_start) turnAt(-ex, 0.0);  // onto the first lane's line, back over the start
  } else {
    // Past the block's end, across to the first lane's line, along it over the start.
    const double hx = h.x();
    turnAt(-ey, hx > 0 ? L + approach : approach);
    turnAt(-hx * ex, 0.0);
  }
}

void Trajectory::speed(double tau, double* s, double* ds) const {
  const double V = config_.speed_m_s;
  const double u = (tau - config_.still_s) / config_.accel_s;
  if (u <= 0) *s = 0, *ds = 0;
  else if (u >= 1) *s = V, *ds = 0;
  else *s = V * smooth(u), *ds = V * smoothDeriv(u) / config_.accel_s;
  if (!hover_on_) return;
  // Stop and hover: the speed times a factor going 1 -> 0, held, 0 -> 1.
  const double r = config_.hover_ramp_s, t0 = config_.hover_start_s - config_.begin_s;
  const double t1 = t0 + r + config_.hover_s;
  double f = 1, df = 0;
  if (tau > t0 && tau < t0 + r) f = 1 - smooth((tau - t0) / r), df = -smoothDeriv((tau - t0) / r) / r;
  else if (tau >= t0 + r && tau <= t1) f = 0;
  else if (tau > t1 && tau < t1 + r) f = smooth((tau - t1) / r), df = smoothDeriv((tau - t1) / r) / r;
  *ds = *ds * f + *s * df;
  *s *= f;
}

void Trajectory::yaw(double t, double* psi, double* rate) const {
  *psi = 0;
  *rate = 0;
  for (const auto& p : pulses_) {
    if (t <= p.t0) break;
    double f, F;
    pulseProfile(t - p.t0, p.ramp, p.plateau, &f, &F);
    *psi += p.sign * p.rate * F;
    *rate += p.sign * p.rate * f;
  }
}

Eigen::Vector2d Trajectory::horizontalVelocity(double t) const {
  double s, ds, psi, r;
  speed(t, &s, &ds);
  yaw(t, &psi, &r);
  return s * Eigen::Vector2d(std::cos(psi), std::sin(psi));
}

Eigen::Vector2d Trajectory::integrate(double a, double b) const {
  static constexpr double x[5] = {0.0, -0.5384693101056831, 0.5384693101056831, -0.9061798459386640,
                                  0.9061798459386640};
  static constexpr double w[5] = {0.5688888888888889, 0.4786286704993665, 0.4786286704993665,
                                  0.2369268850561891, 0.2369268850561891};
  // Split at the smoothness breaks (ends of ramps) inside [a, b] so each piece is polynomial-smooth.
  std::vector<double> cuts{a, b};
  auto add = [&](double c) {
    if (c > a && c < b) cuts.push_back(c);
  };
  add(config_.still_s);
  add(config_.still_s + config_.accel_s);
  if (hover_on_) {
    const double t0 = config_.hover_start_s - config_.begin_s, r = config_.hover_ramp_s;
    add(t0), add(t0 + r), add(t0 + r + config_.hover_s), add(t0 + 2 * r + config_.hover_s);
  }
  for (const auto& p : pulses_) {
    add(p.t0), add(p.t0 + p.ramp), add(p.t0 + p.ramp + p.plateau), add(p.t0 + 2 * p.ramp + p.plateau);
  }
  std::sort(cuts.begin(), cuts.end());
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (size_t k = 0; k + 1 < cuts.size(); ++k) {
    const double m = 0.5 * (cuts[k] + cuts[k + 1]), h = 0.5 * (cuts[k + 1] - cuts[k]);
    for (int i = 0; i < 5; ++i) sum += w[i] * h * horizontalVelocity(m + h * x[i]);
  }
  return sum;
}

void Trajectory::swayAndWaves(double t, double g, double dg, Eigen::Vector3d* ang, Eigen::Vector3d* rate,
                              double* heave, double* dheave, double* ddheave) const {
  // Sway fades in with speed (g = speed / cruise) so the vehicle is perfectly still at the start.
  const auto& c = config_;
  const double wr = 2 * kPi / c.roll_period_s, wp = 2 * kPi / c.pitch_period_s;
  const double Ar = c.roll_amplitude_deg * kPi / 180, Ap = c.pitch_amplitude_deg * kPi / 180;
  double roll = Ar * g * std::sin(wr * t), droll = Ar * (dg * std::sin(wr * t) + g * wr * std::cos(wr * t));
  double pitch = Ap * g * std::sin(wp * t + 1.0),
         dpitch = Ap * (dg * std::sin(wp * t + 1.0) + g * wp * std::cos(wp * t + 1.0));
  *heave = *dheave = *ddheave = 0;
  for (const auto& w : c.waves) {
    const double om = 2 * kPi / w.period_s, ph = om * t + w.phase_rad;
    const double ar = w.roll_deg * kPi / 180, ap = w.pitch_deg * kPi / 180;
    roll += ar * std::sin(ph), droll += ar * om * std::cos(ph);
    pitch += ap * std::sin(ph - 1.0), dpitch += ap * om * std::cos(ph - 1.0);
    *heave += w.heave_m * std::sin(ph - 2.0);
    *dheave += w.heave_m * om * std::cos(ph - 2.0);
    *ddheave -= w.heave_m * om * om * std::sin(ph - 2.0);
  }
  *ang = {roll, pitch, 0};
  *rate = {droll, dpitch, 0};
}

BodyState Trajectory::at(double t) const {
  BodyState st;
  st.t_s = t;
  const double tau = t - config_.begin_s;  // path time: the plan's clock
  const double tc = std::clamp(tau, 0.0, span_s_ + 0.5);
  const auto k = std::min(static_cast<size_t>(tc / knot_dt_), knots_.size() - 1);
  const Eigen::Vector2d pxy = knots_[k] + integrate(k * knot_dt_, tau);
  double s, ds, psi, r;
  speed(tau, &s, &ds);
  yaw(tau, &psi, &r);
  const Eigen::Vector2d e(std::cos(psi), std::sin(psi)), n(-std::sin(psi), std::cos(psi));
  const Eigen::Vector2d vxy = s * e, axy = ds * e + s * r * n;
  double z = z_const_, vz = 0, az = 0;
  if (config_.follow_altitude) {
    const auto H = relief_.eval(pxy.x(), pxy.y());
    z = H.h + config_.altitude_m;
    vz = H.hx * vxy.x() + H.hy * vxy.y();
    az = H.hxx * vxy.x() * vxy.x() + 2 * H.hxy * vxy.x() * vxy.y() + H.hyy * vxy.y() * vxy.y() +
         H.hx * axy.x() + H.hy * axy.y();
  }
  Eigen::Vector3d ang, dang;
  double heave, dheave, ddheave;
  swayAndWaves(t, s / config_.speed_m_s, ds / config_.speed_m_s, &ang, &dang, &heave, &dheave, &ddheave);
  st.p_W = {pxy.x(), pxy.y(), z + heave};
  st.v_W = {vxy.x(), vxy.y(), vz + dheave};
  st.a_W = {axy.x(), axy.y(), az + ddheave};
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(psi, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3d Ry = Eigen::AngleAxisd(ang.y(), Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Matrix3d Rx = Eigen::AngleAxisd(ang.x(), Eigen::Vector3d::UnitX()).toRotationMatrix();
  st.R_W_B = Rz * Ry * Rx;
  st.omega_B = Rx.transpose() * Ry.transpose() * Eigen::Vector3d(0, 0, r) +
               Rx.transpose() * Eigen::Vector3d(0, dang.y(), 0) + Eigen::Vector3d(dang.x(), 0, 0);
  return st;
}

double Trajectory::length() const {
  // From the first frame (t = 0) on.
  double len = 0;
  const double dt = 0.5, end = span_s_;
  for (double tau = -config_.begin_s; tau < end; tau += dt) len += integrate(tau, std::min(tau + dt, end)).norm();
  return len;
}

}  // namespace seavio::simulate
