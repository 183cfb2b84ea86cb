#pragma once
/// SURF detector and descriptor (Bay, Ess, Tuytelaars, Van Gool, "Speeded-Up Robust
/// Features", CVIU 2008), written from the paper and OpenCV 2.x's nonfree implementation
/// because Debian's OpenCV ships without the nonfree module. The paper uses SURF for its
/// features (section III-B).
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/features/integral_image.hpp"

namespace seavio::features {

/// SURF parameters; the defaults are OpenCV's.
struct SurfParams {
  double hessian_threshold = 400;  ///< default threshold on det(H) [grey level^2]; the call
                                   ///< argument of Surf::detectAndCompute takes precedence
  int octaves = 4;                 ///< number of octaves (filter sizes double per octave)
  int octave_layers = 2;           ///< maxima-bearing layers per octave (filters = layers + 2)
  int first_octave = 0;            ///< finest octave searched (1 skips the 9-27 px filters, whose
                                   ///< features on lit sand ripples slide with the lights)
  bool extended = false;           ///< 128-element descriptor instead of 64
  bool upright = false;            ///< U-SURF: no orientation, descriptor in image axes
  int max_features = 0;            ///< 0 = no cap; else keep the strongest by det(H)
  bool avx2 = true;                ///< AVX2 box-filter kernels where the CPU has them
                                   ///< (bit-identical output; false keeps the SSE2 path)
};

/// Every problem with `p`, one message per bad key ("surf.octaves must be ..."); empty if
/// valid.
std::vector<std::string> validate(const SurfParams& p);

/// The buffers of one SURF call (integral image, response planes, row scratch), kept for the
/// next call: repeated calls on images of the same size allocate nothing but their outputs.
/// One workspace serves one call at a time (one per thread).
class SurfWorkspace {
 public:
  SurfWorkspace() = default;

 private:
  friend class Surf;
  IntegralImage integral_;
  std::unique_ptr<float[]> layers_;
  std::size_t layers_capacity_ = 0;  // floats
  std::unique_ptr<uint32_t[]> scratch_;
  std::size_t scratch_capacity_ = 0;  // entries
};

/// The SURF detector/descriptor. Immutable after construction, so one object may serve the
/// left and right images from two threads at once.
///
/// Keypoint conventions (as OpenCV's SURF): `pt` in pixels with pixel centres at integers;
/// `size` is the interpolated box-filter side [px] (9 at the finest scale; the Gaussian scale
/// is s = 1.2 size / 9); `angle` the dominant gradient direction in degrees [0, 360),
/// clockwise in the image (x right, y down), 0 when upright; `response` det(H); `octave` the
/// octave index; `class_id` the sign of the Laplacian (trace of H: +1 dark blob on bright
/// ground, -1 bright blob), so matchers can skip pairs of opposite sign.
class Surf {
 public:
  /// `params` must be valid (validate() empty): the configuration's loader checks them
  /// (drivers/config), core does not throw.
  explicit Surf(SurfParams params);

  const SurfParams& params() const { return params_; }
  /// True if the box filters run the AVX2 kernels (params().avx2 and the CPU has AVX2).
  bool usesAvx2() const { return use_avx2_; }
  /// 64, or 128 when extended.
  int descriptorSize() const { return params_.extended ? 128 : 64; }
  /// Box-filter side [px] of `layer` in `octave` (Bay's sequence: 9, 15, 21, 27; 15, 27, 39,
  /// 51; 27, 51, 75, 99; ...).
  static int filterSize(int octave, int layer);

  /// Detects keypoints in `gray8` with det(H) > `hessian_threshold` and describes them; false
  /// (and no keypoints) unless `gray8` is CV_8UC1 or empty. `descriptors` becomes CV_32F, one unit-
  /// length row per keypoint, in the same order; keypoints come sorted by response, strongest
  /// first. An image too small for the first octave yields no keypoints.
  bool detectAndCompute(const cv::Mat& gray8, double hessian_threshold,
                        std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors) const;

  /// Detection only, with orientation (keypoints as above, no descriptors).
  bool detect(const cv::Mat& gray8, double hessian_threshold,
              std::vector<cv::KeyPoint>& keypoints) const;

  /// As above with the caller's buffers (~13 bytes per pixel of the largest image), so that
  /// repeated calls allocate only their outputs. The overloads without a workspace make a
  /// fresh one per call: core keeps no hidden per-thread state; the per-frame path passes the
  /// workspace its owner keeps (odometry::FrontendWorkspace, one per image side).
  bool detectAndCompute(const cv::Mat& gray8, double hessian_threshold, std::vector<cv::KeyPoint>& keypoints,
                        cv::Mat& descriptors, SurfWorkspace& workspace) const;
  bool detect(const cv::Mat& gray8, double hessian_threshold, std::vector<cv::KeyPoint>& keypoints,
              SurfWorkspace& workspace) const;

 private:
  bool run(const cv::Mat& gray8, double hessian_threshold, std::vector<cv::KeyPoint>& keypoints,
           cv::Mat* descriptors, SurfWorkspace& workspace) const;
  /// run's body (runWith) compiled for the baseline instruction set and for AVX2 (x86-64).
  void runBaseline(const cv::Mat& gray8, double hessian_threshold, std::vector<cv::KeyPoint>& keypoints,
                   cv::Mat* descriptors, SurfWorkspace& workspace) const;
  void runAvx2(const cv::Mat& gray8, double hessian_threshold, std::vector<cv::KeyPoint>& keypoints,
               cv::Mat* descriptors, SurfWorkspace& workspace) const;
  template <bool kAvx2>
  void runWith(const cv::Mat& gray8, double hessian_threshold, std::vector<cv::KeyPoint>& keypoints,
               cv::Mat* descriptors, SurfWorkspace& workspace) const;

  SurfParams params_;
  bool use_avx2_ = false;  ///< params_.avx2 and the CPU has AVX2
  /// Orientation samples: integer offsets (in units of s) inside radius 6 and their Gaussian
  /// weights (sigma 2.5 s, as OpenCV).
  std::vector<cv::Point> ori_offsets_;
  std::vector<float> ori_weights_;  // padded with 3 zeros (four-lane loop)
  /// The disc's rows as (v, first u, count), in the order of ori_offsets_.
  std::vector<cv::Vec3i> ori_rows_;
  /// Gaussian weights (sigma 3.3 sample spacings) of the 20 x 20 descriptor gradients, in
  /// cellMajor order (the four sub-regions of a band adjacent, as the four-lane sums read them).
  std::vector<float> desc_weights_;
};

}  // namespace seavio::features
