#pragma once
/// The per-image half of the pipeline: rectify, detect and describe, match along rows,
/// triangulate (paper Fig. 2, left column). Const and stateless so the daemon's worker pool
/// can run the left and right detections in parallel; the buffers a frame needs live in a
/// FrontendWorkspace owned by the caller (one per pipeline), so that frames after the first
/// reuse them instead of allocating.
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "core/camera/stereo_rectifier.hpp"
#include "core/common/parallel_for.hpp"
#include "core/common/types.hpp"
#include "core/features/feature_extractor.hpp"
#include "core/matching/stereo_completion.hpp"
#include "core/matching/stereo_matcher.hpp"
#include "core/matching/temporal_matcher.hpp"
#include "core/odometry/ripple_notch.hpp"

namespace seavio::odometry {

/// Everything the tracker needs from one stereo frame.
struct FrameFeatures {
  int64_t t_ns = 0;
  uint64_t seq = 0;
  features::Features left, right;
  matching::StereoFeatures stereo;  ///< stereo points + left descriptors, row-aligned
  double detector_threshold = 0;    ///< threshold the features were detected with
  StageTimes times;                 ///< rectify, features, stereo filled
  /// The rectified, filtered images the features come from (CV_8UC1), for patch refinement
  /// (OdometryParams::patch_refinement). Owned: the workspace's are overwritten next frame.
  cv::Mat left_image, right_image;
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

/// Flat-field corrects `in` into `out` (both CV_8UC1).
void normalizeIllumination(const cv::Mat& in, cv::Mat& out, const IlluminationParams& params);

/// Separable Gaussian blur of a CV_32FC1 image in place with a reflected border: the kernel
/// cv::GaussianBlur(img, img, {0, 0}, sigma, 0, cv::BORDER_REFLECT) uses (side round(8 sigma
/// + 1), odd), equal to it up to float rounding (the sums' order differs). The kernel (made
/// when sigma changes) and row buffers are kept, so repeated calls allocate nothing; OpenCV 4
/// builds its kernel and filter engine on every call and exposes no reusable one.
class GaussianBlur32f {
 public:
  void apply(cv::Mat& img, double sigma);

 private:
  double sigma_ = -1;
  std::vector<float> kernel_;
  std::vector<float> pad_;  ///< one source row with its reflected border
  cv::Mat tmp_;             ///< the row pass
};

/// Buffers of normalizeIllumination kept across frames.
struct IlluminationScratch {
  cv::Mat small;    ///< 8-bit area means (only for sizes not divisible by the scale)
  cv::Mat small_f;  ///< the low-pass at reduced resolution (area mean, blurred, >= 1)
  cv::Mat rows_f;   ///< its rows resampled to full width
  GaussianBlur32f blur;
  std::vector<int> block_sum;
  cv::Size taps_size, taps_small;  ///< sizes the bilinear taps below were made for
  std::vector<int> x_index, y_index;
  std::vector<float> x_weight, y_weight;
};
/// The same as above with the buffers of `scratch` (the version above makes a fresh one):
/// identical output.
void normalizeIllumination(const cv::Mat& in, cv::Mat& out, const IlluminationParams& params,
                           IlluminationScratch& scratch);

/// Marine-snow suppression. Snow particles lit by the vehicle's own lights show as bright
/// dots of a few pixels, hundreds per image at 4 m altitude; SURF's strongest small-scale
/// responses, they crowd the floor out of the feature budget and, moving with their own
/// parallax, never match from frame to frame (at 1 Hz no frame survived). A grey-level
/// opening (erode then dilate) with a disc wider than the dots removes them and leaves the
/// larger floor texture and dark structure alone. It flattens the floor's own fine bright
/// texture too, which costs heading (1 Hz, 300 frames of six surveys: 133 urad per step on
/// clear water with the opening, 98 with only the dots opened; git history of docs/benchmarks.md).
/// So by default only the dots take the opening: pixels near one more than `dot_dn` above it;
/// the rest keep up to `keep_dn` above it (255: untouched; 0: the plain opening).
struct SnowFilterParams {
  bool enabled = true;
  int kernel_px = 5;  ///< disc diameter [px]: bright spots narrower than this are dots
  int keep_dn = 255;  ///< [DN] a pixel away from dots keeps up to this above the opening (255: untouched; 0: the plain opening)
  int dot_dn = 40;    ///< [DN] a pixel this far above the opening is a dot: it and its 8 neighbours take the opening
  bool operator==(const SnowFilterParams&) const = default;
};

/// Opens `in` into `out` (CV_8UC1) with a `params.kernel_px` disc, cut as the parameters say;
/// a copy when disabled.
void suppressSnow(const cv::Mat& in, cv::Mat& out, const SnowFilterParams& params);

/// The snow filter's disc as horizontal runs (made once) and its buffers. The opening is done
/// here rather than by cv::morphologyEx, which builds a filter engine per call: erosion and
/// dilation are minima and maxima, so the result is bit-identical (replicated border = clamped
/// coordinates, as OpenCV's BORDER_REPLICATE).
class SnowFilter {
 public:
  explicit SnowFilter(const SnowFilterParams& params = {});
  /// Opens `in` into `out` (CV_8UC1; may be the same Mat); a copy when disabled.
  void apply(const cv::Mat& in, cv::Mat& out);
  const SnowFilterParams& params() const { return params_; }

