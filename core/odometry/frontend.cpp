#include "core/odometry/frontend.hpp"

#include <algorithm>
#include <cmath>
#include <functional>

#include <opencv2/imgproc.hpp>

#if defined(__SSE2__)
#include <emmintrin.h>  // baseline on x86-64
#endif

#include "core/common/capacity.hpp"
#include "core/common/stage_timer.hpp"
#include "core/features/mat_rows.hpp"

namespace seavio::odometry {

namespace {

/// Index of `p` in [0, n) under OpenCV's BORDER_REFLECT (fedcba|abcdefgh|hgfedcb), reflected
/// again while outside, as cv::borderInterpolate.
int reflectIndex(int p, int n) {
  if (n == 1) return 0;
  while (p < 0 || p >= n) p = p < 0 ? -p - 1 : 2 * n - p - 1;
  return p;
}

}  // namespace

void GaussianBlur32f::apply(cv::Mat& img, double sigma) {
  CV_Assert(img.type() == CV_32FC1);
  if (img.empty()) return;
  if (sigma != sigma_) {
    // cv::GaussianBlur's kernel for float images and ksize 0: side round(8 sigma + 1), odd;
    // weights exp(-x^2 / (2 sigma^2)) normalised to sum 1.
    const int side = cvRound(sigma * 4 * 2 + 1) | 1;
    kernel_.resize(static_cast<std::size_t>(side));
    double total = 0;
    std::vector<double> w(kernel_.size());
    for (int i = 0; i < side; ++i) {
      const double x = i - (side - 1) * 0.5;
      w[static_cast<std::size_t>(i)] = std::exp(-x * x / (2 * sigma * sigma));
      total += w[static_cast<std::size_t>(i)];
    }
    for (std::size_t i = 0; i < w.size(); ++i) kernel_[i] = static_cast<float>(w[i] / total);
    sigma_ = sigma;
  }
  const int w = img.cols, h = img.rows, side = static_cast<int>(kernel_.size()), r = side / 2;
  const float* k = kernel_.data();
  // Rows: each source row with its reflected border in `pad_`, then the kernel along it.
  tmp_.create(h, w, CV_32FC1);
  pad_.resize(static_cast<std::size_t>(w + 2 * r));
  for (int y = 0; y < h; ++y) {
    const float* s = img.ptr<float>(y);
    for (int x = -r; x < w + r; ++x) pad_[static_cast<std::size_t>(x + r)] = s[reflectIndex(x, w)];
    float* o = tmp_.ptr<float>(y);
    for (int x = 0; x < w; ++x) {
      const float* p = pad_.data() + x;
      float acc = 0.f;
      for (int i = 0; i < side; ++i) acc += p[i] * k[i];
      o[x] = acc;
    }
  }
  // Columns: each output row a weighted sum of the reflected rows of the row pass.
  for (int y = 0; y < h; ++y) {
    float* o = img.ptr<float>(y);
    std::fill(o, o + w, 0.f);
    for (int i = 0; i < side; ++i) {
      const float* q = tmp_.ptr<float>(reflectIndex(y - r + i, h));
      const float ki = k[i];
      for (int x = 0; x < w; ++x) o[x] += q[x] * ki;
    }
  }
}

void normalizeIllumination(const cv::Mat& in, cv::Mat& out, const IlluminationParams& params) {
  IlluminationScratch scratch;
  normalizeIllumination(in, out, params, scratch);
}

namespace {

/// cv::resize's INTER_LINEAR source index and weight along one axis for destination index
/// `d` (centres aligned: (d + 0.5) scale - 0.5, clamped to the first and last sample).
void linearTap(int d, double scale, int src_len, int& index, float& weight) {
  float f = static_cast<float>((d + 0.5) * scale - 0.5);
  int i = cvFloor(f);
  f -= static_cast<float>(i);
  if (i < 0) {
    i = 0;
    f = 0.f;
  }
  if (i >= src_len - 1) {
    i = src_len - 1;
    f = 0.f;
  }
  index = i;
  weight = f;
}

}  // namespace

void normalizeIllumination(const cv::Mat& in, cv::Mat& out, const IlluminationParams& params,
                           IlluminationScratch& scratch) {
  CV_Assert(in.type() == CV_8UC1);
  if (in.empty()) {
    out.create(in.size(), CV_8UC1);
    return;
  }
  const int s = std::max(2, params.scale);
  const int w = in.cols, h = in.rows;
  const int sw = std::max(1, w / s), sh = std::max(1, h / s);
  // 1. Area mean over s x s blocks. Where the image divides evenly this is cv::resize's
  //    INTER_AREA integer-scale path, summed and rounded the same way (bit-identical); other
  //    sizes take cv::resize itself.
  cv::Mat& small = scratch.small_f;
  if (sw * s == w && sh * s == h) {
    small.create(sh, sw, CV_32FC1);
    const float inv_area = 1.f / static_cast<float>(s * s);
    scratch.block_sum.assign(static_cast<std::size_t>(sw), 0);
    for (int by = 0; by < sh; ++by) {
      std::fill(scratch.block_sum.begin(), scratch.block_sum.end(), 0);
      for (int y = by * s; y < (by + 1) * s; ++y) {
        const uint8_t* r = in.ptr<uint8_t>(y);
        for (int bx = 0; bx < sw; ++bx) {
          int acc = 0;
          int x = bx * s;
#if defined(__SSE2__)
          // 16 bytes per step: psadbw against zero sums them into two 64-bit lanes.
          for (; x + 16 <= (bx + 1) * s; x += 16) {
            const __m128i sad =
                _mm_sad_epu8(_mm_loadu_si128(reinterpret_cast<const __m128i*>(r + x)), _mm_setzero_si128());
            acc += _mm_cvtsi128_si32(sad) + _mm_cvtsi128_si32(_mm_srli_si128(sad, 8));
          }
#endif
          for (; x < (bx + 1) * s; ++x) acc += r[x];
          scratch.block_sum[static_cast<std::size_t>(bx)] += acc;
        }
      }
      float* o = small.ptr<float>(by);
      for (int bx = 0; bx < sw; ++bx)
        o[bx] = cv::saturate_cast<uint8_t>(static_cast<float>(scratch.block_sum[static_cast<std::size_t>(bx)]) * inv_area);
    }
  } else {
    cv::resize(in, scratch.small, cv::Size(sw, sh), 0, 0, cv::INTER_AREA);
    scratch.small.convertTo(small, CV_32F);
  }
  // 2. Our Gaussian, not cv::GaussianBlur: OpenCV builds its kernel and filter engine on every
  //    call (about a dozen allocations per image); results agree to float rounding.
  if (params.blur_sigma > 0) scratch.blur.apply(small, params.blur_sigma);
  for (int y = 0; y < sh; ++y) {
    float* r = small.ptr<float>(y);
    for (int x = 0; x < sw; ++x) r[x] = std::max(r[x], 1.f);
  }
  // 3. Bilinear back to full size (cv::resize INTER_LINEAR's taps and order: along rows, then
  //    between rows), fused with the division and the rounding to 8 bits, so the full-size
  //    float images are never stored. Taps are remade only when the size changes.
  if (scratch.taps_size != in.size() || scratch.taps_small != small.size()) {
    scratch.x_index.resize(static_cast<std::size_t>(w));
    scratch.x_weight.resize(static_cast<std::size_t>(w));
    scratch.y_index.resize(static_cast<std::size_t>(h));
    scratch.y_weight.resize(static_cast<std::size_t>(h));
    // cv::resize's source step per destination pixel: 1 / (destination / source size).
    const double scale_x = 1.0 / (static_cast<double>(w) / sw), scale_y = 1.0 / (static_cast<double>(h) / sh);
    for (int x = 0; x < w; ++x)
      linearTap(x, scale_x, sw, scratch.x_index[static_cast<std::size_t>(x)],
                scratch.x_weight[static_cast<std::size_t>(x)]);
    for (int y = 0; y < h; ++y)
      linearTap(y, scale_y, sh, scratch.y_index[static_cast<std::size_t>(y)],
                scratch.y_weight[static_cast<std::size_t>(y)]);
    scratch.taps_size = in.size();
    scratch.taps_small = small.size();
  }
  scratch.rows_f.create(sh, w, CV_32FC1);  // each low-pass row resampled to full width
  for (int y = 0; y < sh; ++y) {
    const float* r = small.ptr<float>(y);
    float* o = scratch.rows_f.ptr<float>(y);
    for (int x = 0; x < w; ++x) {
      const int i = scratch.x_index[static_cast<std::size_t>(x)];
      const float a = scratch.x_weight[static_cast<std::size_t>(x)];
      o[x] = i + 1 < sw ? r[i] * (1.f - a) + r[i + 1] * a : r[i];
    }
  }
  out.create(h, w, CV_8UC1);  // may be `in` itself: each pixel is read before it is written
  const float target = static_cast<float>(params.target_grey);
  for (int y = 0; y < h; ++y) {
    const int j = scratch.y_index[static_cast<std::size_t>(y)];
    const float b = scratch.y_weight[static_cast<std::size_t>(y)];
    const float* r0 = scratch.rows_f.ptr<float>(j);
    const float* r1 = scratch.rows_f.ptr<float>(std::min(j + 1, sh - 1));
    const uint8_t* src = in.ptr<uint8_t>(y);
    uint8_t* dst = out.ptr<uint8_t>(y);
    const float b0 = 1.f - b;
    int x = 0;
#if defined(__SSE2__)
    // Eight pixels per step, the scalar loop's float operations per lane; cvtps rounds to
    // nearest even as cvRound does, and the two saturating packs clamp to [0, 255] as
    // saturate_cast: identical bytes.
    const __m128 vb0 = _mm_set1_ps(b0), vb = _mm_set1_ps(b), vt = _mm_set1_ps(target);
    const __m128i zero = _mm_setzero_si128();
    for (; x + 8 <= w; x += 8) {
      const __m128 l0 = _mm_add_ps(_mm_mul_ps(_mm_loadu_ps(r0 + x), vb0), _mm_mul_ps(_mm_loadu_ps(r1 + x), vb));
      const __m128 l1 =
          _mm_add_ps(_mm_mul_ps(_mm_loadu_ps(r0 + x + 4), vb0), _mm_mul_ps(_mm_loadu_ps(r1 + x + 4), vb));
      const __m128i p = _mm_unpacklo_epi8(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(src + x)), zero);
      const __m128 s0 = _mm_cvtepi32_ps(_mm_unpacklo_epi16(p, zero));
      const __m128 s1 = _mm_cvtepi32_ps(_mm_unpackhi_epi16(p, zero));
      const __m128i q0 = _mm_cvtps_epi32(_mm_div_ps(_mm_mul_ps(s0, vt), l0));
      const __m128i q1 = _mm_cvtps_epi32(_mm_div_ps(_mm_mul_ps(s1, vt), l1));
      const __m128i q = _mm_packs_epi32(q0, q1);
      _mm_storel_epi64(reinterpret_cast<__m128i*>(dst + x), _mm_packus_epi16(q, q));
    }
#endif
    for (; x < w; ++x) {
      const float low = r0[x] * b0 + r1[x] * b;
      dst[x] = cv::saturate_cast<uint8_t>(static_cast<float>(src[x]) * target / low);
    }
  }
}

