#pragma once
/// Proportional control of the detector threshold to hold a feature count from frame to frame
/// (paper section III-B: "adjusted according to the number of found features in the last
/// image using a simple proportional controller").
#include <string>
#include <vector>

namespace seavio::features {

struct FeatureCountControllerParams {
  int target_count = 500;          ///< wanted features per image
  /// Stereo matches wanted per frame; 0 = off. Marine snow takes a share of the features a
  /// threshold yields (bright dots, occluded floor) that never match across the rig, so a
  /// fixed feature count leaves a snowy frame with fewer points on the floor. When set, the
  /// threshold is lowered past `target_count` features while the frame's stereo matches are
  /// short of this, up to `max_count` features. Clear water, which reaches it with
  /// `target_count` features, settles at `target_count` as without it.
  int target_stereo_matches = 300;
  /// RANSAC inliers wanted per tracked frame; 0 = off. The motion's precision grows with the
  /// inliers, and the share of the features that become inliers is the image overlap with the
  /// reference: at 1 Hz over a survey only a strip overlaps, and 500 features leave half the
  /// inliers of 10 Hz (~135 against ~270; the heading noise per frame grows as 1 / sqrt of
  /// them). When set, the threshold is lowered past `target_count` features while the frame's
  /// inliers are short of this, up to `max_count` features. 10 Hz reaches 450 with
  /// `target_count` features and is unchanged; on the full 1 Hz survey it halved the
  /// horizontal error, and with the tilt part of the rotation prior from the
  /// accelerometer-bias filter (OdometryParams::gyro_bias_prior_tilt_from_filter) without
  /// the vertical it cost alone (git history of docs/benchmarks.md). At 1 Hz ~2x the CPU per frame.
  int target_inliers = 450;
  int max_count = 3000;            ///< most features per image when chasing matches or inliers
  /// Proportional gain in log space: log t += gain * log(observed / target). The count of a
  /// detector falls roughly as threshold^-alpha (alpha ~ 1 for SURF's det(H) on natural
  /// texture), so gain ~ 1 / alpha settles in one step; below that it is slower but safer.
  double gain = 0.7;
  double min_threshold = 1.0;      ///< clamp (detector units, SURF: det(H) [grey level^2])
  double max_threshold = 50000.0;  ///< clamp
  double initial_threshold = 400.0;
  /// Largest change of the threshold in one frame, as a factor (guards against an empty or
  /// saturated frame).
  double max_step_factor = 4.0;
};

/// Every problem with `p`, one message per bad key; empty if valid.
std::vector<std::string> validate(const FeatureCountControllerParams& p);

/// The threshold controller. Working in log-threshold space makes the loop gain independent of
/// the threshold's magnitude, so one gain suits a dim and a bright scene. Not thread-safe:
/// one owner (the frontend) calls update() once per frame.
class FeatureCountController {
 public:
  /// `params` must be valid (validate() empty): the configuration's loader checks them
  /// (drivers/config), core does not throw.
  explicit FeatureCountController(const FeatureCountControllerParams& params = {});

  /// Threshold to use for the next image.
  double threshold() const { return threshold_; }
  const FeatureCountControllerParams& params() const { return params_; }

  /// Feeds the count the current threshold produced; moves the threshold towards the target.
  void update(int observed_count);
  /// Same, with the stereo matches the features made (target_stereo_matches): the threshold
  /// settles where the features reach target_count or the matches target_stereo_matches,
  /// whichever needs more features, and never past max_count features.
  void update(int observed_count, int stereo_matches);
  /// Same, with the RANSAC inliers of the frame just tracked (target_inliers); `inliers` < 0
  /// (the first frame, or one the caller does not want read), only the counts above steer.
  void update(int observed_count, int stereo_matches, int inliers);

  /// Back to the initial threshold.
  void reset() { threshold_ = params_.initial_threshold; }

 private:
  void step(double log_error);  ///< log t += gain * log_error, clamped

  FeatureCountControllerParams params_;
  double threshold_;
};

}  // namespace seavio::features
