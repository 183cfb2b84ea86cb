#pragma once
/// One front door for the detectors the config can select: our SURF (the paper's, section
/// III-B) and OpenCV's SIFT, ORB and AKAZE for comparison. All take one scalar threshold so the
/// same FeatureCountController drives any of them.
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/features/feature_count_controller.hpp"
#include "core/features/surf.hpp"

namespace seavio::features {

enum class DetectorType { kSurf, kSift, kOrb, kAkaze };

/// "surf", "sift", "orb" or "akaze" (case-insensitive); nullopt for another name.
std::optional<DetectorType> parseDetectorType(const std::string& name);
/// Lower-case name, the inverse of parseDetectorType.
std::string toString(DetectorType type);

/// Sensible range and start of a detector's threshold (its units):
/// SURF det(H) [grey level^2] 1..50000 from 400; SIFT contrastThreshold 0.001..0.3 from 0.04;
/// ORB FAST threshold [grey levels] 1..150 from 20; AKAZE detector threshold 1e-5..0.05 from
/// 0.001.
struct ThresholdRange {
  double min = 0;
  double max = 0;
  double initial = 0;
};
ThresholdRange defaultThresholdRange(DetectorType type);

/// Controller parameters for `type` with its default threshold range and `target_count`.
FeatureCountControllerParams defaultControllerParams(DetectorType type, int target_count = 500);

struct FeatureParams {
  DetectorType type = DetectorType::kSurf;
  SurfParams surf;                             ///< used when type == kSurf
  FeatureCountControllerParams controller;     ///< ranges must suit `type` (see above)
  int max_features = 0;                        ///< 0 = no cap; else keep the strongest
};

/// Every problem with `p` (its SURF and controller parts included); empty if valid.
std::vector<std::string> validate(const FeatureParams& p);

/// Features of one image.
struct Features {
  std::vector<cv::KeyPoint> keypoints;  ///< pixels, OpenCV conventions (see Surf)
  cv::Mat descriptors;                  ///< one row per keypoint: CV_32F or CV_8U (binary)
  int norm_type = cv::NORM_L2;          ///< cv::NORM_L2 or cv::NORM_HAMMING
};

/// Extracts features with the configured detector. Stateless and const, so the left and
/// right images can be processed from two threads with one object (OpenCV's detectors are
/// created per call for the same reason).
class FeatureExtractor {
 public:
  /// `params` must be valid (validate() empty): the configuration's loader checks them
  /// (drivers/config), core does not throw.
  explicit FeatureExtractor(const FeatureParams& params);

  const FeatureParams& params() const { return params_; }

  /// Detects and describes features in `gray8` with `threshold` in the detector's units (see
  /// ThresholdRange); none unless `gray8` is CV_8UC1.
  Features extract(const cv::Mat& gray8, double threshold) const;
  /// The same with SURF's buffers in `workspace` (kept by the caller across frames, one per
  /// thread calling at once); the OpenCV detectors ignore it.
  Features extract(const cv::Mat& gray8, double threshold, SurfWorkspace& workspace) const;
  /// The same into `out`, whose buffers are reused (give back an earlier frame's Features):
  /// with SURF, repeated calls on images of one size allocate nothing. Identical
  /// keypoints and descriptors. False (and no features) unless `gray8` is CV_8UC1 or empty.
  bool extract(const cv::Mat& gray8, double threshold, SurfWorkspace& workspace, Features& out) const;

 private:
  FeatureParams params_;
  Surf surf_;
};

}  // namespace seavio::features
