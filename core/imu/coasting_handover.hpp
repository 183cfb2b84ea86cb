#pragma once
/// The velocity handed over to IMU coasting when vision is lost, measured over a
/// window of visual fixes instead of taken from the last frame.
///
/// The odometry's velocity after a visual fix is the IMU prediction corrected by the whole
/// position residual of that one frame (v += (p_vision - p_predicted) / dt), so a position error
/// of e between two frames 0.1 s apart is a velocity error of 10 e. At the edge of a loss the
/// last fixes are the poorest (fewer features, a fading image), and coasting integrates that
/// velocity error for the whole outage. Here the velocity comes from a straight-line fit over
/// the last `window_s` of visual positions with the IMU's accelerations taken out (the same
/// increments the prediction integrated, paper section III-A), and its covariance from the
/// scatter of those positions about the line: a window of marginal fixes hands over a large
/// uncertainty, a clean one a small one.
#include <array>
#include <cstdint>
#include <optional>

#include <Eigen/Core>

namespace seavio::imu {

/// One visual frame's interval, all in W: from the previous state (a visual fix) to this fix.
struct VisualInterval {
  int64_t t_ns = 0;  ///< this fix [ns]
  /// Visual position change since the previous fix, map corrections excluded [m].
  Eigen::Vector3d displacement = Eigen::Vector3d::Zero();
  Eigen::Vector3d imu_dv = Eigen::Vector3d::Zero();  ///< IMU velocity change over the interval [m/s]
  /// IMU position change over the interval with a zero start velocity [m] (the prediction's
  /// displacement minus start velocity x dt).
  Eigen::Vector3d imu_dp = Eigen::Vector3d::Zero();
};

struct HandoverParams {
  double window_s = 1.0;  ///< fixes no older than this before the last one [s]
  int min_fixes = 4;      ///< fewer contiguous fixes: no estimate (the caller's default applies)
  /// From this many fixes on, the fit is a parabola: it also measures the acceleration the
  /// IMU increments missed (tilt x g, accelerometer bias); 0: never.
  int min_fixes_acceleration = 0;
};

/// The fitted velocity at the last fix.
struct HandoverVelocity {
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();
  /// Of the fit alone (position scatter), per axis and between axes [m^2/s^2].
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  /// The last fix's time minus the fixes' mean time [s]: the fit measures the velocity there,
  /// so the accelerometer-bias and tilt errors of the IMU increments act on it for this long.
  double age_s = 0;
  int fixes = 0;  ///< positions fitted (intervals + 1)
  /// Parabola fits only (age_s is then 0): the acceleration in W the IMU increments missed
  /// over the window [m/s^2], its covariance and its cross-covariance with the velocity
  /// (rows velocity, columns acceleration).
  bool has_acceleration = false;
  Eigen::Vector3d acceleration_error = Eigen::Vector3d::Zero();
  Eigen::Matrix3d acceleration_covariance = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d velocity_acceleration_covariance = Eigen::Matrix3d::Zero();
};

class CoastingHandover {
 public:
  /// The chain of fixes is broken (coasting, no IMU): the next fix starts a new window.
  void reset() {
    count_ = 0;
    anchored_ = false;
  }
  /// A visual fix, with the interval from the previous one. The first fix after reset() only
  /// anchors the window (its interval began at a state that was not a visual fix).
  void add(const VisualInterval& k);
  /// The velocity at the last fix, nullopt with fewer than `p.min_fixes` contiguous fixes.
  std::optional<HandoverVelocity> velocity(const HandoverParams& p) const;

  static constexpr int kCapacity = 64;  ///< intervals kept (6.4 s at 10 Hz); no allocation per frame

 private:
  struct Slot {
    VisualInterval k;
    int64_t t0_ns = 0;  ///< the previous fix
  };
  std::array<Slot, kCapacity> ring_{};
  int head_ = 0;   ///< next slot
  int count_ = 0;  ///< intervals held
  bool anchored_ = false;
  int64_t last_t_ns_ = 0;  ///< the newest fix
};

}  // namespace seavio::imu
