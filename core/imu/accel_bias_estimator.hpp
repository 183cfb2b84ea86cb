#pragma once
/// Accelerometer bias and roll/pitch error of the visual chain, estimated together.
///
/// Vision measures only relative rotations, so the chain's roll and pitch random-walk; over the
/// paper's 4.5 km survey (1.5 m frames) they reach tens of mrad, every horizontal metre then
/// carries that many mm of vertical error, and the IMU prediction leaks g x tilt of false
/// acceleration. Gravity is the absolute tilt reference, but the accelerometer reads it through
/// its bias: a bias b tilts the apparent vertical by b/g (0.3 m/s^2, the simulator's drift over
/// the survey, is 30 mrad). Both are observable together: over a window between two visual
/// fixes the specific force turned into W by the chain's attitude, plus gravity, must equal the
/// velocity change vision measured (paper III-A's model run backwards),
///
///   z = (1/T) [ sum R^(f - b^) dt + g_W T - (v_end - v_start) ] = -[m]x eps + (1/T) sum R^ dt . db,
///
/// where m is the mean specific force in W (~ +g z). A tilt error eps is fixed in W, a bias is
/// fixed in the body: on a straight leg only their sum is seen, but the lawnmower's 180 deg
/// turns rotate the body under the bias and separate them. A 9-state Kalman filter (eps_x, eps_y
/// in W, db in B, the start-up tilt e0 in W, and the horizontal gyro-bias error dbg_x, dbg_y
/// in B that turns eps: AccelBiasParams::gyro_bias_states) with error-state feedback: after
/// each update the caller turns its chain by `tiltCorrection()` and the estimate's tilt part
/// returns to zero; the bias goes into the dead reckoning. e0, the tilt the chain had at
/// start-up, is a constant starting exactly correlated with eps: on the first leg every update
/// moves both, at the turns they part, and `initialTilt()` is what the levelling on the biased
/// accelerometer left (the publisher's start-up frame, OdometryParams::accel_bias_start_frame).
/// Heading is not observed by gravity and is left alone.
#include <cstdint>
#include <span>

#include <Eigen/Core>

#include "core/common/types.hpp"

namespace seavio::imu {

struct AccelBiasParams {
  double initial_bias_sigma_m_s2 = 0.03;        ///< bias spread at start-up [m/s^2]
  double bias_random_walk_m_s2_sqrt_s = 3e-3;   ///< bias drift [m/s^2/sqrt(s)] (the IMU's random walk)
  /// Roll/pitch drift of the visual chain [rad/sqrt(s)]: how fast the filter lets the tilt
  /// error change between updates, against the bias. What is left once the gyro bias is a
  /// state (1e-3 without: git history of docs/benchmarks.md).
  double tilt_random_walk_rad_sqrt_s = 2e-4;
  /// Error of one visual velocity at a window's ends [m/s] (a frame's relative-position error
  /// over its interval).
  double velocity_sigma_m_s = 0.02;
  double accel_noise_density = 2e-3;            ///< accelerometer white noise [m/s^2/sqrt(Hz)]
  double window_s = 1.0;                        ///< shortest window between updates [s]
  /// An update whose innovation is further out than this (Mahalanobis distance) is refused: a
  /// bad visual velocity must not tilt the chain.
  double gate_sigmas = 4.0;
  /// Also estimate the horizontal gyro bias (body x, y; states 7-8): a gyro bias error turns
  /// the chain's tilt steadily (eps' = (R dbg)_xy), which a tilt random walk can only follow by
  /// being large, and a large walk lets the tilt absorb what each turn shows of the
  /// accelerometer bias (git history of docs/benchmarks.md: the first turn left the full survey's
  /// bias 0.004-0.021 m/s^2 off, the second lane pitched 4 mrad). The caller adds
  /// gyroBiasCorrection() to its gyro bias after each update; the gravity tilt-rate observer,
  /// which estimated the same thing apart, is then not run (OdometryParams).
  bool gyro_bias_states = true;
  double gyro_bias_random_walk_rad_s_sqrt_s = 1e-5;  ///< [rad/s/sqrt(s)]
};

class AccelBiasEstimator {
 public:
  explicit AccelBiasEstimator(const AccelBiasParams& params = {});

  /// Starts over at the first frame with attitude `R_W_B`. Levelled by the accelerometer (the
  /// usual start), the initial tilt error is the bias's image (eps = [b]_xy / g, exactly
  /// correlated); otherwise the tilt is independent with `tilt_sigma_rad`. With
  /// gyro_bias_states the horizontal gyro-bias error starts at `gyro_bias_sigma_rad_s` (the
  /// caller's: a still start knows it better than a moving one).
  void reset(const Eigen::Matrix3d& R_W_B, bool levelled_by_accelerometer, double tilt_sigma_rad,
             double gyro_bias_sigma_rad_s);

