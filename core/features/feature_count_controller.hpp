#pragma once
/// Proportional control of the detector threshold to hold a feature count from frame to frame
/// (paper section III-B: "adjusted according to the number of found features in the last
/// image using a simple proportional controller").
#include <string>
#include <vector>

namespace seavio::features {

struct FeatureCountControllerParams {
  int target_count = 500;          ///< wanted features per image
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
  /// Throws std::invalid_argument listing every problem found by validate().
  explicit FeatureCountController(const FeatureCountControllerParams& params = {});

  /// Threshold to use for the next image.
  double threshold() const { return threshold_; }
  const FeatureCountControllerParams& params() const { return params_; }

  /// Feeds the count the current threshold produced; moves the threshold towards the target.
  void update(int observed_count);

  /// Back to the initial threshold.
  void reset() { threshold_ = params_.initial_threshold; }

 private:
  FeatureCountControllerParams params_;
  double threshold_;
};

}  // namespace seavio::features
