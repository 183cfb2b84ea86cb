#include "core/matching/patch_alignment.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include <Eigen/Dense>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace seavio::matching {

namespace {

/// Bilinear grey level of `m` at (x, y); the caller keeps (x, y) and (x + 1, y + 1) inside.
inline float bilinear(const cv::Mat& m, float x, float y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const float fx = x - static_cast<float>(x0), fy = y - static_cast<float>(y0);
  const uint8_t* r0 = m.ptr<uint8_t>(y0) + x0;
  const uint8_t* r1 = r0 + m.step[0];
  return (1 - fy) * ((1 - fx) * r0[0] + fx * r0[1]) + fy * ((1 - fx) * r1[0] + fx * r1[1]);
}

#if defined(__SSE2__)
/// bilinear() at four points at once. Each lane performs bilinear()'s operations in its order
/// (floor, the weights, then the two row blends and their blend; no fused multiply-add on
/// SSE2), so every sample has the same bits as the scalar one; four at a time because the
/// patch samples are most of patch alignment's time.
inline __m128 bilinear4(const uint8_t* data, std::size_t step, __m128 x, __m128 y) {
  // floor(): truncation, one less where that rounded up (negative non-integers).
  __m128i xi = _mm_cvttps_epi32(x), yi = _mm_cvttps_epi32(y);
  xi = _mm_add_epi32(xi, _mm_castps_si128(_mm_cmpgt_ps(_mm_cvtepi32_ps(xi), x)));
  yi = _mm_add_epi32(yi, _mm_castps_si128(_mm_cmpgt_ps(_mm_cvtepi32_ps(yi), y)));
  const __m128 fx = _mm_sub_ps(x, _mm_cvtepi32_ps(xi)), fy = _mm_sub_ps(y, _mm_cvtepi32_ps(yi));
  alignas(16) int32_t xs[4], ys[4];
  _mm_store_si128(reinterpret_cast<__m128i*>(xs), xi);
  _mm_store_si128(reinterpret_cast<__m128i*>(ys), yi);
  // Each pixel pair (x0, x0 + 1) of a row as one 16-bit word, low byte x0: words 0-3 the
  // upper rows of the four lanes, 4-7 their lower rows.
  const auto pair = [](const uint8_t* p) {
    uint16_t w;
    std::memcpy(&w, p, sizeof w);
    return static_cast<int>(w);
  };
  const uint8_t* r[4];
  for (int l = 0; l < 4; ++l)
    r[l] = data + static_cast<std::ptrdiff_t>(ys[l]) * static_cast<std::ptrdiff_t>(step) + xs[l];
  __m128i pairs = _mm_setzero_si128();
  pairs = _mm_insert_epi16(pairs, pair(r[0]), 0);
  pairs = _mm_insert_epi16(pairs, pair(r[1]), 1);
  pairs = _mm_insert_epi16(pairs, pair(r[2]), 2);
  pairs = _mm_insert_epi16(pairs, pair(r[3]), 3);
  pairs = _mm_insert_epi16(pairs, pair(r[0] + step), 4);
  pairs = _mm_insert_epi16(pairs, pair(r[1] + step), 5);
  pairs = _mm_insert_epi16(pairs, pair(r[2] + step), 6);
  pairs = _mm_insert_epi16(pairs, pair(r[3] + step), 7);
  const __m128i zero = _mm_setzero_si128(), low = _mm_set1_epi32(0xff);
  const __m128i t = _mm_unpacklo_epi16(pairs, zero), b = _mm_unpackhi_epi16(pairs, zero);
  const __m128 p00 = _mm_cvtepi32_ps(_mm_and_si128(t, low)), p01 = _mm_cvtepi32_ps(_mm_srli_epi32(t, 8));
  const __m128 p10 = _mm_cvtepi32_ps(_mm_and_si128(b, low)), p11 = _mm_cvtepi32_ps(_mm_srli_epi32(b, 8));
  const __m128 one = _mm_set1_ps(1.f);
  const __m128 wx0 = _mm_sub_ps(one, fx), wy0 = _mm_sub_ps(one, fy);
  const __m128 row0 = _mm_add_ps(_mm_mul_ps(wx0, p00), _mm_mul_ps(fx, p01));
  const __m128 row1 = _mm_add_ps(_mm_mul_ps(wx0, p10), _mm_mul_ps(fx, p11));
  return _mm_add_ps(_mm_mul_ps(wy0, row0), _mm_mul_ps(fy, row1));
}
#endif

/// The patch of `img` at `uv` warped by `A`: sample k (row r = k / side, column c = k % side,
/// offsets o_r = r - h, o_c = c - h) at (uv + A.col(1) o_r) + A.col(0) o_c, bilinear, into
/// out[0..n). `offset_c`, `offset_r` hold o_c, o_r of each k (makeOffsets). The caller keeps
/// every sample inside `img` as bilinear() requires.
void samplePatch(const cv::Mat& img, const Eigen::Vector2f& uv, const Eigen::Matrix2f& A, const float* offset_c,
                 const float* offset_r, int n, float* out) {
  int k = 0;
#if defined(__SSE2__)
  const uint8_t* data = img.ptr<uint8_t>(0);
  const std::size_t step = img.step[0];
  const __m128 ux = _mm_set1_ps(uv.x()), uy = _mm_set1_ps(uv.y());
  const __m128 a00 = _mm_set1_ps(A(0, 0)), a10 = _mm_set1_ps(A(1, 0)), a01 = _mm_set1_ps(A(0, 1)),
               a11 = _mm_set1_ps(A(1, 1));
  for (; k + 4 <= n; k += 4) {
    const __m128 oc = _mm_loadu_ps(offset_c + k), orow = _mm_loadu_ps(offset_r + k);
    const __m128 x = _mm_add_ps(_mm_add_ps(ux, _mm_mul_ps(a01, orow)), _mm_mul_ps(a00, oc));
    const __m128 y = _mm_add_ps(_mm_add_ps(uy, _mm_mul_ps(a11, orow)), _mm_mul_ps(a10, oc));
    _mm_storeu_ps(out + k, bilinear4(data, step, x, y));
  }
#endif
  for (; k < n; ++k) {
    const Eigen::Vector2f row = uv + A.col(1) * offset_r[k];
    const Eigen::Vector2f p = row + A.col(0) * offset_c[k];
    out[k] = bilinear(img, p.x(), p.y());
  }
}

/// Column and row offsets from the centre (c - h, r - h) of each sample of a (2 h + 1)^2 patch.
void makeOffsets(int h, float* offset_c, float* offset_r) {
  const int side = 2 * h + 1;
  for (int r = 0, k = 0; r < side; ++r)
    for (int c = 0; c < side; ++c, ++k) {
      offset_c[k] = static_cast<float>(c - h);
      offset_r[k] = static_cast<float>(r - h);
    }
}

/// True when every bilinear sample within `reach` px of (x, y) stays inside `m`.
bool inside(const cv::Mat& m, float x, float y, float reach) {
  return std::isfinite(x) && std::isfinite(y) && x - reach >= 0 && y - reach >= 0 &&
         x + reach < static_cast<float>(m.cols - 1) && y + reach < static_cast<float>(m.rows - 1);
}

/// Shifts `v[0..n)` to zero mean and unit variance; false (unchanged scale) when its standard
/// deviation is below `min_stddev`.
bool normalise(float* v, int n, double min_stddev, float* stddev_out = nullptr) {
  double s = 0, s2 = 0;
  for (int i = 0; i < n; ++i) {
    s += v[i];
    s2 += static_cast<double>(v[i]) * v[i];
  }
  const double mean = s / n, sd = std::sqrt(std::max(0.0, s2 / n - mean * mean));
  if (stddev_out) *stddev_out = static_cast<float>(sd);
  if (sd < min_stddev || sd <= 0) return false;
  const float m = static_cast<float>(mean), inv = static_cast<float>(1.0 / sd);
  for (int i = 0; i < n; ++i) v[i] = (v[i] - m) * inv;
  return true;
}

}  // namespace

