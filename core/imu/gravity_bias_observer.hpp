#pragma once
/// The roll/pitch part of the gyro bias from the accelerometer's gravity.
///
/// Over a flat floor the visual rotation couples pitch with surge (the pitch/surge ambiguity
/// the gyro prior resolves, paper III-C), so a gyro bias learnt from it inherits a pitch rate
/// proportional to speed. Gravity observes the tilt rates without that coupling: over
/// contiguous windows of visual tracking, the specific force the IMU measured, turned into W
/// with the chain's attitude, is compared with the acceleration vision measured (the change of
/// the windows' mean velocities) minus gravity (paper III-A: the same terms the dead reckoning
/// integrates). What is left is the chain's tilt error times g plus the accelerometer bias. The
/// bias is constant in the body frame and, while the heading holds, so is its image in W; it
/// does not change from one window pair to the next, the tilt error does. So the change of the
/// residual in the body frame between consecutive pairs is the chain's tilt rate, i.e. the
/// error of the horizontal gyro bias, without the accelerometer bias having to be known. Only
/// the accelerometer bias' random walk (about 3e-4 rad/s per sqrt(s) / window in the
/// simulator) and vision's velocity noise remain in it. Across a turn the W image of the
/// accelerometer bias rotates, so pairs spanning a heading change are not compared.
#include <cstdint>
#include <optional>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace seavio::imu {

struct GravityBiasObserverParams {
  double window_s = 2.0;        ///< length of one window [s]; a pair is two, a rate needs three
  double max_turn_rad = 0.05;   ///< largest heading change over the three windows of a rate
  double max_rate_rad_s = 5e-3; ///< a larger tilt rate is a glitch of the chain, not a bias
  /// A window also spans at least this many visual intervals: at 1 Hz a 1 s window would be a
  /// single frame step, whose mean velocity carries one step's full visual noise.
  int min_intervals = 1;
};

class GravityBiasObserver {
 public:
  explicit GravityBiasObserver(GravityBiasObserverParams params = {}) : params_(params) {}

  /// One interval [t0, t1] tracked by vision: the chain's positions at both ends, its attitude
  /// (W <- B) at the middle and at t1, and the mean specific force over the interval in the
  /// body frame (accelerometer minus its estimated bias). An interval that does not start where
  /// the last one ended starts afresh. Returns, when a window closes and the heading held over
  /// the last three windows, the tilt-rate error of the chain: (true - estimated) gyro bias,
  /// its component perpendicular to gravity, body frame [rad/s].
  std::optional<Eigen::Vector3d> add(int64_t t0_ns, const Eigen::Vector3d& p0_W, int64_t t1_ns,
                                     const Eigen::Vector3d& p1_W, const Eigen::Matrix3d& R_mid_W_B,
                                     const Eigen::Vector3d& f_B, const Eigen::Matrix3d& R1_W_B);
  /// Forget everything (vision lost, a gap).
  void reset();
  /// A map correction moved the chain rigidly by `delta_W` (corrected <- uncorrected world):
  /// the stored windows are re-expressed in the corrected frame, so that the next interval,
  /// which ends at a corrected pose, still chains on. The correction's tilt is not a gyro
  /// bias: the last pair's residual is re-expressed too, so the next rate does not see the
  /// step. (Resetting instead froze the tilt rates wherever the map corrects every frame, as
  /// it does at 1 Hz once the survey comes back over mapped ground.)
  void moveChain(const Eigen::Isometry3d& delta_W);

 private:
  struct Window {
    int64_t t0_ns = 0, t1_ns = 0;
    Eigen::Vector3d p0_W = Eigen::Vector3d::Zero(), p1_W = Eigen::Vector3d::Zero();
    Eigen::Vector3d I1 = Eigen::Vector3d::Zero();  ///< integral of R f dt [m/s]
    Eigen::Vector3d I2 = Eigen::Vector3d::Zero();  ///< integral of (t - t0) R f dt [m]
    double heading0 = 0, heading1 = 0;             ///< at both ends [rad]
    int intervals = 0;                             ///< visual intervals added
    Eigen::Matrix3d R1_W_B = Eigen::Matrix3d::Identity();
  };
  struct PairResidual {
    int64_t t_ns = 0;               ///< the pair's centre (the boundary between its windows)
    Eigen::Vector3d m_B = Eigen::Vector3d::Zero();  ///< tilt error x g + accelerometer bias, body
    Eigen::Matrix3d R_W_B = Eigen::Matrix3d::Identity();  ///< the attitude m_B was turned into B with
    double heading_first = 0;       ///< heading at the start of its first window
  };
  GravityBiasObserverParams params_;
  std::optional<Window> open_, last_closed_;
  std::optional<PairResidual> last_pair_;
};

}  // namespace seavio::imu
