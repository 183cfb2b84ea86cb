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

void normalizeIllumination(const cv::Mat& in, cv::Mat& out, const IlluminationParams& params,
                           IlluminationScratch& scratch) {
  // The steps of the version above, each into a buffer kept in `scratch`.
  const int s = std::max(2, params.scale);
  cv::resize(in, scratch.small, cv::Size(std::max(1, in.cols / s), std::max(1, in.rows / s)), 0, 0, cv::INTER_AREA);
  cv::Mat& small = scratch.small_f;
  scratch.small.convertTo(small, CV_32F);
  if (params.blur_sigma > 0) cv::GaussianBlur(small, small, cv::Size(0, 0), params.blur_sigma, 0, cv::BORDER_REFLECT);
  cv::max(small, 1.0, small);
  cv::resize(small, scratch.low_f, in.size(), 0, 0, cv::INTER_LINEAR);
  in.convertTo(scratch.in_f, CV_32F);
  cv::divide(scratch.in_f, scratch.low_f, scratch.in_f, params.target_grey);
  scratch.in_f.convertTo(out, CV_8U);
}

SnowFilter::SnowFilter(const SnowFilterParams& params) : params_(params) {
  if (!params_.enabled || params_.kernel_px < 2) return;
  const int k = params_.kernel_px;
  const cv::Mat disc = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(k, k));
  const int ax = k / 2, ay = k / 2;  // OpenCV's default anchor: the kernel centre
  for (int i = 0; i < disc.rows; ++i) {
    const uint8_t* row = disc.ptr<uint8_t>(i);
    for (int j = 0; j < disc.cols;) {
      if (!row[j]) {
        ++j;
        continue;
      }
      int e = j;
      while (e + 1 < disc.cols && row[e + 1]) ++e;
      const std::pair<int, int> span{j - ax, e - ax};
      const auto it = std::find(spans_.begin(), spans_.end(), span);
      const int index = static_cast<int>(it - spans_.begin());
      if (it == spans_.end()) spans_.push_back(span);
      runs_.push_back(Run{i - ay, span.first, span.second, index});
      j = e + 1;
    }
  }
  horizontal_.resize(spans_.size());
}

void SnowFilter::morph(const cv::Mat& src, cv::Mat& dst, bool erode) {
  const int w = src.cols, h = src.rows;
  // Row-wise min/max over each distinct span, the border replicated into a padded row.
  for (std::size_t si = 0; si < spans_.size(); ++si) {
    const auto [lo, hi] = spans_[si];
    if (lo == 0 && hi == 0) continue;  // the source row itself
    cv::Mat& out = horizontal_[si];
    out.create(h, w, CV_8UC1);
    const int left = std::max(0, -lo), right = std::max(0, hi);
    pad_.resize(static_cast<std::size_t>(w + left + right));
    for (int y = 0; y < h; ++y) {
      const uint8_t* s = src.ptr<uint8_t>(y);
      uint8_t* p = pad_.data();
      std::fill(p, p + left, s[0]);
      std::copy(s, s + w, p + left);
      std::fill(p + left + w, p + left + w + right, s[w - 1]);
      uint8_t* o = out.ptr<uint8_t>(y);
      const uint8_t* first = p + left + lo;
      std::copy(first, first + w, o);
      for (int k = 1; k <= hi - lo; ++k) {
        const uint8_t* q = first + k;
        if (erode) {
          for (int x = 0; x < w; ++x) o[x] = std::min(o[x], q[x]);
        } else {
          for (int x = 0; x < w; ++x) o[x] = std::max(o[x], q[x]);
        }
      }
    }
  }
  // Column step: each output row combines the kernel's rows, rows clamped at the border.
  dst.create(h, w, CV_8UC1);
  for (int y = 0; y < h; ++y) {
    uint8_t* o = dst.ptr<uint8_t>(y);
    bool first = true;
    for (const Run& r : runs_) {
      const int yy = std::clamp(y + r.dy, 0, h - 1);
      const auto [lo, hi] = spans_[static_cast<std::size_t>(r.span)];
      const uint8_t* q =
          lo == 0 && hi == 0 ? src.ptr<uint8_t>(yy) : horizontal_[static_cast<std::size_t>(r.span)].ptr<uint8_t>(yy);
      if (first) {
        std::copy(q, q + w, o);
        first = false;
      } else if (erode) {
        for (int x = 0; x < w; ++x) o[x] = std::min(o[x], q[x]);
      } else {
        for (int x = 0; x < w; ++x) o[x] = std::max(o[x], q[x]);
      }
    }
  }
}

