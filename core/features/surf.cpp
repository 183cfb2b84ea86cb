#include "core/features/surf.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>

#include "core/features/integral_image.hpp"

namespace seavio::features {
namespace {

constexpr int kOriRadius = 6;          // orientation samples within 6 s (Bay 2008, 4.1)
constexpr float kOriSigma = 2.5f;      // OpenCV's weight; Bay states 2 s
constexpr int kOriWindowDeg = 60;      // sliding sector
constexpr int kPatch = 20;             // 20 s descriptor window, 4 x 4 sub-regions of 5 x 5
constexpr float kDescSigma = 3.3f;     // Gaussian over the window, in sample spacings
constexpr float kDxyWeight = 0.9f;     // balances the box approximation (Bay 2008, eq. 4)

/// A box sum S(a) - S(b) - S(c) + S(d) expressed as offsets from S(x, y) of the filter
/// centre; unsigned arithmetic so a wrapped table still gives the exact sum.
struct Box {
  std::ptrdiff_t a, b, c, d;
  /// Box of pixels with columns [x + dx0, x + dx1] and rows [y + dy0, y + dy1] (inclusive).
  static Box make(int dx0, int dy0, int dx1, int dy1, std::ptrdiff_t stride) {
    const std::ptrdiff_t c0 = dx0, c1 = dx1 + 1, r0 = dy0, r1 = dy1 + 1;
    return {r1 * stride + c1, r0 * stride + c1, r1 * stride + c0, r0 * stride + c0};
  }
  float sum(const uint32_t* p) const {
    return static_cast<float>(static_cast<int32_t>(p[a] - p[b] - p[c] + p[d]));
  }
};

/// The three box filters of one scale (Bay 2008, Fig. 1): lobe length l = size / 3.
struct HessianFilter {
  Box xx_all, xx_mid, yy_all, yy_mid, xy_tl, xy_tr, xy_bl, xy_br;
  float inv_lobe_area = 0;  // 1 / (l (2l - 1)): normalise by filter area (scale invariance)
  float inv_xy_area = 0;    // 1 / l^2