 private:
  struct Run {
    int dy, lo, hi;  ///< kernel row offset, column offsets [lo, hi] from the anchor
    int span;        ///< index into spans_
  };
  /// One grey-level erosion (min) or dilation (max) of `src` into `dst` (not aliased).
  void morph(const cv::Mat& src, cv::Mat& dst, bool erode);
  SnowFilterParams params_;
  std::vector<Run> runs_;
  std::vector<std::pair<int, int>> spans_;  ///< distinct [lo, hi]
  std::vector<cv::Mat> horizontal_;         ///< per span: the row-wise min/max of the source
  std::vector<uint8_t> pad_;                ///< one source row with its replicated border
  cv::Mat eroded_, opened_, near_dot_;
};

/// Everything the frontend writes per frame, kept by the caller across frames: rectified
/// images, filter buffers, the stereo matcher's scratch. One per pipeline (not thread-shared);
/// a member of its owner, never a global.
struct FrontendWorkspace {
  cv::Mat left_rect, right_rect;
  SnowFilter snow;  ///< set to the frontend's parameters on first use
  IlluminationScratch illumination;
  /// The right image's filter buffers, so that its side can be rectified on another thread.
  SnowFilter snow_right;
  IlluminationScratch illumination_right;
  RippleNotch ripple, ripple_right;  ///< set to the frontend's parameters on first use (and on a change)
  matching::StereoMatchWorkspace stereo;
  matching::StereoCompletionWorkspace completion;
  /// SURF's buffers, one per image side: the daemon describes left and right at once.
  features::SurfWorkspace surf_left, surf_right;
};

class Frontend {
 public:
  Frontend(camera::StereoRectifier rectifier, const features::FeatureParams& feature_params,
           const matching::StereoMatchParams& stereo_params, const IlluminationParams& illumination = {},
           const SnowFilterParams& snow = {}, const RippleNotchParams& ripple = {});

  const camera::RectifiedRig& rig() const { return rectifier_.rig(); }
  const camera::StereoRectifier& rectifier() const { return rectifier_; }

  /// Camera `cam` (0 left, 1 right) of `frame` rectified and filtered into its image and
  /// filter buffers of `ws`. The two sides share nothing, so they may run at once.
  void rectifySide(int cam, const StereoFrame& frame, FrontendWorkspace& ws) const;
  /// Features of one rectified image into `out`, reusing its keypoint and descriptor buffers,
  /// with SURF's buffers in `surf` (one per thread calling at once).
  void detect(const cv::Mat& rectified, double threshold, features::SurfWorkspace& surf,
              features::Features& out) const;
  /// Stereo matching + triangulation of detected features into `out`, reusing its buffers
  /// (points, descriptor rows) and `ws`'s scratch, completed on `ws`'s rectified images
  /// (stereo.completion).
  void matchStereo(const features::Features& left, const features::Features& right, FrontendWorkspace& ws,
                   matching::StereoFeatures& out) const;
  /// Copies the workspace's rectified images into `f` (FrameFeatures::left_image, right_image),
  /// reusing `f`'s buffers.
  static void keepImages(const FrontendWorkspace& ws, FrameFeatures& f);
  /// The whole sequence into `out` with the buffers of `ws` and `out` (give back a
  /// FrameFeatures of an earlier frame to reuse its allocations), timed with `now` (may be
  /// empty). The two image sides are rectified, then described, through `parallel` when given
  /// (the daemon's worker): the same result either way.
  void process(const StereoFrame& frame, double threshold, const NowNsFn& now, FrontendWorkspace& ws,
               FrameFeatures& out, ParallelFor* parallel = nullptr) const;
  /// The same into fresh buffers (tools and tests: one frame at a time).
  FrameFeatures process(const StereoFrame& frame, double threshold, const NowNsFn& now) const;

 private:
  camera::StereoRectifier rectifier_;
  features::FeatureExtractor extractor_;
  matching::StereoMatchParams stereo_params_;
  IlluminationParams illumination_;
  SnowFilterParams snow_;
  RippleNotchParams ripple_;
};

}  // namespace seavio::odometry
