#pragma once
/// Sand-ripple notch: the floor's dominant periodic texture taken out of a rectified image.
///
/// Sand ripples are relief, and the vehicle carries its lights: the bright band on each ripple
/// flank sits where the flank faces the lights, so it slides along the ripples' wave vector as
/// the vehicle passes over them, by ~0.6 % of the vehicle's motion (docs/architecture.md, "Lit
/// ripples"). Features and patches on that shading follow it, and every frame's cloud is the
/// true one under the same body-fixed stretch: the motion comes out short along the wave
/// vector (-0.3 to -0.4 % along the track on ripples across it) and no registration
/// can see it. The albedo (grains, pebbles, rocks) does not move. The ripples' shading is
/// narrow-band, one spatial frequency and its harmonic, while the albedo texture is broadband,
/// so a notch at the spectrum's dominant peak removes most of the sliding part and little of
/// what stays put. A floor without a dominant period (no peak standing out of its annulus)
/// passes unchanged.
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/core/hal/hal.hpp>

namespace seavio::odometry {

struct RippleNotchParams {
  bool enabled = true;
  double min_period_px = 5.0;    ///< periods searched for the peak: [min, max] [px]
  double max_period_px = 40.0;
  double width_fraction = 0.2;   ///< Gaussian notch sigma, fraction of the peak frequency
  int harmonics = 3;             ///< notches at 1..harmonics x the peak
  double min_peak_ratio = 100.0; ///< peak power over the annulus median power to call it ripples
  bool operator==(const RippleNotchParams&) const = default;
};

/// What the notch found in one image.
struct RippleNotchReport {
  bool applied = false;
  double period_px = 0;      ///< of the peak (0 when none searched)
  double direction_rad = 0;  ///< of the wave vector in the image (x right, y down)
  double peak_ratio = 0;     ///< peak power / annulus median power
};

/// Keeps the DFT plans and buffers between frames (frames after the first of a size
/// allocate nothing; cv::dft would build its plan, and allocate, on every call).
class RippleNotch {
 public:
  explicit RippleNotch(const RippleNotchParams& params = {}) : params_(params) {}
  const RippleNotchParams& params() const { return params_; }
  /// Filters `in` into `out` (CV_8UC1, may be the same Mat); a copy when disabled or when the
  /// image has no dominant period.
  RippleNotchReport apply(const cv::Mat& in, cv::Mat& out);

 private:
  RippleNotchParams params_;
  cv::Size plan_size_;
  cv::Ptr<cv::hal::DFT2D> forward_, inverse_;
  cv::Mat real_, spectrum_;
  std::vector<float> annulus_;
};

}  // namespace seavio::odometry