  /// Opens a window at a visual fix whose velocity is `v_W` [m/s] (an open one is dropped).
  void startWindow(const Eigen::Vector3d& v_W);
  /// Drops the open window (coasting, a map correction: the velocity chain is interrupted).
  void breakWindow() { window_open_ = false; }
  /// Turns the open window with the chain when a map correction turns W about the vertical
  /// (OdometryParams::map_keeps_tilt): what was summed stays comparable with what follows.
  void turnWindow(const Eigen::Matrix3d& R) {
    v_start_W_ = R * v_start_W_;
    sum_force_W_ = R * sum_force_W_;
    sum_rotation_ = R * sum_rotation_;
  }
  bool windowOpen() const { return window_open_; }

  /// One inter-frame interval [t0_ns, t1_ns]: the IMU is integrated from the chain's attitude
  /// `R_W_B_start` at t0 (gyro bias subtracted, midpoint rule as in imu_integrator.cpp) into
  /// the open window; the uncertainty grows by the drift over the interval either way.
  void addInterval(const Eigen::Matrix3d& R_W_B_start, const Eigen::Vector3d& gyro_bias_rad_s,
                   std::span<const ImuSample> samples, int64_t t0_ns, int64_t t1_ns);

  enum class Outcome { kOpen, kUpdated, kRefused, kNoWindow };
  /// At the visual fix that ends the last interval, velocity `v_W`: once the window spans
  /// `window_s`, the update. kUpdated: the bias moved and `tiltCorrection()` holds the rotation
  /// the caller must apply to its chain; kUpdated and kRefused close the window.
  Outcome close(const Eigen::Vector3d& v_W);

  /// The rotation vector in W [rad] to left-multiply onto the chain's attitude after the last
  /// update (z = 0); zero when none is due.
  const Eigen::Vector3d& tiltCorrection() const { return tilt_correction_W_; }
  /// With gyro_bias_states: the correction to add to the gyro bias estimate [rad/s] in B
  /// after the last update (z = 0); zero when none is due.
  const Eigen::Vector3d& gyroBiasCorrection() const { return gyro_bias_correction_B_; }
  /// The chain's tilt error at start-up (reset) as now estimated, a rotation vector in W
  /// [rad] (z = 0): R^(0) = exp([e0]x) R(0). Levelling on a biased accelerometer leaves it;
  /// the corrections undo it in the chain, and a publisher that keeps the start-up frame
  /// turns its output back by it (OdometryParams::accel_bias_start_frame).
  const Eigen::Vector3d& initialTilt() const { return initial_tilt_W_; }
  /// Bias estimate in B [m/s^2], to subtract from the accelerometer.
  const Eigen::Vector3d& bias() const { return bias_B_; }
  Eigen::Vector3d biasSigma() const { return P_.diagonal().segment<3>(2).cwiseSqrt(); }
  Eigen::Vector2d tiltSigma() const { return P_.diagonal().head<2>().cwiseSqrt(); }
  /// With gyro_bias_states: the covariance of the horizontal gyro-bias error (body x, y)
  /// [(rad/s)^2]; zero without.
  Eigen::Matrix2d gyroBiasCovariance() const { return P_.block<2, 2>(7, 7); }
  /// Normalised innovation squared of the last update or refusal (3 degrees of freedom).
  double lastNis() const { return last_nis_; }
  int updates() const { return updates_; }
  int refused() const { return refused_; }

 private:
  static constexpr int kStates = 9;
  using StateMatrix = Eigen::Matrix<double, kStates, kStates>;
  AccelBiasParams params_;
  /// (eps_x, eps_y) in W [rad], db in B [m/s^2], the start-up tilt (e0_x, e0_y) in W [rad],
  /// the horizontal gyro bias error (dbg_x, dbg_y) in B [rad/s] (zero and fixed without
  /// gyro_bias_states)
  StateMatrix P_ = StateMatrix::Zero();
  Eigen::Vector3d initial_tilt_W_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d bias_B_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d tilt_correction_W_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_bias_correction_B_ = Eigen::Vector3d::Zero();
  bool window_open_ = false;
  Eigen::Vector3d v_start_W_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d sum_force_W_ = Eigen::Vector3d::Zero();      ///< sum R^(f - b^) dt [m/s]
  Eigen::Matrix3d sum_rotation_ = Eigen::Matrix3d::Zero();     ///< sum R^ dt [s]
  double window_s_ = 0;
  double last_nis_ = 0;
  int updates_ = 0;
  int refused_ = 0;
};

}  // namespace seavio::imu
