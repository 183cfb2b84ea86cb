#pragma once
/// Trajectory accuracy against ground truth: the paper's Table I figures (position error
/// after aligning the first pose), drift as % of distance travelled, ATE after SE(3)
/// Umeyama alignment and relative pose error per 10 m.
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace seavio::eval {

/// One pose of the body B in the world W at time t_ns [ns].
struct TimedPose {
  int64_t t_ns = 0;
  Eigen::Isometry3d T_W_B = Eigen::Isometry3d::Identity();
};

struct EvalParams {
  /// Largest gap [ns] between an estimate and the ground-truth sample it is matched to
  /// when it does not fall between two ground-truth samples.
  int64_t max_dt_ns = 5'000'000;
  /// Largest gap [ns] between two ground-truth samples that may be interpolated.
  int64_t max_interp_gap_ns = 200'000'000;
  /// Segment length of the relative pose error [m].
  double rpe_segment_m = 10.0;
  /// Below this fraction of ground-truth frames covered the result is flagged incomplete.
  double min_coverage = 0.95;
  /// The span [ns] an estimate could cover: the first to the last camera frame. Ground truth
  /// outside it (a real recording's truth starts before the images and ends after them) does
  /// not count against coverage. first > last (the default): the whole ground truth.
  int64_t coverage_first_ns = 1;
  int64_t coverage_last_ns = 0;
  /// Steps between consecutive poses count as straight (heading_step_rms_rad) while the
  /// truth turns slower than this [rad/s].
  double straight_max_turn_rate_rad_s = 0.01;
};

struct TrajectoryMetrics {
  int gt_poses = 0;           ///< ground-truth samples
  int est_poses = 0;          ///< estimated samples
  int associated = 0;         ///< estimates matched to ground truth
  int gt_in_span = 0;         ///< ground-truth samples in the time span of the estimate
  /// Covered / ground-truth frames in EvalParams' coverage span (else the whole ground truth);
  /// a trajectory that stops early or drops frames is < 1.
  double coverage = 0;
  bool incomplete = true;     ///< coverage < EvalParams::min_coverage (or nothing associated)

  // Paper Table I: estimate aligned on its first pose (est' = T_gt0 * inv(T_est0) * est).
  double mean_error_m = 0;
  double std_error_m = 0;
  double max_error_m = 0;
  double final_error_m = 0;
  double distance_m = 0;            ///< ground-truth path length over the associated poses
  double mean_error_pct = 0;        ///< mean_error_m / distance_m * 100
  double final_error_pct = 0;       ///< final_error_m / distance_m * 100
  /// The same error split along W's z axis (up; W is gravity-aligned, as in EuRoC, TUM and
  /// the simulator): a depth sensor would take the vertical part away, heading errors show in
  /// the horizontal part as cross-track error growing along each leg.
  double mean_horizontal_error_m = 0;
  double mean_vertical_error_m = 0;  ///< mean of |z error|
  /// Heading error: the first-pose-aligned attitude error's turn about W's z [deg].
  double mean_heading_error_deg = 0;  ///< mean of |heading error|
  double max_heading_error_deg = 0;   ///< largest |heading error|
  /// Tilt error: the angle between the aligned estimate's and the truth's vertical (the roll
  /// and pitch part of the attitude error, whatever the heading) [deg]. A tilt theta turns
  /// every metre flown along it into theta metres of vertical error, and leaks g * theta of
  /// false acceleration into the IMU prediction.
  double mean_tilt_error_deg = 0;
  double max_tilt_error_deg = 0;
  /// Gravity tilt error: the same angle with no alignment at all, between the vertical the
  /// estimate's attitude claims and the truth's (both worlds z-up along gravity) [deg]. What
  /// a vehicle's controller sees in the published roll and pitch, and what the first-pose
  /// alignment hides: a start judged level while accelerating tilts the whole trajectory,
  /// and each metre flown then gains tilt metres of depth error. Meaningful only for an
  /// estimate whose world is levelled on gravity (an IMU run; not a camera-only one).
  double mean_gravity_tilt_error_deg = 0;
  double max_gravity_tilt_error_deg = 0;
  /// Position error with only the first position and heading aligned (roll and pitch kept as
  /// published: the four directions a gravity-referenced estimate cannot know), % of distance:
  /// what the first-pose figures become when the start's attitude is part of the answer.
  double mean_gravity_error_pct = 0;
  double final_gravity_error_pct = 0;
  /// The heading error's change from one pose to the next on straight stretches (the truth
  /// turning slower than EvalParams::straight_max_turn_rate_rad_s), rms [rad]: the per-frame
  /// heading noise that a chain's heading random-walks with (times the square root of the
  /// frames). Hundreds of steps per survey make it a steadier comparison of two
  /// configurations than any survey's end error, which one walk decides.
  double heading_step_rms_rad = 0;
  /// Median and 90th percentile of the same steps' size (nearest rank) [rad]: whether a
  /// change narrows every step or trims a few outliers, which the rms alone cannot tell.
  double heading_step_median_rad = 0;
  double heading_step_p90_rad = 0;
  int heading_steps = 0;  ///< straight steps it is taken over

  double ate_rmse_m = 0;            ///< after SE(3) Umeyama alignment (no scale)
  double rpe_trans_pct = 0;         ///< mean translational error per segment, % of segment length
  double rpe_rot_deg_per_m = 0;     ///< mean rotational error per segment / segment length
  int rpe_segments = 0;

  /// Per associated pose, for plotting (paper Figs. 6 and 7).
  std::vector<int64_t> t_ns;
  std::vector<double> distance_along_m;            ///< ground-truth distance travelled so far
  std::vector<double> error_m;                     ///< first-pose-aligned position error
  std::vector<double> heading_error_deg;           ///< signed, estimate minus truth, about W's z
  std::vector<double> tilt_error_deg;              ///< unsigned, see mean_tilt_error_deg
  std::vector<Eigen::Vector3d> gt_position;        ///< associated ground truth in W
  std::vector<Eigen::Vector3d> est_first_aligned;  ///< estimate after first-pose alignment
  std::vector<Eigen::Vector3d> est_umeyama_aligned;///< estimate after Umeyama alignment
};

/// Associates `est` with `gt` by time (gt interpolated, linear + slerp, when an estimate
/// falls between two ground-truth samples) and computes every figure above. Both inputs
/// must be sorted by time. Never throws; with no association `incomplete` is true and
/// the figures are zero.
TrajectoryMetrics evaluateTrajectory(const std::vector<TimedPose>& gt, const std::vector<TimedPose>& est,
                                     const EvalParams& params = {});

/// Pose between `a` (s = 0) and `b` (s = 1): linear in translation, slerp in rotation.
Eigen::Isometry3d interpolate(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double s);

/// SE(3) that best maps `src` onto `dst` in least squares (Umeyama 1991, no scale).
Eigen::Isometry3d alignUmeyama(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst);

}  // namespace seavio::eval
