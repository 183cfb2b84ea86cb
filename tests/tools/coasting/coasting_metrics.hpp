#pragma once
// Coasting figures of one vision-loss stretch (issue 9): how the position error, its flag and
// its covariance grow while the odometry dead-reckons on the IMU, and how it recovers. Errors
// are relative to the last frame before the loss, in that frame's body axes, so they measure
// only what the loss adds (not the drift before it) and need no alignment of the world frames.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/common/types.hpp"
#include "drivers/dataset/dataset.hpp"

namespace seavio::test {

/// Figures of one loss stretch [from_ns, to_ns) on the dataset clock.
struct CoastFigures {
  int frames_in_loss = 0;     ///< frames with a stamp inside the stretch
  int flagged_in_loss = 0;    ///< of those, published as IMU-only (coasting)
  bool covariance_grows = true;  ///< position variance rose at every coasting frame
  bool finite = true;         ///< every pose and covariance finite (whole run)
  double sigma_start_m = 0;   ///< sqrt(trace of the position covariance) at the last frame before
  double sigma_end_m = 0;     ///< ... and at the last frame inside the stretch
  std::vector<double> error_at_s;  ///< seconds into the stretch the errors below are taken at
  std::vector<double> error_m;     ///< position error accumulated since the stretch began [m]
  /// The position standard deviation the odometry added since the stretch began, at the same
  /// times: sqrt(trace now - trace at the last frame before) [m]; its bound for error_m.
  std::vector<double> sigma_added_m;
  double error_end_m = 0;     ///< at the last frame inside the stretch
  double recovery_s = -1;     ///< stretch end to the first visual pose after it (-1: none)
  /// At that first visual pose: its position change from the frame before it minus the true
  /// change [m]; a jump at recovery would show here (-1: no recovery).
  double recovery_jump_m = -1;
  double error_after_m = 0;   ///< accumulated error `after_s` after the stretch ended
  double distance_m = 0;      ///< ground-truth distance travelled inside the stretch
  /// |velocity - true velocity| at the last frame before the stretch: what coasting starts
  /// from [m/s] (ground truth without velocity: 0).
  double handover_velocity_error_m_s = 0;
  /// Tilt error at that frame: angle between the estimated and the true vertical in the body
  /// axes [rad]; a tilt error turns gravity into a horizontal acceleration while coasting.
  double handover_tilt_error_rad = 0;
};

/// Ground truth at the sample nearest `t_ns`.
inline const drivers::GroundTruthState& nearestTruth(const drivers::Dataset& ds, int64_t t_ns) {
  const auto& gt = ds.ground_truth;
  auto it = std::lower_bound(gt.begin(), gt.end(), t_ns,
                             [](const drivers::GroundTruthState& g, int64_t t) { return g.t_ns < t; });
  if (it == gt.end()) return gt.back();
  if (it != gt.begin() && t_ns - std::prev(it)->t_ns < it->t_ns - t_ns) --it;
  return *it;
}

inline double positionSigma(const OdometryResult& r) {
  return std::sqrt(std::max(0.0, r.covariance.bottomRightCorner<3, 3>().trace()));
}

/// `results` are per frame of `ds` (same order). `at_s` lists the times into the stretch to
/// report the error at; `after_s` is how long after the stretch the recovery error is taken.
inline CoastFigures coastFigures(const drivers::Dataset& ds, const std::vector<OdometryResult>& results,
                                 int64_t from_ns, int64_t to_ns, const std::vector<double>& at_s,
                                 double after_s) {
  CoastFigures f;
  std::size_t ref = 0;
  bool have_ref = false;
  for (std::size_t i = 0; i < results.size(); ++i) {
    const OdometryResult& r = results[i];
    f.finite = f.finite && r.T_W_B.matrix().allFinite() && r.covariance.allFinite();
    if (r.t_ns < from_ns) {
      ref = i;
      have_ref = true;
    }
  }
  if (!have_ref || ds.ground_truth.empty()) return f;
  const OdometryResult& r0 = results[ref];
  const Eigen::Isometry3d gt0 = nearestTruth(ds, r0.t_ns).T_W_B;
  auto error = [&](const OdometryResult& r) {
    const Eigen::Vector3d est = (r0.T_W_B.inverse() * r.T_W_B).translation();
    const Eigen::Vector3d truth = (gt0.inverse() * nearestTruth(ds, r.t_ns).T_W_B).translation();
    return (est - truth).norm();
  };
  f.sigma_start_m = positionSigma(r0);
  if (const auto& g = nearestTruth(ds, r0.t_ns); g.has_velocity) f.handover_velocity_error_m_s = (r0.v_W - g.v_W).norm();
  const Eigen::Vector3d up_est = r0.T_W_B.rotation().transpose() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d up_true = gt0.rotation().transpose() * Eigen::Vector3d::UnitZ();
  f.handover_tilt_error_rad = std::atan2(up_est.cross(up_true).norm(), up_est.dot(up_true));
  double prev_var = f.sigma_start_m * f.sigma_start_m;
  std::size_t next_at = 0;
  Eigen::Vector3d prev_gt = gt0.translation();
  const int64_t after_ns = to_ns + static_cast<int64_t>(after_s * 1e9);
  for (std::size_t i = ref + 1; i < results.size(); ++i) {
    const OdometryResult& r = results[i];
    if (r.t_ns < to_ns) {
      ++f.frames_in_loss;
      const bool coasting = r.source == PoseSource::kImuOnly;
      f.flagged_in_loss += coasting;
      const double var = positionSigma(r) * positionSigma(r);
      if (coasting && !(var > prev_var)) f.covariance_grows = false;
      prev_var = var;
      f.sigma_end_m = positionSigma(r);
      f.error_end_m = error(r);
      const Eigen::Vector3d p = nearestTruth(ds, r.t_ns).T_W_B.translation();
      f.distance_m += (p - prev_gt).norm();
      prev_gt = p;
      while (next_at < at_s.size() && static_cast<double>(r.t_ns - from_ns) * 1e-9 >= at_s[next_at]) {
        f.error_at_s.push_back(at_s[next_at++]);
        f.error_m.push_back(error(r));
        f.sigma_added_m.push_back(std::sqrt(std::max(0.0, var - f.sigma_start_m * f.sigma_start_m)));
      }
      continue;
    }
    if (f.recovery_s < 0 && r.source == PoseSource::kVision) {
      f.recovery_s = static_cast<double>(r.t_ns - to_ns) * 1e-9;
      const OdometryResult& before = results[i - 1];
      const Eigen::Vector3d est = r.T_W_B.translation() - before.T_W_B.translation();
      const Eigen::Vector3d truth =
          nearestTruth(ds, r.t_ns).T_W_B.translation() - nearestTruth(ds, before.t_ns).T_W_B.translation();
      f.recovery_jump_m = (est - truth).norm();
    }
    if (r.t_ns <= after_ns) f.error_after_m = error(r);
  }
  return f;
}

}  // namespace seavio::test