void SnowFilter::apply(const cv::Mat& in, cv::Mat& out) {
  if (runs_.empty()) {
    if (out.data != in.data) in.copyTo(out);
    return;
  }
  if (in.type() != CV_8UC1 || in.empty()) {
    suppressSnow(in, out, params_);
    return;
  }
  morph(in, eroded_, true);
  morph(eroded_, out, false);
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

void Frontend::rectify(const StereoFrame& frame, FrontendWorkspace& ws) const {
  rectifier_.rectify(frame.left, frame.right, ws.left_rect, ws.right_rect);
  if (snow_.enabled) {
    if (ws.snow.params().enabled != snow_.enabled || ws.snow.params().kernel_px != snow_.kernel_px)
      ws.snow = SnowFilter(snow_);
    ws.snow.apply(ws.left_rect, ws.left_rect);
    ws.snow.apply(ws.right_rect, ws.right_rect);
  }
  if (illumination_.enabled) {
    normalizeIllumination(ws.left_rect, ws.left_rect, illumination_, ws.illumination);
    normalizeIllumination(ws.right_rect, ws.right_rect, illumination_, ws.illumination);
  }
}

features::Features Frontend::detect(const cv::Mat& rectified, double threshold) const {
  return extractor_.extract(rectified, threshold);
}

features::Features Frontend::detect(const cv::Mat& rectified, double threshold, features::SurfWorkspace& surf) const {
  return extractor_.extract(rectified, threshold, surf);
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

namespace {

/// Makes `m` a rows x cols matrix of `type` for writing, keeping its allocation across frames:
/// cv::Mat::resize changes the row count in place while the rows fit, and growth leaves
/// headroom so a slowly rising count does not reallocate every frame. A buffer shared with
/// another Mat header is never written into.
void fitRows(cv::Mat& m, int rows, int cols, int type) {
  const bool reusable = m.u != nullptr && m.u->refcount == 1 && m.dims == 2 && m.cols == cols && m.type() == type &&
                        !m.isSubmatrix() && m.step[0] > 0;
  const auto capacity = reusable ? static_cast<std::size_t>(m.datalimit - m.datastart) / m.step[0] : 0;
  if (!reusable || static_cast<std::size_t>(rows) > capacity) {
    m = cv::Mat(std::max(rows + rows / 2, 1), cols, type);
  }
  m.resize(static_cast<std::size_t>(rows));
}

}  // namespace

void Frontend::matchStereo(const features::Features& left, const features::Features& right, FrontendWorkspace& ws,
                           matching::StereoFeatures& out) const {
  matching::matchStereo(left.keypoints, left.descriptors, right.keypoints, right.descriptors, rectifier_.rig(),
                        stereo_params_, ws.stereo, out.points);
  const int n = static_cast<int>(out.points.size());
  fitRows(out.descriptors, n, left.descriptors.cols, left.descriptors.type());
  out.laplacian_sign.resize(out.points.size());
  for (std::size_t i = 0; i < out.points.size(); ++i) {
    const int l = out.points[i].left_index;
    left.descriptors.row(l).copyTo(out.descriptors.row(static_cast<int>(i)));
    out.laplacian_sign[i] = left.keypoints[static_cast<std::size_t>(l)].class_id;
  }
}

void Frontend::process(const StereoFrame& frame, double threshold, const NowNsFn& now, FrontendWorkspace& ws,
                       FrameFeatures& f) const {
  f.t_ns = frame.t_ns;
  f.seq = frame.seq;
  f.detector_threshold = threshold;
  f.times = StageTimes{};
  StageTimer timer(now);
  rectify(frame, ws);
  f.times.rectify_ms = timer.lap_ms();
  f.left = detect(ws.left_rect, threshold, ws.surf_left);
  f.right = detect(ws.right_rect, threshold, ws.surf_right);
  f.times.features_ms = timer.lap_ms();
  matchStereo(f.left, f.right, ws, f.stereo);
  f.times.stereo_ms = timer.lap_ms();
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