  HessianFilter(int size, std::ptrdiff_t stride) {
    const int l = size / 3;
    const int h = (size - 1) / 2;
    const int m = (l - 1) / 2;
    xx_all = Box::make(-h, -(l - 1), h, l - 1, stride);
    xx_mid = Box::make(-m, -(l - 1), m, l - 1, stride);
    yy_all = Box::make(-(l - 1), -h, l - 1, h, stride);
    yy_mid = Box::make(-(l - 1), -m, l - 1, m, stride);
    xy_tl = Box::make(-l, -l, -1, -1, stride);
    xy_tr = Box::make(1, -l, l, -1, stride);
    xy_bl = Box::make(-l, 1, -1, l, stride);
    xy_br = Box::make(1, 1, l, l, stride);
    inv_lobe_area = 1.f / static_cast<float>(l * (2 * l - 1));
    inv_xy_area = 1.f / static_cast<float>(l * l);
  }
  float dxx(const uint32_t* p) const { return (xx_all.sum(p) - 3.f * xx_mid.sum(p)) * inv_lobe_area; }
  float dyy(const uint32_t* p) const { return (yy_all.sum(p) - 3.f * yy_mid.sum(p)) * inv_lobe_area; }
};

/// det(H) along one grid row of `n` samples `step` pixels apart, starting at `base` (the
/// table entry of the first filter centre). Offsets are copied to locals so the compiler keeps
/// them in registers; on the finest octave step is 1 and the loop vectorises.
inline void hessianRow(const HessianFilter& f, const uint32_t* base, std::ptrdiff_t step, int n,
                       float* out) {
  const std::ptrdiff_t xa0 = f.xx_all.a, xa1 = f.xx_all.b, xa2 = f.xx_all.c, xa3 = f.xx_all.d;
  const std::ptrdiff_t xm0 = f.xx_mid.a, xm1 = f.xx_mid.b, xm2 = f.xx_mid.c, xm3 = f.xx_mid.d;
  const std::ptrdiff_t ya0 = f.yy_all.a, ya1 = f.yy_all.b, ya2 = f.yy_all.c, ya3 = f.yy_all.d;
  const std::ptrdiff_t ym0 = f.yy_mid.a, ym1 = f.yy_mid.b, ym2 = f.yy_mid.c, ym3 = f.yy_mid.d;
  const std::ptrdiff_t t0 = f.xy_tl.a, t1 = f.xy_tl.b, t2 = f.xy_tl.c, t3 = f.xy_tl.d;
  const std::ptrdiff_t r0 = f.xy_tr.a, r1 = f.xy_tr.b, r2 = f.xy_tr.c, r3 = f.xy_tr.d;
  const std::ptrdiff_t l0 = f.xy_bl.a, l1 = f.xy_bl.b, l2 = f.xy_bl.c, l3 = f.xy_bl.d;
  const std::ptrdiff_t b0 = f.xy_br.a, b1 = f.xy_br.b, b2 = f.xy_br.c, b3 = f.xy_br.d;
  const float wl = f.inv_lobe_area, wxy = f.inv_xy_area * kDxyWeight;
  for (int j = 0; j < n; ++j) {
    const uint32_t* p = base + j * step;
    const int32_t xx = static_cast<int32_t>((p[xa0] - p[xa1] - p[xa2] + p[xa3]) -
                                            3u * (p[xm0] - p[xm1] - p[xm2] + p[xm3]));
    const int32_t yy = static_cast<int32_t>((p[ya0] - p[ya1] - p[ya2] + p[ya3]) -
                                            3u * (p[ym0] - p[ym1] - p[ym2] + p[ym3]));
    const int32_t xy = static_cast<int32_t>((p[t0] - p[t1] - p[t2] + p[t3]) + (p[b0] - p[b1] - p[b2] + p[b3]) -
                                            (p[r0] - p[r1] - p[r2] + p[r3]) - (p[l0] - p[l1] - p[l2] + p[l3]));
    const float dxx = static_cast<float>(xx) * wl, dyy = static_cast<float>(yy) * wl;
    const float dxy = static_cast<float>(xy) * wxy;
    out[j] = dxx * dyy - dxy * dxy;
  }
}

/// Valid grid index range [lo, hi] of a filter of side `size` sampled every `step` pixels
/// along an axis of `extent` pixels (the whole filter inside the image).
inline void validRange(int size, int step, int extent, int& lo, int& hi) {
  const int h = (size - 1) / 2;
  lo = (h + step - 1) / step;
  hi = (extent - 1 - h) >= 0 ? (extent - 1 - h) / step : -1;
}

/// Fits a 3D quadratic to the 3 x 3 x 3 neighbourhood (Brown and Lowe 2002, as Bay 2008,
/// 3.3) and returns the offset of its extremum in grid units, or false if it leaves the cell.
bool interpolate(const float n[3][9], cv::Vec3d& offset) {
  const cv::Vec3d b(-(n[1][5] - n[1][3]) / 2.0, -(n[1][7] - n[1][1]) / 2.0,
                    -(n[2][4] - n[0][4]) / 2.0);
  const double dxx = n[1][3] - 2.0 * n[1][4] + n[1][5];
  const double dyy = n[1][1] - 2.0 * n[1][4] + n[1][7];
  const double dss = n[0][4] - 2.0 * n[1][4] + n[2][4];
  const double dxy = (n[1][8] - n[1][6] - n[1][2] + n[1][0]) / 4.0;
  const double dxs = (n[2][5] - n[2][3] - n[0][5] + n[0][3]) / 4.0;
  const double dys = (n[2][7] - n[2][1] - n[0][7] + n[0][1]) / 4.0;
  const cv::Matx33d a(dxx, dxy, dxs, dxy, dyy, dys, dxs, dys, dss);
  if (!cv::solve(a, b, offset, cv::DECOMP_LU)) return false;
  return std::isfinite(offset[0]) && std::isfinite(offset[1]) && std::isfinite(offset[2]) &&
         std::abs(offset[0]) <= 1.0 && std::abs(offset[1]) <= 1.0 && std::abs(offset[2]) <= 1.0;
}

inline float bilinear(const cv::Mat& img, float x, float y) {
  const int ix = static_cast<int>(std::floor(x));
  const int iy = static_cast<int>(std::floor(y));
  if (ix >= 0 && iy >= 0 && ix < img.cols - 1 && iy < img.rows - 1) {
    const float a = x - static_cast<float>(ix), b = y - static_cast<float>(iy);
    const uint8_t* p = img.ptr<uint8_t>(iy) + ix;
    const uint8_t* q = p + img.step[0];
    return (1.f - b) * ((1.f - a) * p[0] + a * p[1]) + b * ((1.f - a) * q[0] + a * q[1]);
  }
  const int cx = std::clamp(static_cast<int>(std::lround(x)), 0, img.cols - 1);
  const int cy = std::clamp(static_cast<int>(std::lround(y)), 0, img.rows - 1);
  return img.at<uint8_t>(cy, cx);
}

}  // namespace

std::vector<std::string> validate(const SurfParams& p) {
  std::vector<std::string> errors;
  if (!(p.hessian_threshold >= 0) || !std::isfinite(p.hessian_threshold)) {
    errors.push_back("surf.hessian_threshold must be finite and >= 0");
  }
  if (p.octaves < 1 || p.octaves > 8) errors.push_back("surf.octaves must be in [1, 8]");
  if (p.octave_layers < 1 || p.octave_layers > 8) {
    errors.push_back("surf.octave_layers must be in [1, 8]");
  }
  if (p.max_features < 0) errors.push_back("surf.max_features must be >= 0 (0 = no cap)");
  return errors;
}

int Surf::filterSize(int octave, int layer) { return 3 * ((2 << octave) * (layer + 1) + 1); }

Surf::Surf(SurfParams params) : params_(params) {
  const auto errors = validate(params_);
  if (!errors.empty()) {
    std::string msg = "invalid SURF parameters:";
    for (const auto& e : errors) msg += " " + e + ";";
    throw std::invalid_argument(msg);
  }
  for (int v = -kOriRadius; v <= kOriRadius; ++v) {
    for (int u = -kOriRadius; u <= kOriRadius; ++u) {
      if (u * u + v * v > kOriRadius * kOriRadius) continue;
      ori_offsets_.emplace_back(u, v);
      ori_weights_.push_back(
          std::exp(-static_cast<float>(u * u + v * v) / (2.f * kOriSigma * kOriSigma)));
    }
  }
  desc_weights_.resize(kPatch * kPatch);
  for (int r = 0; r < kPatch; ++r) {
    for (int c = 0; c < kPatch; ++c) {
      const float dr = static_cast<float>(r) - (kPatch - 1) / 2.f;
      const float dc = static_cast<float>(c) - (kPatch - 1) / 2.f;
      desc_weights_[r * kPatch + c] = std::exp(-(dr * dr + dc * dc) / (2.f * kDescSigma * kDescSigma));
    }
  }
}

void Surf::detectAndCompute(const cv::Mat& gray8, double hessian_threshold,
                            std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors) const {
  run(gray8, hessian_threshold, keypoints, &descriptors);
}

void Surf::detect(const cv::Mat& gray8, double hessian_threshold,
                  std::vector<cv::KeyPoint>& keypoints) const {
  run(gray8, hessian_threshold, keypoints, nullptr);
}

void Surf::run(const cv::Mat& gray8, double hessian_threshold, std::vector<cv::KeyPoint>& keypoints,
               cv::Mat* descriptors) const {
  keypoints.clear();
  if (descriptors != nullptr) descriptors->create(0, descriptorSize(), CV_32F);
  if (gray8.empty()) return;
  if (gray8.type() != CV_8UC1) {
    throw std::invalid_argument("Surf: expected an 8-bit single-channel image, got type " +
                                std::to_string(gray8.type()));
  }
  const IntegralImage integral(gray8);
  const int width = gray8.cols, height = gray8.rows;
  const std::ptrdiff_t stride = integral.stride();
  const uint32_t* sum = integral.data();
  const float threshold = static_cast<float>(hessian_threshold);
  const int n_layers = params_.octave_layers + 2;

  // --- Detection: det(H) over octaves and layers, 3x3x3 maxima, interpolation (Bay 2008, 3).
  std::vector<float> layers;
  for (int octave = 0; octave < params_.octaves; ++octave) {
    const int step = 1 << octave;
    const int rows = (height - 1) / step + 1, cols = (width - 1) / step + 1;
    // The largest filter of the octave bounds where a full 3x3x3 neighbourhood exists.
    int top_i0, top_i1, top_j0, top_j1;
    validRange(filterSize(octave, n_layers - 1), step, height, top_i0, top_i1);
    validRange(filterSize(octave, n_layers - 1), step, width, top_j0, top_j1);
    if (top_i1 - top_i0 < 2 || top_j1 - top_j0 < 2) break;
    const std::size_t plane = static_cast<std::size_t>(rows) * cols;
    if (layers.size() < plane * n_layers) layers.resize(plane * n_layers);

    for (int layer = 0; layer < n_layers; ++layer) {
      const int size = filterSize(octave, layer);
      const HessianFilter filter(size, stride);
      int i0, i1, j0, j1;
      validRange(size, step, height, i0, i1);
      validRange(size, step, width, j0, j1);
      float* det = layers.data() + plane * layer;
      for (int i = i0; i <= i1; ++i) {
        const uint32_t* base = sum + static_cast<std::ptrdiff_t>(i) * step * stride + j0 * step;
        float* out = det + static_cast<std::size_t>(i) * cols + j0;
        if (step == 1) {
          hessianRow(filter, base, 1, j1 - j0 + 1, out);
        } else {
          hessianRow(filter, base, step, j1 - j0 + 1, out);
        }
      }
    }

    for (int layer = 1; layer + 1 < n_layers; ++layer) {
      // The layer above is the largest filter of the triple, so its valid range bounds all.
      int i0, i1, j0, j1;
      validRange(filterSize(octave, layer + 1), step, height, i0, i1);
      validRange(filterSize(octave, layer + 1), step, width, j0, j1);
      const float* below = layers.data() + plane * (layer - 1);
      const float* here = layers.data() + plane * layer;
      const float* above = layers.data() + plane * (layer + 1);
      const int size = filterSize(octave, layer);
      const int ds = size - filterSize(octave, layer - 1);
      for (int i = i0 + 1; i <= i1 - 1; ++i) {
        for (int j = j0 + 1; j <= j1 - 1; ++j) {
          const std::size_t at = static_cast<std::size_t>(i) * cols + j;
          const float v = here[at];
          if (!(v > threshold)) continue;
          float n[3][9];
          bool is_max = true;
          const float* planes[3] = {below, here, above};
          for (int p = 0; p < 3 && is_max; ++p) {
            int k = 0;
            for (int di = -1; di <= 1; ++di) {
              const float* row = planes[p] + at + static_cast<std::ptrdiff_t>(di) * cols;
              for (int dj = -1; dj <= 1; ++dj, ++k) {
                n[p][k] = row[dj];
                if (!(p == 1 && k == 4) && !(v > n[p][k])) is_max = false;
              }
            }
          }
          if (!is_max) continue;
          cv::Vec3d offset;
          if (!interpolate(n, offset)) continue;
          const HessianFilter filter(size, stride);
          const uint32_t* centre = sum + static_cast<std::ptrdiff_t>(i) * step * stride + j * step;
          const float trace = filter.dxx(centre) + filter.dyy(centre);
          cv::KeyPoint kp;
          kp.pt.x = static_cast<float>((j + offset[0]) * step);
          kp.pt.y = static_cast<float>((i + offset[1]) * step);
          kp.size = static_cast<float>(size + offset[2] * ds);
          kp.response = v;
          kp.octave = octave;
          kp.class_id = (trace > 0.f) - (trace < 0.f);
          kp.angle = 0.f;
          if (kp.size > 0.f) keypoints.push_back(kp);
        }
      }
    }
  }

  // Strongest first, ties broken by position so the output never depends on scan order.
  std::sort(keypoints.begin(), keypoints.end(), [](const cv::KeyPoint& a, const cv::KeyPoint& b) {
    if (a.response != b.response) return a.response > b.response;
    if (a.pt.y != b.pt.y) return a.pt.y < b.pt.y;
    if (a.pt.x != b.pt.x) return a.pt.x < b.pt.x;
    return a.size < b.size;
  });
  if (params_.max_features > 0 && static_cast<int>(keypoints.size()) > params_.max_features) {
    keypoints.resize(params_.max_features);
  }

  // --- Orientation (Bay 2008, 4.1) and descriptor (4.2), per keypoint.
  const int dsize = descriptorSize();
  cv::Mat desc;
  if (descriptors != nullptr) desc.create(static_cast<int>(keypoints.size()), dsize, CV_32F);
  std::vector<float> gx(ori_offsets_.size()), gy(ori_offsets_.size()), ang(ori_offsets_.size());
  std::array<float, 360 + kOriWindowDeg> bin_x{}, bin_y{};
  std::array<float, (kPatch + 1) * (kPatch + 1)> patch{};
  std::array<float, kPatch * kPatch> pdx{}, pdy{};
  // Mean grey level of the box x box cell centred at (px, py) [px]: the integral image at the
  // sub-pixel centre (bilinear blend of the four integer placements); plain bilinear for box 1.
  const auto cellMean = [&](float px, float py, int box, float inv_box2) -> float {
    if (box <= 1) return bilinear(gray8, px, py);
    const float fx = px - (box - 1) * 0.5f, fy = py - (box - 1) * 0.5f;
    const int x = static_cast<int>(std::floor(fx)), y = static_cast<int>(std::floor(fy));
    const float ax = fx - static_cast<float>(x), ay = fy - static_cast<float>(y);
    if (x >= 0 && y >= 0 && x + box + 1 <= width && y + box + 1 <= height) {
      const uint32_t* p = sum + static_cast<std::ptrdiff_t>(y) * stride + x;
      const auto bs = [&](std::ptrdiff_t o) {
        const uint32_t* q = p + o;
        return static_cast<float>(static_cast<int32_t>(q[box * stride + box] - q[box] - q[box * stride] + q[0]));
      };
      return ((1.f - ay) * ((1.f - ax) * bs(0) + ax * bs(1)) + ay * ((1.f - ax) * bs(stride) + ax * bs(stride + 1))) *
             inv_box2;
    }
    if (box <= width && box <= height) {
      // Near the border: the box shifted inside the image (replicates the edge).
      const int cx = std::clamp(static_cast<int>(std::lround(fx)), 0, width - box);
      const int cy = std::clamp(static_cast<int>(std::lround(fy)), 0, height - box);
      return static_cast<float>(integral.boxSum(cx, cy, cx + box, cy + box)) * inv_box2;
    }
    return bilinear(gray8, px, py);
  };
  std::size_t kept = 0;
  for (std::size_t k = 0; k < keypoints.size(); ++k) {
    cv::KeyPoint kp = keypoints[k];
    const float s = 1.2f * kp.size / 9.f;
    float angle_deg = 0.f;
    if (!params_.upright) {
      // Gradients at samples s apart within radius 6 s (Bay 2008, 4.1). Bay and OpenCV take 4 s
      // Haar wavelets at rounded positions; axis-aligned boxes do not turn with the image, which
      // cost 10-20 % of the matches under rotation. Here: a grid of 3 s box means s apart at
      // sub-pixel positions, differentiated with a Scharr kernel on cells two apart (derivative
      // scale ~2 s like the wavelet, nearly isotropic): median orientation error on a 30 deg
      // rotation 1.75 deg instead of 5.6.
      constexpr int kG = kOriRadius + 2;
      constexpr int kGW = 2 * kG + 1;
      std::array<float, kGW * kGW> grid;
      const int obox = std::max(1, static_cast<int>(std::lround(3.f * s)));  // smoothing box [px]
      const float inv_obox2 = 1.f / static_cast<float>(obox * obox);
      for (int v = -kG; v <= kG; ++v)
        for (int u = -kG; u <= kG; ++u)
          grid[(v + kG) * kGW + (u + kG)] = cellMean(kp.pt.x + u * s, kp.pt.y + v * s, obox, inv_obox2);
      std::size_t n = 0;
      for (std::size_t q = 0; q < ori_offsets_.size(); ++q) {
        const float* g = grid.data() + (ori_offsets_[q].y + kG) * kGW + (ori_offsets_[q].x + kG);
        const float hx = 3.f * (g[-2 * kGW + 2] - g[-2 * kGW - 2]) + 10.f * (g[2] - g[-2]) +
                         3.f * (g[2 * kGW + 2] - g[2 * kGW - 2]);
        const float hy = 3.f * (g[2 * kGW - 2] - g[-2 * kGW - 2]) + 10.f * (g[2 * kGW] - g[-2 * kGW]) +
                         3.f * (g[2 * kGW + 2] - g[-2 * kGW + 2]);
        gx[n] = hx * ori_weights_[q];
        gy[n] = hy * ori_weights_[q];
        ang[n] = cv::fastAtan2(gy[n], gx[n]);
        ++n;
      }
      if (n == 0) continue;
      // Sliding 60 deg sector over 1 deg bins, in 1 deg steps (OpenCV: 5); the longest summed
      // vector gives the direction.
      std::fill(bin_x.begin(), bin_x.end(), 0.f);
      std::fill(bin_y.begin(), bin_y.end(), 0.f);
      for (std::size_t q = 0; q < n; ++q) {
        const int b = std::min(359, static_cast<int>(ang[q]));
        bin_x[b] += gx[q];
        bin_y[b] += gy[q];
      }
      for (int b = 0; b < kOriWindowDeg; ++b) {
        bin_x[360 + b] = bin_x[b];
        bin_y[360 + b] = bin_y[b];
      }
      float wx = 0.f, wy = 0.f;
      for (int b = 0; b < kOriWindowDeg; ++b) {
        wx += bin_x[b];
        wy += bin_y[b];
      }
      float best = -1.f, best_x = 0.f, best_y = 0.f;
      for (int start = 0; start < 360; ++start) {
        if (wx * wx + wy * wy > best) {
          best = wx * wx + wy * wy;
          best_x = wx;
          best_y = wy;
        }
        wx += bin_x[start + kOriWindowDeg] - bin_x[start];
        wy += bin_y[start + kOriWindowDeg] - bin_y[start];
      }
      angle_deg = cv::fastAtan2(best_y, best_x);
      if (angle_deg >= 360.f) angle_deg -= 360.f;
    }
    kp.angle = angle_deg;

    if (descriptors != nullptr) {
      // Resample a 21 x 21 grid s apart in the keypoint frame (u along the dominant gradient),
      // each sample the mean over an s x s cell, then 2 s Haar gradients (as OpenCV 2.x). OpenCV
      // resamples the whole rotated window, which costs (21 s)^2 per keypoint; here a cell is an
      // axis-aligned box from the integral image at the sub-pixel centre (bilinear blend of the
      // four integer placements), so the cost does not grow with scale.
      const float rad = angle_deg * static_cast<float>(CV_PI / 180.0);
      const float cs = std::cos(rad), sn = std::sin(rad);
      const int box = static_cast<int>(std::lround(s));
      const float inv_box2 = 1.f / static_cast<float>(box * box);
      for (int r = 0; r <= kPatch; ++r) {
        const float dv = (static_cast<float>(r) - kPatch / 2.f) * s;
        for (int c = 0; c <= kPatch; ++c) {
          const float du = (static_cast<float>(c) - kPatch / 2.f) * s;
          const float px = kp.pt.x + du * cs - dv * sn;
          const float py = kp.pt.y + du * sn + dv * cs;
          const float value = cellMean(px, py, box, inv_box2);
          patch[r * (kPatch + 1) + c] = value;
        }
      }
      for (int r = 0; r < kPatch; ++r) {
        const float* p0 = patch.data() + r * (kPatch + 1);
        const float* p1 = p0 + (kPatch + 1);
        for (int c = 0; c < kPatch; ++c) {
          const float w = desc_weights_[r * kPatch + c];
          pdx[r * kPatch + c] = (p0[c + 1] - p0[c] + p1[c + 1] - p1[c]) * w;
          pdy[r * kPatch + c] = (p1[c] - p0[c] + p1[c + 1] - p0[c + 1]) * w;
        }
      }
      float* vec = desc.ptr<float>(static_cast<int>(kept));
      std::fill(vec, vec + dsize, 0.f);
      float* cell = vec;
      for (int ci = 0; ci < 4; ++ci) {
        for (int cj = 0; cj < 4; ++cj) {
          for (int r = ci * 5; r < ci * 5 + 5; ++r) {
            for (int c = cj * 5; c < cj * 5 + 5; ++c) {
              const float tx = pdx[r * kPatch + c], ty = pdy[r * kPatch + c];
              if (params_.extended) {
                // Sums split by the sign of the other component (Bay 2008, 4.2, SURF-128).
                const int oy = ty >= 0.f ? 0 : 2;
                cell[oy] += tx;
                cell[oy + 1] += std::abs(tx);
                const int ox = tx >= 0.f ? 4 : 6;
                cell[ox] += ty;
                cell[ox + 1] += std::abs(ty);
              } else {
                cell[0] += tx;
                cell[1] += ty;
                cell[2] += std::abs(tx);
                cell[3] += std::abs(ty);
              }
            }
          }
          cell += params_.extended ? 8 : 4;
        }
      }
      // Unit length: invariance to contrast.
      double sq = 0.0;
      for (int q = 0; q < dsize; ++q) sq += static_cast<double>(vec[q]) * vec[q];
      const float scale = static_cast<float>(1.0 / (std::sqrt(sq) + 1e-12));
      for (int q = 0; q < dsize; ++q) vec[q] *= scale;
    }
    keypoints[kept++] = kp;
  }
  keypoints.resize(kept);
  if (descriptors != nullptr) {
    *descriptors = kept == static_cast<std::size_t>(desc.rows)
                       ? desc
                       : desc.rowRange(0, static_cast<int>(kept)).clone();
  }
}

}  // namespace seavio::features
