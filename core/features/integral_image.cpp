#include "core/features/integral_image.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#if defined(__SSE2__)
#include <emmintrin.h>  // baseline on x86-64: no -march flag needed
#endif

namespace seavio::features {

bool IntegralImage::compute(const cv::Mat& gray8) {
  // Another type leaves the table of an empty image (one zero row), so boxSum stays defined.
  const bool ok = gray8.empty() || gray8.type() == CV_8UC1;
  width_ = ok ? gray8.cols : 0;
  height_ = ok ? gray8.rows : 0;
  const std::size_t stride = static_cast<std::size_t>(width_) + 1;
  const std::size_t entries = stride * (static_cast<std::size_t>(height_) + 1);
  if (entries > capacity_) {
    table_.reset(new uint32_t[entries]);
    capacity_ = entries;
  }
  std::fill(table_.get(), table_.get() + stride, 0u);  // row 0
  for (int y = 0; y < height_; ++y) {
    const uint8_t* src = gray8.ptr<uint8_t>(y);
    const uint32_t* above = table_.get() + static_cast<std::size_t>(y) * stride;
    uint32_t* row = table_.get() + static_cast<std::size_t>(y + 1) * stride;
    row[0] = 0u;  // column 0
    uint32_t run = 0;
    int x = 0;
#if defined(__SSE2__)
    // Sixteen pixels per step: prefix sums of the bytes in 16-bit lanes (at most 8 x 255 per
    // half), widened to 32 bits, plus the running row sum and the row above. Integer sums
    // modulo 2^32 like the scalar loop: identical table.
    const __m128i zero = _mm_setzero_si128();
    __m128i carry = _mm_setzero_si128();  // run, in every lane
    for (; x + 16 <= width_; x += 16) {
      const __m128i v = _mm_loadu_si128(reinterpret_cast<const __m128i*>(src + x));
      __m128i lo = _mm_unpacklo_epi8(v, zero), hi = _mm_unpacklo_epi8(_mm_srli_si128(v, 8), zero);
      lo = _mm_add_epi16(lo, _mm_slli_si128(lo, 2));
      hi = _mm_add_epi16(hi, _mm_slli_si128(hi, 2));
      lo = _mm_add_epi16(lo, _mm_slli_si128(lo, 4));
      hi = _mm_add_epi16(hi, _mm_slli_si128(hi, 4));
      lo = _mm_add_epi16(lo, _mm_slli_si128(lo, 8));
      hi = _mm_add_epi16(hi, _mm_slli_si128(hi, 8));
      const __m128i s0 = _mm_add_epi32(_mm_unpacklo_epi16(lo, zero), carry);
      const __m128i s1 = _mm_add_epi32(_mm_unpackhi_epi16(lo, zero), carry);
      const __m128i mid = _mm_shuffle_epi32(s1, 0xFF);
      const __m128i s2 = _mm_add_epi32(_mm_unpacklo_epi16(hi, zero), mid);
      const __m128i s3 = _mm_add_epi32(_mm_unpackhi_epi16(hi, zero), mid);
      carry = _mm_shuffle_epi32(s3, 0xFF);
      const __m128i* a = reinterpret_cast<const __m128i*>(above + x + 1);
      __m128i* o = reinterpret_cast<__m128i*>(row + x + 1);
      _mm_storeu_si128(o, _mm_add_epi32(s0, _mm_loadu_si128(a)));
      _mm_storeu_si128(o + 1, _mm_add_epi32(s1, _mm_loadu_si128(a + 1)));
      _mm_storeu_si128(o + 2, _mm_add_epi32(s2, _mm_loadu_si128(a + 2)));
      _mm_storeu_si128(o + 3, _mm_add_epi32(s3, _mm_loadu_si128(a + 3)));
    }
    run = static_cast<uint32_t>(_mm_cvtsi128_si32(carry));
#endif
    for (; x < width_; ++x) {
      run += src[x];
      row[x + 1] = above[x + 1] + run;
    }
  }
  return ok;
}

uint32_t IntegralImage::boxSum(int x0, int y0, int x1, int y1) const {
  x0 = std::clamp(x0, 0, width_);
  x1 = std::clamp(x1, 0, width_);
  y0 = std::clamp(y0, 0, height_);
  y1 = std::clamp(y1, 0, height_);
  if (x1 <= x0 || y1 <= y0) return 0u;
  return at(x1, y1) - at(x0, y1) - at(x1, y0) + at(x0, y0);
}

}  // namespace seavio::features