Eigen::Matrix2f inPlaneTurn(const Eigen::Matrix3d& R_ref_curr) {
  const Eigen::Matrix3d R_curr_ref = R_ref_curr.transpose();
  const double angle = std::atan2(R_curr_ref(1, 0) - R_curr_ref(0, 1), R_curr_ref(0, 0) + R_curr_ref(1, 1));
  return Eigen::Rotation2Df(static_cast<float>(angle)).toRotationMatrix();
}

PatchTemplate makePatchTemplate(const cv::Mat& ref, const Eigen::Vector2f& ref_uv, const PatchAlignParams& params) {
  PatchTemplate t;
  const int h = std::clamp(params.half_size_px, 1, PatchTemplate::kMaxHalf);
  t.half_size_px = h;
  if (ref.empty() || ref.type() != CV_8UC1 || !inside(ref, ref_uv.x(), ref_uv.y(), static_cast<float>(h) + 1.f))
    return t;
  const int side = 2 * h + 1, n = side * side;
  // One row and column more on each side for the central-difference gradients.
  const int big = side + 2;
  constexpr int kMaxGrid = (2 * PatchTemplate::kMaxHalf + 3) * (2 * PatchTemplate::kMaxHalf + 3);
  float grid[kMaxGrid], offset_c[kMaxGrid], offset_r[kMaxGrid];
  makeOffsets(h + 1, offset_c, offset_r);
  const int grid_n = big * big;
  int i = 0;
#if defined(__SSE2__)
  const __m128 ux = _mm_set1_ps(ref_uv.x()), uy = _mm_set1_ps(ref_uv.y());
  for (; i + 4 <= grid_n; i += 4)
    _mm_storeu_ps(grid + i, bilinear4(ref.ptr<uint8_t>(0), ref.step[0], _mm_add_ps(ux, _mm_loadu_ps(offset_c + i)),
                                      _mm_add_ps(uy, _mm_loadu_ps(offset_r + i))));
#endif
  for (; i < grid_n; ++i) grid[i] = bilinear(ref, ref_uv.x() + offset_c[i], ref_uv.y() + offset_r[i]);
  for (int r = 0, k = 0; r < side; ++r)
    for (int c = 0; c < side; ++c, ++k) {
      const float* g = grid + (r + 1) * big + (c + 1);
      t.values[k] = g[0];
      t.grad_x[k] = 0.5f * (g[1] - g[-1]);
      t.grad_y[k] = 0.5f * (g[big] - g[-big]);
    }
  float sd = 0;
  if (!normalise(t.values, n, params.min_stddev_dn, &sd)) return t;
  Eigen::Matrix2d H = Eigen::Matrix2d::Zero();
  for (int k = 0; k < n; ++k) {
    t.grad_x[k] /= sd;
    t.grad_y[k] /= sd;
    const Eigen::Vector2d J(t.grad_x[k], t.grad_y[k]);
    H += J * J.transpose();
  }
  // An edge (a ripple crest without grain) fixes only one direction: not aligned.
  if (H.trace() <= 0 || H.determinant() < params.min_eigen_ratio * H.trace() * H.trace()) return t;
  t.hessian_inverse = H.inverse().cast<float>();
  t.ok = t.hessian_inverse.allFinite();
  return t;
}

