#pragma once
/// The acceleration the IMU prediction misses (tilt x g, accelerometer bias), measured from the
/// innovations of several recent visual fixes that agree, for coasting at low frame rates
/// (the 1 Hz paper survey's coasted frames).
///
/// After a visual fix the odometry's velocity is the prediction's corrected by the whole
/// position residual over dt (odometry.cpp). With an acceleration error `a` constant over two
/// intervals, that velocity is then low by a * dt / 2 and the next prediction misses by
/// a * dt_prev * dt / 2 + a * dt^2 / 2 (a * dt^2 at a steady rate; prediction_innovation.hpp).
/// Coasting from that state without a correction misses by k * a * dt^2 on the k-th frame in a
/// row (0.48 m per step on paper-snow). The coasting handover fit (coasting_handover.hpp) would
/// measure `a`, but it needs fixes within seconds and never runs at 1 Hz; a single fix's
/// innovation is no substitute: after a loss the fixes are poor, and one poor fix's miss
/// applied k times made the survey worse (docs/architecture.md). So `a` is taken from the
/// last few steady fixes only if most of them agree with their median (direction and size) and
/// it is a plausible tilt/bias; otherwise coasting gets no correction, only the covariance of a
/// leak as large as the fixes measured.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>

#include <Eigen/Core>

namespace seavio::imu {

struct LeakParams {
  /// Fixes over shorter intervals are not used: at 10 Hz the leak (mm) is below the visual
  /// noise, and the handover fit measures it there.
  double min_interval_s = 0.5;
  int window_fixes = 5;      ///< the most recent steady fixes considered
  int min_agreeing = 3;      ///< at least this many (and a majority) agree with the median
  /// Agreement: within this fraction of the median's norm, or `tolerance_floor_m_s2`.
  double tolerance_fraction = 0.3;
  double tolerance_floor_m_s2 = 0.05;
  /// A larger median is not a tilt or bias (6 deg of tilt): no correction [m/s^2].
  double max_acceleration_m_s2 = 1.0;
  double max_age_s = 30.0;             ///< fixes older than this before the loss are stale [s]
  double sigma_floor_m_s2 = 0.02;      ///< least standard deviation of an applied estimate [m/s^2]
};

struct LeakEstimate {
  /// True: the fixes agree and `acceleration_W` is the correction; false: it is zero and
  /// `covariance` is the leak's second moment (what the uncorrected coasting may carry).
  bool consistent = false;
  Eigen::Vector3d acceleration_W = Eigen::Vector3d::Zero();  ///< [m/s^2]
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();       ///< of the correction's error [m^2/s^4]
  /// The state's velocity after the last fix is low by the leak times this [s] (dt / 2).
  double velocity_lag_s = 0;
  int used = 0;      ///< fixes considered
  int agreeing = 0;  ///< of them, agreeing with the median
};

class CoastingLeak {
 public:
  /// A visual fix at `t_ns` with its innovation (vision minus prediction, map corrections
  /// excluded) [m, W] over `dt_s`. Only a fix that follows a fix is steady (the velocity the
  /// prediction started from carried the dt / 2 lag); the first fix after a loss or reset
  /// only restores that.
  void fix(const Eigen::Vector3d& innovation_W, double dt_s, int64_t t_ns) {
    if (dt_s <= 0) {
      reset();
      return;
    }
    if (last_dt_s_ > 0) {
      Sample& s = ring_[static_cast<std::size_t>(head_)];
      s = {t_ns, dt_s, innovation_W / (0.5 * dt_s * (last_dt_s_ + dt_s))};
      head_ = (head_ + 1) % kCapacity;
      count_ = std::min(count_ + 1, kCapacity);
    }
    last_dt_s_ = dt_s;
  }
  /// A frame without a visual fix: the next fix's innovation carries the coasting's error.
  void coast() { last_dt_s_ = 0; }
  /// The IMU chain is broken: nothing measured so far applies.
  void reset() {
    last_dt_s_ = 0;
    count_ = 0;
  }
  /// The leak at a loss at `t_ns` (call at the first lost frame, before coast()), from the last
  /// steady fixes; nullopt without any, or if the last frame was no fix over a long interval.
  std::optional<LeakEstimate> estimate(int64_t t_ns, const LeakParams& p) const {
    const double last_fix_dt_s = last_dt_s_;
    std::array<Eigen::Vector3d, kCapacity> a{};
    int n = 0;
    for (int i = 0; i < count_ && n < std::min(p.window_fixes, kCapacity); ++i) {
      const Sample& s = ring_[static_cast<std::size_t>((head_ - 1 - i + kCapacity) % kCapacity)];
      if (1e-9 * static_cast<double>(t_ns - s.t_ns) > p.max_age_s) break;
      if (s.dt_s < p.min_interval_s) continue;
      a[static_cast<std::size_t>(n++)] = s.acceleration_W;
    }
    if (n == 0 || last_fix_dt_s < p.min_interval_s) return std::nullopt;
    LeakEstimate e;
    e.used = n;
    e.velocity_lag_s = 0.5 * last_fix_dt_s;
    // Component-wise median: one poor fix cannot move it.
    Eigen::Vector3d median;
    for (int axis = 0; axis < 3; ++axis) {
      std::array<double, kCapacity> c{};
      for (int i = 0; i < n; ++i) c[static_cast<std::size_t>(i)] = a[static_cast<std::size_t>(i)][axis];
      std::sort(c.begin(), c.begin() + n);
      median[axis] = n % 2 ? c[static_cast<std::size_t>(n / 2)]
                           : 0.5 * (c[static_cast<std::size_t>(n / 2 - 1)] + c[static_cast<std::size_t>(n / 2)]);
    }
    const double tolerance = std::max(p.tolerance_fraction * median.norm(), p.tolerance_floor_m_s2);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d second = Eigen::Matrix3d::Zero();  // of all fixes, about zero
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d& ai = a[static_cast<std::size_t>(i)];
      second += ai * ai.transpose() / n;
      if ((ai - median).norm() <= tolerance) {
        sum += ai;
        ++e.agreeing;
      }
    }
    e.consistent = e.agreeing >= p.min_agreeing && 2 * e.agreeing > n && median.norm() <= p.max_acceleration_m_s2;
    if (!e.consistent) {
      e.covariance = second;
      return e;
    }
    e.acceleration_W = sum / e.agreeing;
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d d = a[static_cast<std::size_t>(i)] - e.acceleration_W;
      if ((a[static_cast<std::size_t>(i)] - median).norm() <= tolerance) scatter += d * d.transpose();
    }
    // The mean's error from the agreeing fixes' scatter, never below the floor (the leak
    // drifts as the vehicle turns; a few fixes that agree by chance).
    e.covariance = scatter / (e.agreeing * std::max(e.agreeing - 1, 1)) +
                   Eigen::Matrix3d::Identity() * p.sigma_floor_m_s2 * p.sigma_floor_m_s2;
    return e;
  }

  static constexpr int kCapacity = 16;

 private:
  struct Sample {
    int64_t t_ns = 0;
    double dt_s = 0;
    Eigen::Vector3d acceleration_W = Eigen::Vector3d::Zero();
  };
  std::array<Sample, kCapacity> ring_{};
  int head_ = 0;
  int count_ = 0;
  double last_dt_s_ = 0;
};

}  // namespace seavio::imu
