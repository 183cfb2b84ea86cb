#include "core/camera/remap_bilinear.hpp"

#include <algorithm>
#include <cstddef>
#include <cstring>

#include <opencv2/imgproc.hpp>

#if defined(__SSE2__)
#include <emmintrin.h>  // baseline on x86-64
#endif

namespace seavio::camera {
namespace {

constexpr int kFracBits = 5;  // cv::INTER_BITS: maps in 1/32 px
constexpr int kFrac = 1 << kFracBits;
constexpr int kFracMask = kFrac - 1;
constexpr int kTableMask = kFrac * kFrac - 1;  // OpenCV masks the fraction index with this
constexpr int kShift = 2 * kFracBits;          // weights (32 - f)(32 - g) sum to 1 << 10
constexpr int kHalf = 1 << (kShift - 1);

/// One output pixel from its 2 x 2 source neighbourhood; corners outside the image read
/// `border` (cv::remap's BORDER_CONSTANT), a neighbourhood wholly outside gives `border`.
inline uint8_t samplePixel(const uint8_t* s0, std::ptrdiff_t step, int w, int h, int sx, int sy, int f,
                           int border) {
  f &= kTableMask;
  const int fx = f & kFracMask, fy = f >> kFracBits;
  int p00, p01, p10, p11;
  if (static_cast<unsigned>(sx) < static_cast<unsigned>(w - 1) && static_cast<unsigned>(sy) < static_cast<unsigned>(h - 1)) {
    const uint8_t* p = s0 + sy * step + sx;
    p00 = p[0];
    p01 = p[1];
    p10 = p[step];
    p11 = p[step + 1];
  } else {
    if (sx >= w || sx + 1 < 0 || sy >= h || sy + 1 < 0) return static_cast<uint8_t>(border);
    const auto at = [&](int x, int y) -> int {
      return x >= 0 && x < w && y >= 0 && y < h ? s0[y * step + x] : border;
    };
    p00 = at(sx, sy);
    p01 = at(sx + 1, sy);
    p10 = at(sx, sy + 1);
    p11 = at(sx + 1, sy + 1);
  }
  const int top = p00 * (kFrac - fx) + p01 * fx;
  const int bottom = p10 * (kFrac - fx) + p11 * fx;
  return static_cast<uint8_t>((top * (kFrac - fy) + bottom * fy + kHalf) >> kShift);
}

#if defined(__SSE2__)
inline int load16(const uint8_t* p) {
  uint16_t v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

/// Lane I of `top` / `bottom`: the source pixel pair (x, x + 1) of output pixel I in its row
/// and in the row below (pinsrw needs the lane as a constant).
template <int I>
inline void gatherPair(const uint8_t* s0, std::ptrdiff_t step, const int16_t* xy, __m128i& top, __m128i& bottom) {
  const uint8_t* p = s0 + xy[2 * I + 1] * step + xy[2 * I];
  top = _mm_insert_epi16(top, load16(p), I);
  bottom = _mm_insert_epi16(bottom, load16(p + step), I);
}

/// Eight output pixels whose neighbourhoods all lie inside the image. Gathering is scalar
/// (pinsrw); the weighting is the scalar formula in 16-bit lanes: horizontal sums (at most
/// 255 * 32) by pmaddwd against (32 - fx, fx), then the vertical pair the same way, so no
/// intermediate is rounded and the bytes equal samplePixel's.
inline void eightInside(const uint8_t* s0, std::ptrdiff_t step, const int16_t* xy, const uint16_t* frac,
                        uint8_t* out) {
  __m128i top = _mm_setzero_si128(), bottom = _mm_setzero_si128();
  gatherPair<0>(s0, step, xy, top, bottom);
  gatherPair<1>(s0, step, xy, top, bottom);
  gatherPair<2>(s0, step, xy, top, bottom);
  gatherPair<3>(s0, step, xy, top, bottom);
  gatherPair<4>(s0, step, xy, top, bottom);
  gatherPair<5>(s0, step, xy, top, bottom);
  gatherPair<6>(s0, step, xy, top, bottom);
  gatherPair<7>(s0, step, xy, top, bottom);
  const __m128i zero = _mm_setzero_si128(), full = _mm_set1_epi16(kFrac);
  const __m128i f = _mm_and_si128(_mm_loadu_si128(reinterpret_cast<const __m128i*>(frac)), _mm_set1_epi16(kTableMask));
  const __m128i fx = _mm_and_si128(f, _mm_set1_epi16(kFracMask));
  const __m128i fy = _mm_srli_epi16(f, kFracBits);
  const __m128i fx1 = _mm_sub_epi16(full, fx), fy1 = _mm_sub_epi16(full, fy);
  const __m128i wx_lo = _mm_unpacklo_epi16(fx1, fx), wx_hi = _mm_unpackhi_epi16(fx1, fx);
  const __m128i top_h = _mm_packs_epi32(_mm_madd_epi16(_mm_unpacklo_epi8(top, zero), wx_lo),
                                        _mm_madd_epi16(_mm_unpackhi_epi8(top, zero), wx_hi));
  const __m128i bottom_h = _mm_packs_epi32(_mm_madd_epi16(_mm_unpacklo_epi8(bottom, zero), wx_lo),
                                           _mm_madd_epi16(_mm_unpackhi_epi8(bottom, zero), wx_hi));
  const __m128i half = _mm_set1_epi32(kHalf);
  const __m128i v_lo = _mm_srai_epi32(
      _mm_add_epi32(_mm_madd_epi16(_mm_unpacklo_epi16(top_h, bottom_h), _mm_unpacklo_epi16(fy1, fy)), half), kShift);
  const __m128i v_hi = _mm_srai_epi32(
      _mm_add_epi32(_mm_madd_epi16(_mm_unpackhi_epi16(top_h, bottom_h), _mm_unpackhi_epi16(fy1, fy)), half), kShift);
  const __m128i v = _mm_packs_epi32(v_lo, v_hi);
  _mm_storel_epi64(reinterpret_cast<__m128i*>(out), _mm_packus_epi16(v, v));
}
#endif

}  // namespace

void remapBilinear(const cv::Mat& src, cv::Mat& dst, const cv::Mat& xy, const cv::Mat& frac, uint8_t border) {
  CV_Assert(xy.type() == CV_16SC2 && frac.type() == CV_16UC1 && xy.size() == frac.size());
  if (src.type() != CV_8UC1 || src.empty() || (!dst.empty() && dst.datastart == src.datastart)) {
    cv::remap(src, dst, xy, frac, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(border));
    return;
  }
  dst.create(xy.size(), CV_8UC1);
  const int w = src.cols, h = src.rows;
  const std::ptrdiff_t step = static_cast<std::ptrdiff_t>(src.step[0]);
  const uint8_t* s0 = src.ptr<uint8_t>();
#if defined(__SSE2__)
  // Lanes alternate x, y: a neighbourhood is inside when 0 <= x < w - 1 and 0 <= y < h - 1.
  const __m128i limit = _mm_set_epi16(static_cast<int16_t>(std::min(h - 1, 32767)), static_cast<int16_t>(std::min(w - 1, 32767)),
                                      static_cast<int16_t>(std::min(h - 1, 32767)), static_cast<int16_t>(std::min(w - 1, 32767)),
                                      static_cast<int16_t>(std::min(h - 1, 32767)), static_cast<int16_t>(std::min(w - 1, 32767)),
                                      static_cast<int16_t>(std::min(h - 1, 32767)), static_cast<int16_t>(std::min(w - 1, 32767)));
  const __m128i minus_one = _mm_set1_epi16(-1);
#endif
  for (int y = 0; y < dst.rows; ++y) {
    const int16_t* m = xy.ptr<int16_t>(y);
    const uint16_t* f = frac.ptr<uint16_t>(y);
    uint8_t* d = dst.ptr<uint8_t>(y);
    int x = 0;
#if defined(__SSE2__)
    for (; x + 8 <= dst.cols; x += 8) {
      const __m128i a = _mm_loadu_si128(reinterpret_cast<const __m128i*>(m + 2 * x));
      const __m128i b = _mm_loadu_si128(reinterpret_cast<const __m128i*>(m + 2 * x + 8));
      const __m128i inside = _mm_and_si128(
          _mm_and_si128(_mm_cmpgt_epi16(a, minus_one), _mm_cmplt_epi16(a, limit)),
          _mm_and_si128(_mm_cmpgt_epi16(b, minus_one), _mm_cmplt_epi16(b, limit)));
      if (_mm_movemask_epi8(inside) == 0xFFFF) {
        eightInside(s0, step, m + 2 * x, f + x, d + x);
      } else {
        for (int k = x; k < x + 8; ++k) d[k] = samplePixel(s0, step, w, h, m[2 * k], m[2 * k + 1], f[k], border);
      }
    }
#endif
    for (; x < dst.cols; ++x) d[x] = samplePixel(s0, step, w, h, m[2 * x], m[2 * x + 1], f[x], border);
  }
}

}  // namespace seavio::camera
