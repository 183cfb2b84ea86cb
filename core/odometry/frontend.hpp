#pragma once
/// The per-image half of the pipeline: rectify, detect and describe, match along rows,
/// triangulate (paper Fig. 2, left column). Const and stateless so the daemon's worker pool
/// can run the left and right detections in parallel.
#include <vector>

#include <opencv2/core.hpp>

#include "core/camera/stereo_rectifier.hpp"
#include "core/common/types.hpp"
#include "core/features/feature_extractor.hpp"
#include "core/matching/stereo_matcher.hpp"
#include "core/matching/temporal_matcher.hpp"

namespace seavio::odometry {

/// Everything the tracker needs from one stereo frame.
struct FrameFeatures {
  int64_t t_ns = 0;
  uint64_t seq = 0;
  features::Features left, right;
  matching::StereoFeatures stereo;  ///< stereo points + left descriptors, row-aligned
  double detector_threshold = 0;    ///< threshold the features were detected with
  StageTimes times;                 ///< rectify, features, stereo filled
};

/// Flat-field correction. The vehicle carries its lights, so uneven illumination and
/// vignetting form a pattern fixed in the image, darkening the borders where features would
/// otherwise be lost; dividing by a low-pass of the image evens the contrast the detector and
/// its count controller see across the frame.
struct IlluminationParams {
  bool enabled = true;
  int scale = 16;           ///< low-pass by area-downsampling with this factor
  double blur_sigma = 2.0;  ///< extra Gaussian smoothing at the low resolution [px]
  double target_grey = 110.0;
};

/// Flat-field corrects `in` into `out` (both CV_8UC1). `scratch` buffers are reused.
void normalizeIllumination(const cv::Mat& in, cv::Mat& out, const IlluminationParams& params);

/// Marine-snow suppression. Snow particles lit by the vehicle's own lights show as bright
/// dots of a few pixels, hundreds per image at 4 m altitude; SURF's strongest small-scale
/// responses, they crowd the floor out of the feature budget and, moving with their own
/// parallax, never match from frame to frame (at 1 Hz no frame survived). A grey-level
/// opening (erode then dilate) with a disc wider than the dots removes them and leaves the
/// larger floor texture and dark structure alone.
struct SnowFilterParams {
  bool enabled = true;
  int kernel_px = 5;  ///< disc diameter [px]: bright spots narrower than this vanish
};

/// Opens `in` into `out` (CV_8UC1) with a `params.kernel_px` disc; a copy when disabled.
void suppressSnow(const cv::Mat& in, cv::Mat& out, const SnowFilterParams& params);

class Frontend {
 public:
  Frontend(camera::StereoRectifier rectifier, const features::FeatureParams& feature_params,
           const matching::StereoMatchParams& stereo_params, const IlluminationParams& illumination = {},
           const SnowFilterParams& snow = {});

  const camera::RectifiedRig& rig() const { return rectifier_.rig(); }
  const camera::StereoRectifier& rectifier() const { return rectifier_; }

  /// Rectified image of camera `cam` (0 left, 1 right).
  void rectify(const StereoFrame& frame, cv::Mat& left_rect, cv::Mat& right_rect) const;
  /// Features of one rectified image.
  features::Features detect(const cv::Mat& rectified, double threshold) const;
  /// Stereo matching + triangulation of already detected features.
  matching::StereoFeatures matchStereo(const features::Features& left, const features::Features& right) const;
  /// All three, sequentially, timed with `now` (may be empty).
  FrameFeatures process(const StereoFrame& frame, double threshold, const NowNsFn& now) const;

 private:
  camera::StereoRectifier rectifier_;
  features::FeatureExtractor extractor_;
  matching::StereoMatchParams stereo_params_;
  IlluminationParams illumination_;
  SnowFilterParams snow_;
};

}  // namespace seavio::odometry