PatchAlignment alignPatch(const PatchTemplate& tmpl, const cv::Mat& img, const Eigen::Vector2f& uv0,
                          const Eigen::Matrix2f& A, const PatchAlignParams& params) {
  PatchAlignment out;
  out.uv = uv0;
  if (!tmpl.ok || img.empty() || img.type() != CV_8UC1 || !A.allFinite()) return out;
  const int h = tmpl.half_size_px, side = 2 * h + 1, n = side * side;
  const float reach = static_cast<float>(h) * A.cwiseAbs().rowwise().sum().maxCoeff() +
                      static_cast<float>(params.max_shift_px) + 1.f;
  if (!inside(img, uv0.x(), uv0.y(), reach)) return out;
  float cur[PatchTemplate::kMaxSamples];
  float offset_c[PatchTemplate::kMaxSamples], offset_r[PatchTemplate::kMaxSamples];
  makeOffsets(h, offset_c, offset_r);
  const auto sample = [&](const Eigen::Vector2f& uv) {
    samplePatch(img, uv, A, offset_c, offset_r, n, cur);
    return normalise(cur, n, params.min_stddev_dn);
  };
  // Inverse compositional Gauss-Newton on the translation: the image patch at uv looks like
  // the template shifted by delta (in template pixels), so the template's centre lies at
  // uv - A delta. The normalisation's own derivative is left out (it changes slowly with a
  // sub-pixel shift), as in the usual ZNCC Lucas-Kanade.
  // With params.huber > 0 the Gauss-Newton step is iteratively reweighted: the Hessian is
  // then the weighted one, rebuilt from the template's gradients each iteration.
  const float c = static_cast<float>(params.huber);
  float residual[PatchTemplate::kMaxSamples], weight[PatchTemplate::kMaxSamples];
  Eigen::Vector2f uv = uv0;
  for (int it = 0; it < params.max_iterations; ++it) {
    if (!sample(uv)) return out;
    Eigen::Vector2f b = Eigen::Vector2f::Zero();
    Eigen::Vector2f delta;
    if (c > 0) {
      // Residuals and weights first, in a loop without a reduction, which the compiler
      // vectorises (the division is most of the weights' cost); then the sums.
      for (int k = 0; k < n; ++k) {
        residual[k] = cur[k] - tmpl.values[k];
        weight[k] = c / std::max(std::abs(residual[k]), c);
      }
      float hxx = 0, hxy = 0, hyy = 0;
      for (int k = 0; k < n; ++k) {
        const float gx = weight[k] * tmpl.grad_x[k], gy = weight[k] * tmpl.grad_y[k];
        b.x() += gx * residual[k];
        b.y() += gy * residual[k];
        hxx += gx * tmpl.grad_x[k];
        hxy += gx * tmpl.grad_y[k];
        hyy += gy * tmpl.grad_y[k];
      }
      const float det = hxx * hyy - hxy * hxy;
      if (!(det > 0)) return out;
      delta = Eigen::Vector2f(hyy * b.x() - hxy * b.y(), hxx * b.y() - hxy * b.x()) / det;
    } else {
      for (int k = 0; k < n; ++k) {
        const float res = cur[k] - tmpl.values[k];
        b.x() += tmpl.grad_x[k] * res;
        b.y() += tmpl.grad_y[k] * res;
      }
      delta = tmpl.hessian_inverse * b;
    }
    if (!delta.allFinite()) return out;
    const Eigen::Vector2f step = A * delta;
    uv -= step;
    if ((uv - uv0).norm() > params.max_shift_px) return out;
    if (step.norm() < 5e-3f) break;  // well under the 0.03 px bilinear sampling leaves
  }
  if (!sample(uv)) return out;
  double zncc = 0;
  for (int k = 0; k < n; ++k) zncc += static_cast<double>(cur[k]) * tmpl.values[k];
  out.zncc = static_cast<float>(zncc / n);
  if (out.zncc < params.min_zncc) return out;
  out.ok = true;
  out.uv = uv;
  return out;
}

PatchAlignment alignPatch(const cv::Mat& ref, const Eigen::Vector2f& ref_uv, const cv::Mat& img,
                          const Eigen::Vector2f& uv0, const Eigen::Matrix2f& A, const PatchAlignParams& params) {
  return alignPatch(makePatchTemplate(ref, ref_uv, params), img, uv0, A, params);
}

}  // namespace seavio::matching