namespace {
/// The opening's cut limited to the snow: a pixel within one of a dot (more than `dot_dn` above
/// the opening) takes the opening, so the dot and its halo go; elsewhere the pixel keeps up to
/// `keep_dn` above the opening, so the floor's own fine bright texture, which a plain opening
/// flattens too, survives. `near_dot` is scratch (CV_8UC1, the image's size). May run in place.
void cutSnowDots(const cv::Mat& in, const cv::Mat& opened, cv::Mat& out, const SnowFilterParams& params,
                 cv::Mat& near_dot) {
  const int w = in.cols, h = in.rows;
  // near_dot: the rows' dots dilated by one column; the row dilation follows in the output loop.
  near_dot.create(h, w, CV_8UC1);
  for (int y = 0; y < h; ++y) {
    const uint8_t* s = in.ptr<uint8_t>(y);
    const uint8_t* o = opened.ptr<uint8_t>(y);
    uint8_t* m = near_dot.ptr<uint8_t>(y);
    std::fill(m, m + w, uint8_t{0});
    for (int x = 0; x < w; ++x) {
      if (s[x] - o[x] <= params.dot_dn) continue;
      m[x] = 1;
      if (x > 0) m[x - 1] = 1;
      if (x + 1 < w) m[x + 1] = 1;
    }
  }
  out.create(h, w, CV_8UC1);
  for (int y = 0; y < h; ++y) {
    const uint8_t* s = in.ptr<uint8_t>(y);
    const uint8_t* o = opened.ptr<uint8_t>(y);
    const uint8_t* m0 = near_dot.ptr<uint8_t>(std::max(0, y - 1));
    const uint8_t* m1 = near_dot.ptr<uint8_t>(y);
    const uint8_t* m2 = near_dot.ptr<uint8_t>(std::min(h - 1, y + 1));
    uint8_t* d = out.ptr<uint8_t>(y);
    for (int x = 0; x < w; ++x)
      d[x] = (m0[x] | m1[x] | m2[x]) ? o[x] : static_cast<uint8_t>(std::min<int>(s[x], o[x] + params.keep_dn));
  }
}
}  // namespace

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
  if (params_.keep_dn <= 0) {
    morph(eroded_, out, false);
    return;
  }
  morph(eroded_, opened_, false);
  cutSnowDots(in, opened_, out, params_, near_dot_);
}

