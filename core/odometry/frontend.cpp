#include "core/odometry/frontend.hpp"

#include <algorithm>

#include <opencv2/imgproc.hpp>

#include "core/common/stage_timer.hpp"

namespace seavio::odometry {

void normalizeIllumination(const cv::Mat& in, cv::Mat& out, const IlluminationParams& params) {
  const int s = std::max(2, params.scale);
  cv::Mat small, low, in_f, low_f;
  cv::resize(in, small, cv::Size(std::max(1, in.cols / s), std::max(1, in.rows / s)), 0, 0, cv::INTER_AREA);
  small.convertTo(small, CV_32F);
  if (params.blur_sigma > 0) cv::GaussianBlur(small, small, cv::Size(0, 0), params.blur_sigma, 0, cv::BORDER_REFLECT);
  cv::max(small, 1.0, small);
  cv::resize(small, low_f, in.size(), 0, 0, cv::INTER_LINEAR);
  in.convertTo(in_f, CV_32F);
  cv::divide(in_f, low_f, in_f, params.target_grey);
  in_f.convertTo(out, CV_8U);
}

void suppressSnow(const cv::Mat& in, cv::Mat& out, const SnowFilterParams& params) {
  if (!params.enabled || params.kernel_px < 2) {
    if (out.data != in.data) in.copyTo(out);
    return;
  }
  const cv::Mat disc = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(params.kernel_px, params.kernel_px));
  cv::morphologyEx(in, out, cv::MORPH_OPEN, disc, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
}

Frontend::Frontend(camera::StereoRectifier rectifier, const features::FeatureParams& feature_params,
                   const matching::StereoMatchParams& stereo_params, const IlluminationParams& illumination,
                   const SnowFilterParams& snow)
    : rectifier_(std::move(rectifier)),
      extractor_(feature_params),
      stereo_params_(stereo_params),
      illumination_(illumination),
      snow_(snow) {}

void Frontend::rectify(const StereoFrame& frame, cv::Mat& left_rect, cv::Mat& right_rect) const {
  rectifier_.rectify(frame.left, frame.right, left_rect, right_rect);
  if (snow_.enabled) {
    suppressSnow(left_rect, left_rect, snow_);
    suppressSnow(right_rect, right_rect, snow_);
  }
  if (illumination_.enabled) {
    normalizeIllumination(left_rect, left_rect, illumination_);
    normalizeIllumination(right_rect, right_rect, illumination_);
  }
}

features::Features Frontend::detect(const cv::Mat& rectified, double threshold) const {
  return extractor_.extract(rectified, threshold);
}

matching::StereoFeatures Frontend::matchStereo(const features::Features& left, const features::Features& right) const {
  matching::StereoFeatures out;
  out.points = matching::matchStereo(left.keypoints, left.descriptors, right.keypoints, right.descriptors,
                                     rectifier_.rig(), stereo_params_);
  out.descriptors.create(static_cast<int>(out.points.size()), left.descriptors.cols, left.descriptors.type());
  out.laplacian_sign.resize(out.points.size());
  for (std::size_t i = 0; i < out.points.size(); ++i) {
    const int l = out.points[i].left_index;
    left.descriptors.row(l).copyTo(out.descriptors.row(static_cast<int>(i)));
    out.laplacian_sign[i] = left.keypoints[static_cast<std::size_t>(l)].class_id;
  }
  return out;
}

FrameFeatures Frontend::process(const StereoFrame& frame, double threshold, const NowNsFn& now) const {
  FrameFeatures f;
  f.t_ns = frame.t_ns;
  f.seq = frame.seq;
  f.detector_threshold = threshold;
  StageTimer timer(now);
  cv::Mat left, right;
  rectify(frame, left, right);
  f.times.rectify_ms = timer.lap_ms();
  f.left = detect(left, threshold);
  f.right = detect(right, threshold);
  f.times.features_ms = timer.lap_ms();
  f.stereo = matchStereo(f.left, f.right);
  f.times.stereo_ms = timer.lap_ms();
  return f;
}

}  // namespace seavio::odometry
