#pragma once
/// Coasting figures of one vision-loss stretch: how the position error, its flag and
/// its covariance grow while the odometry dead-reckons on the IMU, and how it recovers. Errors
/// are relative to the last frame before the loss, in that frame's body axes, so they measure
/// only what the loss adds (not the drift before it) and need no alignment of the world frames.
/// `seavio bench coasting` prints them for rendered surveys; tests/tools/coasting asserts them.
#include <cstdint>
#include <string>
#include <vector>

#include "core/common/types.hpp"
#include "drivers/dataset/dataset.hpp"

namespace seavio::tools {

/// One vision-loss stretch of a rendered survey, on the dataset clock.
struct LossStretch {
  std::string kind;  ///< blackout, turbidity, featureless, altitude
  int64_t from_ns = 0, to_ns = 0;
};

/// DIR/mav0/vision_loss.csv as the simulator writes it ("#kind,start [ns],end [ns]"). Throws
/// std::runtime_error naming the file and line for a missing file or a malformed row.
std::vector<LossStretch> readLossStretches(const std::string& dataset_dir);

/// Figures of one loss stretch [from_ns, to_ns).
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
  double after_s = 0;         ///< how long after the stretch ended error_after_m is taken [s]
  double error_after_m = 0;   ///< accumulated error `after_s` after the stretch ended
  double distance_m = 0;      ///< ground-truth distance travelled inside the stretch
  /// |velocity - true velocity| at the last frame before the stretch: what coasting starts
  /// from [m/s] (ground truth without velocity: 0).
  double handover_velocity_error_m_s = 0;
  /// Tilt error at that frame: angle between the estimated and the true vertical in the body
  /// axes [rad]; a tilt error turns gravity into a horizontal acceleration while coasting.
  double handover_tilt_error_rad = 0;
};

/// `results` are per frame of `ds` (same order). `at_s` lists the times into the stretch to
/// report the error at; `after_s` is how long after the stretch the recovery error is taken.
/// No frame before the stretch or no ground truth: only `finite` is filled in.
CoastFigures coastFigures(const drivers::Dataset& ds, const std::vector<OdometryResult>& results,
                          const LossStretch& stretch, const std::vector<double>& at_s, double after_s);

/// One line: `what`, the stretch and its figures (docs/reliability.md's tables come from these).
std::string formatCoastFigures(const std::string& what, const LossStretch& stretch, const CoastFigures& f);

}  // namespace seavio::tools