void suppressSnow(const cv::Mat& in, cv::Mat& out, const SnowFilterParams& params) {
  if (!params.enabled || params.kernel_px < 2) {
    if (out.data != in.data) in.copyTo(out);
    return;
  }
  const cv::Mat disc = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(params.kernel_px, params.kernel_px));
  if (params.keep_dn <= 0) {
    cv::morphologyEx(in, out, cv::MORPH_OPEN, disc, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
    return;
  }
  cv::Mat opened, near_dot;
  cv::morphologyEx(in, opened, cv::MORPH_OPEN, disc, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  cutSnowDots(in, opened, out, params, near_dot);
}

Frontend::Frontend(camera::StereoRectifier rectifier, const features::FeatureParams& feature_params,
                   const matching::StereoMatchParams& stereo_params, const IlluminationParams& illumination,
                   const SnowFilterParams& snow, const RippleNotchParams& ripple)
    : rectifier_(std::move(rectifier)),
      extractor_(feature_params),
      stereo_params_(stereo_params),
      illumination_(illumination),
      snow_(snow),
      ripple_(ripple) {}

void Frontend::rectifySide(int cam, const StereoFrame& frame, FrontendWorkspace& ws) const {
  cv::Mat& rect = cam == 0 ? ws.left_rect : ws.right_rect;
  SnowFilter& snow = cam == 0 ? ws.snow : ws.snow_right;
  rectifier_.rectifyOne(cam, cam == 0 ? frame.left : frame.right, rect);
  if (snow_.enabled) {
    if (snow.params() != snow_) snow = SnowFilter(snow_);
    snow.apply(rect, rect);
  }
  if (illumination_.enabled)
    normalizeIllumination(rect, rect, illumination_, cam == 0 ? ws.illumination : ws.illumination_right);
  if (ripple_.enabled) {
    RippleNotch& notch = cam == 0 ? ws.ripple : ws.ripple_right;
    if (notch.params() != ripple_) notch = RippleNotch(ripple_);
    notch.apply(rect, rect);
  }
}

void Frontend::detect(const cv::Mat& rectified, double threshold, features::SurfWorkspace& surf,
                      features::Features& out) const {
  extractor_.extract(rectified, threshold, surf, out);
}

void Frontend::matchStereo(const features::Features& left, const features::Features& right, FrontendWorkspace& ws,
                           matching::StereoFeatures& out) const {
  matching::matchStereo(left.keypoints, left.descriptors, right.keypoints, right.descriptors, rectifier_.rig(),
                        stereo_params_, ws.stereo, out.points);
  out.completed = matching::completeStereo(left.keypoints, ws.left_rect, ws.right_rect, rectifier_.rig(),
                                           stereo_params_, ws.completion, out.points);
  const int n = static_cast<int>(out.points.size());
  features::fitRows(out.descriptors, n, left.descriptors.cols, left.descriptors.type());
  resizeWithHeadroom(out.laplacian_sign, out.points.size());
  for (std::size_t i = 0; i < out.points.size(); ++i) {
    const int l = out.points[i].left_index;
    left.descriptors.row(l).copyTo(out.descriptors.row(static_cast<int>(i)));
    out.laplacian_sign[i] = left.keypoints[static_cast<std::size_t>(l)].class_id;
  }
}

namespace {

/// `side(0)` and `side(1)`, through `parallel` when given. Passed by reference (a
/// reference_wrapper fits std::function's own storage), so a frame allocates nothing here.
template <typename Side>
void forBothSides(ParallelFor* parallel, const Side& side) {
  if (parallel) {
    parallel->run(2, std::cref(side));
    return;
  }
  side(0);
  side(1);
}

}  // namespace

void Frontend::process(const StereoFrame& frame, double threshold, const NowNsFn& now, FrontendWorkspace& ws,
                       FrameFeatures& f, ParallelFor* parallel) const {
  f.t_ns = frame.t_ns;
  f.seq = frame.seq;
  f.detector_threshold = threshold;
  f.times = StageTimes{};
  StageTimer timer(now);
  // Left and right share nothing until stereo matching: each side has its own image, filter
  // and SURF buffers in `ws`.
  const auto rectifyOne = [&](std::size_t cam) { rectifySide(static_cast<int>(cam), frame, ws); };
  forBothSides(parallel, rectifyOne);
  f.times.rectify_ms = timer.lap_ms();
  const auto detectOne = [&](std::size_t cam) {
    if (cam == 0) {
      detect(ws.left_rect, threshold, ws.surf_left, f.left);
    } else {
      detect(ws.right_rect, threshold, ws.surf_right, f.right);
    }
  };
  forBothSides(parallel, detectOne);
  f.times.features_ms = timer.lap_ms();
  matchStereo(f.left, f.right, ws, f.stereo);
  f.times.stereo_ms = timer.lap_ms();
  keepImages(ws, f);
}

void Frontend::keepImages(const FrontendWorkspace& ws, FrameFeatures& f) {
  ws.left_rect.copyTo(f.left_image);
  ws.right_rect.copyTo(f.right_image);
}

FrameFeatures Frontend::process(const StereoFrame& frame, double threshold, const NowNsFn& now) const {
  FrontendWorkspace ws;
  FrameFeatures f;
  process(frame, threshold, now, ws, f);
  return f;
}

}  // namespace seavio::odometry
