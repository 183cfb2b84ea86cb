#include "core/features/surf.hpp"

#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <stdexcept>

#include "core/features/integral_image.hpp"
#include "core/features/mat_rows.hpp"

#if defined(__SSE2__)
#include <emmintrin.h>  // baseline on x86-64: no -march flag needed
#endif

// AVX2 kernels beside the baseline ones, chosen at run time (GCC and Clang on x86-64).
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define SEAVIO_SURF_AVX2 1
#else
#define SEAVIO_SURF_AVX2 0
#endif

namespace seavio::features {
namespace {

constexpr int kOriRadius = 6;          // orientation samples within 6 s (Bay 2008, 4.1)
constexpr float kOriSigma = 2.5f;      // OpenCV's weight; Bay states 2 s
constexpr int kOriWindowDeg = 60;      // sliding sector
constexpr int kPatch = 20;             // 20 s descriptor window, 4 x 4 sub-regions of 5 x 5
constexpr float kDescSigma = 3.3f;     // Gaussian over the window, in sample spacings
constexpr float kDxyWeight = 0.9f;     // balances the box approximation (Bay 2008, eq. 4)
/// Orientation samples: integer offsets within radius kOriRadius (113).
constexpr int kOriSamples = [] {
  int n = 0;
  for (int v = -kOriRadius; v <= kOriRadius; ++v)
    for (int u = -kOriRadius; u <= kOriRadius; ++u) n += u * u + v * v <= kOriRadius * kOriRadius;
  return n;
}();

/// The orientation's grid of cell means reaches 2 cells beyond the disc (the Scharr stencil on
/// cells two apart): kOriGrid cells either side of the keypoint.
constexpr int kOriGrid = kOriRadius + 2;
/// Per grid row v = -kOriGrid..kOriGrid, the cells the stencil reads (first u, count): disc
/// rows v and v +- 2, widened by 2. 225 of the 17 x 17 cells; the corners are never read.
constexpr auto kOriGridRows = [] {
  std::array<std::array<int, 2>, 2 * kOriGrid + 1> rows{};
  for (int v = -kOriGrid; v <= kOriGrid; ++v) {
    int lo = kOriGrid + 1, hi = -kOriGrid - 1;
    for (int b = -2; b <= 2; b += 2) {
      const int dv = v - b;
      if (dv < -kOriRadius || dv > kOriRadius) continue;
      int w = 0;  // disc row dv spans u = -w..w
      while ((w + 1) * (w + 1) + dv * dv <= kOriRadius * kOriRadius) ++w;
      lo = std::min(lo, -w - 2);
      hi = std::max(hi, w + 2);
    }
    rows[v + kOriGrid] = {lo, hi >= lo ? hi - lo + 1 : 0};
  }
  return rows;
}();
constexpr int kOriGridCells = [] {
  int n = 0;
  for (const auto& r : kOriGridRows) n += r[1];
  return n;
}();

/// A box sum S(a) - S(b) - S(c) + S(d) expressed as offsets from S(x, y) of the filter
/// centre; unsigned arithmetic so a wrapped table still gives the exact sum.
struct Box {
  std::ptrdiff_t a = 0, b = 0, c = 0, d = 0;
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
  int size = 0;             // filter side [px]
  float inv_lobe_area = 0;  // 1 / (l (2l - 1)): normalise by filter area (scale invariance)
  float inv_xy_area = 0;    // 1 / l^2

  HessianFilter() = default;
  HessianFilter(int side, std::ptrdiff_t stride) : size(side) {
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

#if defined(__GNUC__)
#define SEAVIO_SURF_INLINE inline __attribute__((always_inline))
#define SEAVIO_SURF_NOINLINE __attribute__((noinline))
#define SEAVIO_SURF_LAMBDA_INLINE __attribute__((always_inline))
#else
#define SEAVIO_SURF_INLINE inline
#define SEAVIO_SURF_NOINLINE
#define SEAVIO_SURF_LAMBDA_INLINE
#endif

/// det(H) = Dxx Dyy - (0.9 Dxy)^2 (Bay 2008, eq. 4) from the eight box sums of one filter
/// centre (xx: whole and middle box; yy: the same; xy: top-left, top-right, bottom-left,
/// bottom-right lobes), each exact modulo 2^32, normalised by `wl` = 1 / lobe area and `wxy` =
/// 0.9 / xy lobe area. The one formula of every kernel below and of hessianAt, so responses
/// from any of them are bit-identical.
SEAVIO_SURF_INLINE float hessianResponse(uint32_t xx_all, uint32_t xx_mid, uint32_t yy_all, uint32_t yy_mid,
                                         uint32_t tl, uint32_t tr, uint32_t bl, uint32_t br, float wl, float wxy) {
  const int32_t xx = static_cast<int32_t>(xx_all - 3u * xx_mid);
  const int32_t yy = static_cast<int32_t>(yy_all - 3u * yy_mid);
  const int32_t xy = static_cast<int32_t>(tl + br - tr - bl);
  const float dxx = static_cast<float>(xx) * wl, dyy = static_cast<float>(yy) * wl;
  const float dxy = static_cast<float>(xy) * wxy;
  return dxx * dyy - dxy * dxy;
}

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
    out[j] = hessianResponse(p[xa0] - p[xa1] - p[xa2] + p[xa3], p[xm0] - p[xm1] - p[xm2] + p[xm3],
                             p[ya0] - p[ya1] - p[ya2] + p[ya3], p[ym0] - p[ym1] - p[ym2] + p[ym3],
                             p[t0] - p[t1] - p[t2] + p[t3], p[r0] - p[r1] - p[r2] + p[r3],
                             p[l0] - p[l1] - p[l2] + p[l3], p[b0] - p[b1] - p[b2] + p[b3], wl, wxy);
  }
}

/// hessianRow for a lobe length L known at compile time: the box corners lie on ten table
/// rows, so ten row pointers plus constant column offsets replace 32 runtime offsets (which
/// do not fit in registers). Serves octaves 2 and up (step 1 takes hessianLayerUnit, step 2
/// hessianRowStep2). Same integer arithmetic (exact modulo 2^32) and float operations as
/// hessianRow: bit-identical.
template <int L, bool kUnitStep>
SEAVIO_SURF_INLINE void hessianRowFixed(const HessianFilter& f, const uint32_t* base, std::ptrdiff_t stride,
                     std::ptrdiff_t step_arg, int n, float* out) {
  constexpr int H = (3 * L - 1) / 2, M = (L - 1) / 2;
  const std::ptrdiff_t step = kUnitStep ? 1 : step_arg;
  const uint32_t* xr0 = base - (L - 1) * stride;  // xx rows
  const uint32_t* xr1 = base + L * stride;
  const uint32_t* ya0 = base - H * stride;        // yy, outer box rows
  const uint32_t* ya1 = base + (H + 1) * stride;
  const uint32_t* ym0 = base - M * stride;        // yy, middle box rows
  const uint32_t* ym1 = base + (M + 1) * stride;
  const uint32_t* q0 = base - L * stride;         // xy rows
  const uint32_t* q1 = base;
  const uint32_t* q2 = base + stride;
  const uint32_t* q3 = base + (L + 1) * stride;
  const float wl = f.inv_lobe_area, wxy = f.inv_xy_area * kDxyWeight;
  for (int j = 0; j < n; ++j) {
    const std::ptrdiff_t c = j * step;
    const uint32_t xx_all = xr1[c + H + 1] - xr0[c + H + 1] - xr1[c - H] + xr0[c - H];
    const uint32_t xx_mid = xr1[c + M + 1] - xr0[c + M + 1] - xr1[c - M] + xr0[c - M];
    const uint32_t yy_all = ya1[c + L] - ya0[c + L] - ya1[c - (L - 1)] + ya0[c - (L - 1)];
    const uint32_t yy_mid = ym1[c + L] - ym0[c + L] - ym1[c - (L - 1)] + ym0[c - (L - 1)];
    const uint32_t tl = q1[c] - q0[c] - q1[c - L] + q0[c - L];
    const uint32_t tr = q1[c + L + 1] - q0[c + L + 1] - q1[c + 1] + q0[c + 1];
    const uint32_t bl = q3[c] - q2[c] - q3[c - L] + q2[c - L];
    const uint32_t br = q3[c + L + 1] - q2[c + L + 1] - q3[c + 1] + q2[c + 1];
    out[j] = hessianResponse(xx_all, xx_mid, yy_all, yy_mid, tl, tr, bl, br, wl, wxy);
  }
}

/// hessianRowFixed at unit step with the row differences factored out: every box of a
/// filter spans one of five row pairs (xx; yy outer; yy middle; xy upper; xy lower), so the
/// difference of each pair is formed once per column and every box sum becomes two reads of
/// it instead of four of the table (16 reads per response instead of 32). The same sums
/// modulo 2^32 in a different association: bit-identical output.
/// Unit steps only: at coarser steps forming the differences at every column costs more than
/// the reads it saves. The xx and yy-outer differences are formed here in `scratch` (2 (n +
/// 3 L) entries); the three L-row differences (yy middle, xy upper, xy lower) are the same
/// vertical L-row sums at rows i - M, i - L and i + 1, so hessianLayerUnit forms each once
/// and passes it to three output rows (`fm`, `d1`, `d2`, at the first output column).
template <int L>
SEAVIO_SURF_INLINE void hessianRowUnit(const HessianFilter& f, const uint32_t* base, std::ptrdiff_t stride, int n, float* out,
                    uint32_t* scratch, const uint32_t* fm, const uint32_t* d1, const uint32_t* d2) {
  constexpr int H = (3 * L - 1) / 2, M = (L - 1) / 2;
  const std::ptrdiff_t span = n + 2 * H + 1;  // columns -H .. n + H
  uint32_t* e = scratch + H;       // xx rows
  uint32_t* fo = e + span;         // yy outer rows
  {
    const uint32_t* xr0 = base - (L - 1) * stride - H;
    const uint32_t* xr1 = base + L * stride - H;
    const uint32_t* ya0 = base - H * stride - H;
    const uint32_t* ya1 = base + (H + 1) * stride - H;
    uint32_t* e0 = e - H;
    uint32_t* fo0 = fo - H;
    for (std::ptrdiff_t k = 0; k < span; ++k) e0[k] = xr1[k] - xr0[k];
    for (std::ptrdiff_t k = 0; k < span; ++k) fo0[k] = ya1[k] - ya0[k];
  }
  const float wl = f.inv_lobe_area, wxy = f.inv_xy_area * kDxyWeight;
  for (int c = 0; c < n; ++c) {
    const uint32_t xx_all = e[c + H + 1] - e[c - H];
    const uint32_t xx_mid = e[c + M + 1] - e[c - M];
    const uint32_t yy_all = fo[c + L] - fo[c - (L - 1)];
    const uint32_t yy_mid = fm[c + L] - fm[c - (L - 1)];
    const uint32_t tl = d1[c] - d1[c - L];
    const uint32_t tr = d1[c + L + 1] - d1[c + 1];
    const uint32_t bl = d2[c] - d2[c - L];
    const uint32_t br = d2[c + L + 1] - d2[c + 1];
    out[c] = hessianResponse(xx_all, xx_mid, yy_all, yy_mid, tl, tr, bl, br, wl, wxy);
  }
}

/// hessianRowUnit over output rows i0..i1 (columns j0 .. j0 + n - 1) of `det` (row pitch
/// `cols`): the vertical L-row sums V(r) = S(r + L) - S(r) of the table go through a ring of
/// L + 2 rows, each formed once and read by the rows i = r + M (yy middle), r + L (xy upper)
/// and r - 1 (xy lower). `scratch` holds (L + 4) (n + 3 L) entries.
template <int L>
SEAVIO_SURF_INLINE void hessianLayerUnit(const HessianFilter& f, const uint32_t* sum, std::ptrdiff_t stride, int i0, int i1, int j0,
                      int n, float* det, std::ptrdiff_t cols, uint32_t* scratch) {
  constexpr int H = (3 * L - 1) / 2, M = (L - 1) / 2, kRing = L + 2;
  const std::ptrdiff_t span = n + 2 * H + 1;
  uint32_t* ring = scratch + 2 * span;
  std::array<int, kRing> ring_row;
  ring_row.fill(-1);
  const auto vrow = [&](int r) SEAVIO_SURF_LAMBDA_INLINE -> const uint32_t* {  // r >= i0 - L >= 0
    const int slot = r % kRing;
    uint32_t* v = ring + slot * span;
    if (ring_row[slot] != r) {
      const uint32_t* a = sum + static_cast<std::ptrdiff_t>(r) * stride + j0 - H;
      const uint32_t* b = a + L * stride;
      for (std::ptrdiff_t k = 0; k < span; ++k) v[k] = b[k] - a[k];
      ring_row[slot] = r;
    }
    return v + H;
  };
  for (int i = i0; i <= i1; ++i) {
    const uint32_t* base = sum + static_cast<std::ptrdiff_t>(i) * stride + j0;
    const uint32_t* fm = vrow(i - M);
    const uint32_t* d1 = vrow(i - L);
    const uint32_t* d2 = vrow(i + 1);
    hessianRowUnit<L>(f, base, stride, n, det + static_cast<std::ptrdiff_t>(i) * cols + j0, scratch, fm, d1, d2);
  }
}

/// Table row difference b - a over the 2 k columns starting at `a`/`b`, split by column parity:
/// even[q] = b[2 q] - a[2 q], odd[q] = b[2 q + 1] - a[2 q + 1], q < k.
SEAVIO_SURF_INLINE void rowDifferenceSplit(const uint32_t* a, const uint32_t* b, std::ptrdiff_t k, uint32_t* even,
                               uint32_t* odd) {
  std::ptrdiff_t q = 0;
#if defined(__SSE2__)
  for (; q + 4 <= k; q += 4) {
    const __m128i lo = _mm_sub_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(b + 2 * q)),
                                     _mm_loadu_si128(reinterpret_cast<const __m128i*>(a + 2 * q)));
    const __m128i hi = _mm_sub_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(b + 2 * q + 4)),
                                     _mm_loadu_si128(reinterpret_cast<const __m128i*>(a + 2 * q + 4)));
    const __m128 l = _mm_castsi128_ps(lo), h = _mm_castsi128_ps(hi);
    _mm_storeu_ps(reinterpret_cast<float*>(even + q), _mm_shuffle_ps(l, h, _MM_SHUFFLE(2, 0, 2, 0)));
    _mm_storeu_ps(reinterpret_cast<float*>(odd + q), _mm_shuffle_ps(l, h, _MM_SHUFFLE(3, 1, 3, 1)));
  }
#endif
  for (; q < k; ++q) {
    even[q] = b[2 * q] - a[2 * q];
    odd[q] = b[2 * q + 1] - a[2 * q + 1];
  }
}

/// Entry at column offset O (relative to the filter centre, >= -H) of a row difference split
/// by hessianRowStep2, for output j.
template <int O, int H>
SEAVIO_SURF_INLINE uint32_t splitAt(const uint32_t* even, const uint32_t* odd, int j) {
  constexpr int d = O + H;
  static_assert(d >= 0, "offset inside the split row");
  if constexpr (d % 2 == 0) {
    return even[j + d / 2];
  } else {
    return odd[j + d / 2];
  }
}

/// hessianRowUnit for the step-2 octave: the five row differences are formed at every column
/// once (SSE2, 1.25 instructions per entry) and split by column parity, so each of the 16
/// reads per response becomes a unit-stride read the compiler vectorises, instead of 32
/// strided table reads. Same sums modulo 2^32: bit-identical. `scratch` holds 10 (n + H).
template <int L>
SEAVIO_SURF_INLINE void hessianRowStep2(const HessianFilter& f, const uint32_t* base, std::ptrdiff_t stride, int n, float* out,
                     uint32_t* scratch) {
  constexpr int H = (3 * L - 1) / 2, M = (L - 1) / 2;
  const std::ptrdiff_t k = n + H;  // column pairs from -H to 2 (n - 1) + H + 1
  uint32_t* split[10];
  for (int a = 0; a < 10; ++a) split[a] = scratch + a * k;
  const uint32_t* b0 = base - H;
  rowDifferenceSplit(b0 - (L - 1) * stride, b0 + L * stride, k, split[0], split[1]);  // xx
  rowDifferenceSplit(b0 - H * stride, b0 + (H + 1) * stride, k, split[2], split[3]);  // yy outer
  rowDifferenceSplit(b0 - M * stride, b0 + (M + 1) * stride, k, split[4], split[5]);  // yy middle
  rowDifferenceSplit(b0 - L * stride, b0, k, split[6], split[7]);                      // xy upper
  rowDifferenceSplit(b0 + stride, b0 + (L + 1) * stride, k, split[8], split[9]);       // xy lower
  const uint32_t *ee = split[0], *eo = split[1], *foe = split[2], *foo = split[3], *fme = split[4],
                 *fmo = split[5], *d1e = split[6], *d1o = split[7], *d2e = split[8], *d2o = split[9];
  const float wl = f.inv_lobe_area, wxy = f.inv_xy_area * kDxyWeight;
  for (int j = 0; j < n; ++j) {
    const uint32_t xx_all = splitAt<H + 1, H>(ee, eo, j) - splitAt<-H, H>(ee, eo, j);
    const uint32_t xx_mid = splitAt<M + 1, H>(ee, eo, j) - splitAt<-M, H>(ee, eo, j);
    const uint32_t yy_all = splitAt<L, H>(foe, foo, j) - splitAt<-(L - 1), H>(foe, foo, j);
    const uint32_t yy_mid = splitAt<L, H>(fme, fmo, j) - splitAt<-(L - 1), H>(fme, fmo, j);
    const uint32_t tl = splitAt<0, H>(d1e, d1o, j) - splitAt<-L, H>(d1e, d1o, j);
    const uint32_t tr = splitAt<L + 1, H>(d1e, d1o, j) - splitAt<1, H>(d1e, d1o, j);
    const uint32_t bl = splitAt<0, H>(d2e, d2o, j) - splitAt<-L, H>(d2e, d2o, j);
    const uint32_t br = splitAt<L + 1, H>(d2e, d2o, j) - splitAt<1, H>(d2e, d2o, j);
    out[j] = hessianResponse(xx_all, xx_mid, yy_all, yy_mid, tl, tr, bl, br, wl, wxy);
  }
}

/// det(H) over grid rows i0..i1 and columns j0..j1 of one layer (`det`, row pitch `cols`)
/// with the kernel for the filter's lobe (hessianLayerUnit at step 1, hessianRowStep2 at step
/// 2, hessianRowFixed above); false if the lobe has no fixed kernel. Every kernel is inlined
/// here, so each entry point below compiles the whole set for its instruction set.
SEAVIO_SURF_INLINE bool hessianLayerFixed(const HessianFilter& f, const uint32_t* sum, std::ptrdiff_t stride,
                                          int step, int i0, int i1, int j0, int n, float* det, std::ptrdiff_t cols,
                                          uint32_t* scratch) {
#define SEAVIO_SURF_FIXED(LOBE)                                                                                    \
  case LOBE:                                                                                                       \
    if (step == 1) {                                                                                               \
      hessianLayerUnit<LOBE>(f, sum, stride, i0, i1, j0, n, det, cols, scratch);                                   \
    } else {                                                                                                       \
      for (int i = i0; i <= i1; ++i) {                                                                             \
        const uint32_t* base =                                                                                     \
            sum + static_cast<std::ptrdiff_t>(i) * step * stride + static_cast<std::ptrdiff_t>(j0) * step;         \
        float* out = det + static_cast<std::ptrdiff_t>(i) * cols + j0;                                             \
        if (step == 2) {                                                                                           \
          hessianRowStep2<LOBE>(f, base, stride, n, out, scratch);                                                 \
        } else {                                                                                                   \
          hessianRowFixed<LOBE, false>(f, base, stride, step, n, out);                                             \
        }                                                                                                          \
      }                                                                                                            \
    }                                                                                                              \
    return true;
  // Lobes of the middle layers (the ones computed in full) of octaves 0-3, two layers each.
  switch (f.size / 3) {
    SEAVIO_SURF_FIXED(5)
    SEAVIO_SURF_FIXED(7)
    SEAVIO_SURF_FIXED(9)
    SEAVIO_SURF_FIXED(13)
    SEAVIO_SURF_FIXED(17)
    SEAVIO_SURF_FIXED(25)
    SEAVIO_SURF_FIXED(33)
    SEAVIO_SURF_FIXED(49)
    default: return false;
  }
#undef SEAVIO_SURF_FIXED
}

/// hessianLayerFixed for the baseline instruction set (SSE2 on x86-64).
SEAVIO_SURF_NOINLINE bool hessianLayerBaseline(const HessianFilter& f, const uint32_t* sum, std::ptrdiff_t stride,
                                               int step, int i0, int i1, int j0, int n, float* det,
                                               std::ptrdiff_t cols, uint32_t* scratch) {
  return hessianLayerFixed(f, sum, stride, step, i0, i1, j0, n, det, cols, scratch);
}

#if SEAVIO_SURF_AVX2
/// hessianLayerFixed compiled for AVX2 (eight responses per vector step instead of four),
/// called only when the CPU has AVX2 (Surf::Surf). AVX2 without FMA: the compiler cannot
/// contract a multiply and a subtraction, so every lane performs the baseline's integer and
/// float operations in the same order and the responses are bit-identical (SurfAvx2.*).
__attribute__((target("avx2"))) SEAVIO_SURF_NOINLINE bool hessianLayerAvx2(
    const HessianFilter& f, const uint32_t* sum, std::ptrdiff_t stride, int step, int i0, int i1, int j0, int n,
    float* det, std::ptrdiff_t cols, uint32_t* scratch) {
  return hessianLayerFixed(f, sum, stride, step, i0, i1, j0, n, det, cols, scratch);
}
#endif

/// det(H) over grid rows i0..i1 and columns j0..j1 of one layer (`det`, row pitch `cols`)
/// with the fastest kernel for the filter: hessianLayerFixed (AVX2 when `avx2`), else the
/// generic hessianRow.
void hessianLayer(const HessianFilter& f, const uint32_t* sum, std::ptrdiff_t stride, int step, int i0, int i1,
                  int j0, int j1, float* det, std::ptrdiff_t cols, uint32_t* scratch, bool avx2) {
  const int n = j1 - j0 + 1;
#if SEAVIO_SURF_AVX2
  if (avx2 ? hessianLayerAvx2(f, sum, stride, step, i0, i1, j0, n, det, cols, scratch)
           : hessianLayerBaseline(f, sum, stride, step, i0, i1, j0, n, det, cols, scratch)) {
    return;
  }
#else
  (void)avx2;
  if (hessianLayerBaseline(f, sum, stride, step, i0, i1, j0, n, det, cols, scratch)) return;
#endif
  for (int i = i0; i <= i1; ++i) {
    const uint32_t* base =
        sum + static_cast<std::ptrdiff_t>(i) * step * stride + static_cast<std::ptrdiff_t>(j0) * step;
    hessianRow(f, base, step, n, det + static_cast<std::ptrdiff_t>(i) * cols + j0);
  }
}

/// det(H) at one filter centre `p`: the arithmetic of hessianRow, so a response computed
/// on demand is bit-identical to one from a full layer.
inline float hessianAt(const HessianFilter& f, const uint32_t* p) {
  const auto box = [p](const Box& b) { return p[b.a] - p[b.b] - p[b.c] + p[b.d]; };
  return hessianResponse(box(f.xx_all), box(f.xx_mid), box(f.yy_all), box(f.yy_mid), box(f.xy_tl), box(f.xy_tr),
                         box(f.xy_bl), box(f.xy_br), f.inv_lobe_area, f.inv_xy_area * kDxyWeight);
}

/// Mean grey level of the box x box cell whose top-left corner is at the sub-pixel position
/// (fx, fy) = (x + ax, y + ay): bilinear blend of the four integer placements, each an exact
/// integer box sum. Requires x, y >= 0, x + box + 1 <= width, y + box + 1 <= height.
SEAVIO_SURF_INLINE float boxMeanInside(const uint32_t* sum, std::ptrdiff_t stride, int x, int y, float ax,
                                       float ay, int box, float inv_box2) {
  const uint32_t* p = sum + static_cast<std::ptrdiff_t>(y) * stride + x;
  const std::ptrdiff_t down = box * stride;
  const auto bs = [&](std::ptrdiff_t o) {
    const uint32_t* q = p + o;
    return static_cast<float>(static_cast<int32_t>(q[down + box] - q[box] - q[down] + q[0]));
  };
  return ((1.f - ay) * ((1.f - ax) * bs(0) + ax * bs(1)) + ay * ((1.f - ax) * bs(stride) + ax * bs(stride + 1))) *
         inv_box2;
}

/// floor() as an int without the libm call (x86-64 has no inline floor before SSE4.1).
inline int floorInt(float x) {
  const int i = static_cast<int>(x);
  return i - (static_cast<float>(i) > x);
}

/// std::lround(x) without the libm call (the border path of the cell sampler calls it per
/// sample): x + 0.5 is exact in double for any float below 2^52, so truncating |x| + 0.5
/// rounds halves away from zero exactly as lround does.
inline long roundInt(float x) {
  const double d = x;
  return d >= 0.0 ? static_cast<long>(d + 0.5) : -static_cast<long>(-d + 0.5);
}

/// Valid grid index range [lo, hi] of a filter of side `size` sampled every `step` pixels
/// along an axis of `extent` pixels (the whole filter inside the image).
inline void validRange(int size, int step, int extent, int& lo, int& hi) {
  const int h = (size - 1) / 2;
  lo = (h + step - 1) / step;
  hi = (extent - 1 - h) >= 0 ? (extent - 1 - h) / step : -1;
}

/// cv::fastAtan2 [deg, 0..360) inlined: OpenCV 4's polynomial (mathfuncs_core, atan_f32)
/// with the same float operations in the same order, so the angle is bit-identical (checked
/// on 2e7 random pairs) while the per-sample loop avoids a library call per gradient.
inline float fastAtan2Deg(float y, float x) {
  constexpr float kP1 = 0.9997878412794807f * static_cast<float>(180 / CV_PI);
  constexpr float kP3 = -0.3258083974640975f * static_cast<float>(180 / CV_PI);
  constexpr float kP5 = 0.1555786518463281f * static_cast<float>(180 / CV_PI);
  constexpr float kP7 = -0.04432655554792128f * static_cast<float>(180 / CV_PI);
  const float ax = std::abs(x), ay = std::abs(y);
  float a;
  if (ax >= ay) {
    const float c = ay / (ax + static_cast<float>(DBL_EPSILON)), c2 = c * c;
    a = (((kP7 * c2 + kP5) * c2 + kP3) * c2 + kP1) * c;
  } else {
    const float c = ax / (ay + static_cast<float>(DBL_EPSILON)), c2 = c * c;
    a = 90.f - (((kP7 * c2 + kP5) * c2 + kP3) * c2 + kP1) * c;
  }
  if (x < 0) a = 180.f - a;
  if (y < 0) a = 360.f - a;
  return a;
}

#if defined(__SSE2__)
/// fastAtan2Deg on four lanes: the same float operations per lane, branches as selects, so
/// every angle is bit-identical to the scalar one.
inline __m128 fastAtan2DegSse(__m128 y, __m128 x) {
  const __m128 abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
  const __m128 ax = _mm_and_ps(x, abs_mask), ay = _mm_and_ps(y, abs_mask);
  const __m128 x_major = _mm_cmpge_ps(ax, ay);  // ax >= ay: c = ay / ax, else ax / ay
  const auto select = [](__m128 m, __m128 a, __m128 b) { return _mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b)); };
  const __m128 num = select(x_major, ay, ax);
  const __m128 den = _mm_add_ps(select(x_major, ax, ay), _mm_set1_ps(static_cast<float>(DBL_EPSILON)));
  const __m128 c = _mm_div_ps(num, den), c2 = _mm_mul_ps(c, c);
  constexpr float kP1 = 0.9997878412794807f * static_cast<float>(180 / CV_PI);
  constexpr float kP3 = -0.3258083974640975f * static_cast<float>(180 / CV_PI);
  constexpr float kP5 = 0.1555786518463281f * static_cast<float>(180 / CV_PI);
  constexpr float kP7 = -0.04432655554792128f * static_cast<float>(180 / CV_PI);
  __m128 a = _mm_add_ps(_mm_mul_ps(_mm_set1_ps(kP7), c2), _mm_set1_ps(kP5));
  a = _mm_add_ps(_mm_mul_ps(a, c2), _mm_set1_ps(kP3));
  a = _mm_add_ps(_mm_mul_ps(a, c2), _mm_set1_ps(kP1));
  a = _mm_mul_ps(a, c);
  a = select(x_major, a, _mm_sub_ps(_mm_set1_ps(90.f), a));
  const __m128 zero = _mm_setzero_ps();
  a = select(_mm_cmplt_ps(x, zero), _mm_sub_ps(_mm_set1_ps(180.f), a), a);
  a = select(_mm_cmplt_ps(y, zero), _mm_sub_ps(_mm_set1_ps(360.f), a), a);
  return a;
}
#endif

/// Index of descriptor gradient (r, c) of the 20 x 20 window, stored so that the samples at
/// the same place in the four 5 x 5 sub-regions of a band are adjacent (vectorised sums).
constexpr int cellMajor(int r, int c) { return r * kPatch + (c % 5) * 4 + c / 5; }

constexpr int kScanBlock = 16;

/// Bit k set if response v[k] exceeds `threshold`, k < kScanBlock.
inline unsigned aboveMask(const float* v, float threshold) {
#if defined(__SSE2__)
  const __m128 t = _mm_set1_ps(threshold);
  return static_cast<unsigned>(_mm_movemask_ps(_mm_cmpgt_ps(_mm_loadu_ps(v), t))) |
         static_cast<unsigned>(_mm_movemask_ps(_mm_cmpgt_ps(_mm_loadu_ps(v + 4), t))) << 4 |
         static_cast<unsigned>(_mm_movemask_ps(_mm_cmpgt_ps(_mm_loadu_ps(v + 8), t))) << 8 |
         static_cast<unsigned>(_mm_movemask_ps(_mm_cmpgt_ps(_mm_loadu_ps(v + 12), t))) << 12;
#else
  unsigned mask = 0;
  for (int k = 0; k < kScanBlock; ++k) mask |= static_cast<unsigned>(v[k] > threshold) << k;
  return mask;
#endif
}

#if defined(__SSE2__)
/// Samples (r, c5), (r, 5 + c5), (r, 10 + c5), (r, 15 + c5) of a 21-wide patch row: the same
/// place in the four 5 x 5 sub-regions of a band, one per lane.
inline __m128 bandColumn(const float* row, int c5) {
  return _mm_setr_ps(row[c5], row[5 + c5], row[10 + c5], row[15 + c5]);
}

/// The 64-element descriptor (before normalisation) from the 21 x 21 patch of cell means and
/// the Gaussian weights in cellMajor order: the four sub-regions of a band in the four lanes,
/// gradients formed and summed in the scalar loop's order (r, then c), so every lane performs
/// the scalar float operations in sequence: bit-identical.
inline void describe64(const float* patch, const float* weights, float* vec) {
  const __m128 abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
  __m128 g0[6], g1[6];  // rows r and r + 1, columns c5 = 0..5 of each sub-region
  for (int k = 0; k < 6; ++k) g0[k] = bandColumn(patch, k);
  for (int ci = 0; ci < 4; ++ci) {
    __m128 sx = _mm_setzero_ps(), sy = _mm_setzero_ps(), sax = _mm_setzero_ps(), say = _mm_setzero_ps();
    for (int r = ci * 5; r < ci * 5 + 5; ++r) {
      const float* p1 = patch + (r + 1) * (kPatch + 1);
      for (int k = 0; k < 6; ++k) g1[k] = bandColumn(p1, k);
      for (int c5 = 0; c5 < 5; ++c5) {
        const __m128 w = _mm_loadu_ps(weights + cellMajor(r, c5));
        // (p0[c + 1] - p0[c] + p1[c + 1] - p1[c]) w and (p1[c] - p0[c] + p1[c + 1] - p0[c + 1]) w
        const __m128 dx =
            _mm_mul_ps(_mm_sub_ps(_mm_add_ps(_mm_sub_ps(g0[c5 + 1], g0[c5]), g1[c5 + 1]), g1[c5]), w);
        const __m128 dy =
            _mm_mul_ps(_mm_sub_ps(_mm_add_ps(_mm_sub_ps(g1[c5], g0[c5]), g1[c5 + 1]), g0[c5 + 1]), w);
        sx = _mm_add_ps(sx, dx);
        sy = _mm_add_ps(sy, dy);
        sax = _mm_add_ps(sax, _mm_and_ps(dx, abs_mask));
        say = _mm_add_ps(say, _mm_and_ps(dy, abs_mask));
      }
      for (int k = 0; k < 6; ++k) g0[k] = g1[k];
    }
    _MM_TRANSPOSE4_PS(sx, sy, sax, say);  // lane cj -> (sum dx, sum dy, sum |dx|, sum |dy|)
    _mm_storeu_ps(vec + ci * 16, sx);
    _mm_storeu_ps(vec + ci * 16 + 4, sy);
    _mm_storeu_ps(vec + ci * 16 + 8, sax);
    _mm_storeu_ps(vec + ci * 16 + 12, say);
  }
}
#endif

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
  const int ix = floorInt(x);
  const int iy = floorInt(y);
  if (ix >= 0 && iy >= 0 && ix < img.cols - 1 && iy < img.rows - 1) {
    const float a = x - static_cast<float>(ix), b = y - static_cast<float>(iy);
    const uint8_t* p = img.ptr<uint8_t>(iy) + ix;
    const uint8_t* q = p + img.step[0];
    return (1.f - b) * ((1.f - a) * p[0] + a * p[1]) + b * ((1.f - a) * q[0] + a * q[1]);
  }
  const int cx = std::clamp(static_cast<int>(roundInt(x)), 0, img.cols - 1);
  const int cy = std::clamp(static_cast<int>(roundInt(y)), 0, img.rows - 1);
  return img.at<uint8_t>(cy, cx);
}

/// Cell means at many sub-pixel positions: the same arithmetic as boxMeanInside and bilinear
/// sample by sample, so the result is bit-identical to calling them one at a time. With SSE2,
/// four samples per step: corners, fractions and the inside test as vectors, the four integer
/// placements of each cell as two 64-bit reads per table row, transposed so the bilinear blend
/// runs on four samples at once (same float operations in the same order per lane). Sized for
/// the largest grid sampled per keypoint (the descriptor's 21 x 21), padded to whole groups.
struct CellSampler {
  static constexpr int kMax = 21 * 21;
  static constexpr int kPad = (kMax + 3) / 4 * 4;
  alignas(16) float px[kPad] = {}, py[kPad] = {};  // cell centres [px] (inputs)
#if !defined(__SSE2__)
  alignas(16) float ax[kMax], ay[kMax];   // fractional parts of the top-left corner
  alignas(16) float b[kMax][4];  // the four integer placements (x, y), (x+1, y), (x, y+1), (x+1, y+1)
  alignas(16) int xi[kMax], yi[kMax];     // integer parts of the top-left corner
  alignas(16) int inside[kMax];           // 1 if the 2 x 2 placements lie inside the image
#endif

  /// out[i] = mean grey level of the box x box cell centred at (px[i], py[i]), i < n; `out`
  /// has room for n rounded up to a multiple of 4. `fallback(px, py)` for the samples near
  /// the border (cellMean's general path).
  /// Not inlined into Surf::run: inlined it compiled to more instructions (register
  /// pressure). sampleAvx2 is the same code compiled for AVX2 (bit-identical: no FMA).
  template <typename Fallback>
  SEAVIO_SURF_NOINLINE void sample(int n, int box, float inv_box2, const uint32_t* sum, std::ptrdiff_t stride,
                                   const cv::Mat& gray8, float* out, Fallback&& fallback) {
    sampleImpl(n, box, inv_box2, sum, stride, gray8, out, fallback);
  }
#if SEAVIO_SURF_AVX2
  template <typename Fallback>
  __attribute__((target("avx2"))) SEAVIO_SURF_NOINLINE void sampleAvx2(int n, int box, float inv_box2,
                                                                      const uint32_t* sum, std::ptrdiff_t stride,
                                                                      const cv::Mat& gray8, float* out,
                                                                      Fallback&& fallback) {
    sampleImpl(n, box, inv_box2, sum, stride, gray8, out, fallback);
  }
#endif

  template <typename Fallback>
  SEAVIO_SURF_INLINE void sampleImpl(int n, int box, float inv_box2, const uint32_t* sum, std::ptrdiff_t stride,
                                     const cv::Mat& gray8, float* out, Fallback& fallback) {
    const int width = gray8.cols, height = gray8.rows;
    const float half = static_cast<float>(box - 1) * 0.5f;
    const int x_last = width - box - 1, y_last = height - box - 1;
#if defined(__SSE2__)
    // Offsets are formed in float below: exact only under 2^24; larger images (over ~16 Mpx)
    // take the general path for every sample (cellMean: the same arithmetic, slower).
    const int room = x_last >= 0 && y_last >= 0 && static_cast<double>(height + 1) * stride < (1 << 24) &&
                     static_cast<double>(height + 1) * static_cast<double>(gray8.step[0]) < (1 << 24);
    const __m128 vhalf = _mm_set1_ps(half), one = _mm_set1_ps(1.f), vinv = _mm_set1_ps(inv_box2);
    const __m128i minus1 = _mm_set1_epi32(-1);
    const __m128i xlim = _mm_set1_epi32(x_last + 1), ylim = _mm_set1_epi32(y_last + 1);
    const std::ptrdiff_t down = box * stride;
    const std::size_t gstep = gray8.step[0];
    const uint8_t* g0 = gray8.ptr<uint8_t>(0);
    // Row pitch of the table (box > 1) or of the image (box 1), for the offsets below.
    const __m128 vrow = _mm_set1_ps(static_cast<float>(box > 1 ? stride : static_cast<std::ptrdiff_t>(gstep)));
    for (int i = 0; i < n; i += 4) {
      const __m128 fx = _mm_sub_ps(_mm_load_ps(px + i), vhalf);
      const __m128 fy = _mm_sub_ps(_mm_load_ps(py + i), vhalf);
      // floor: truncate, then step down where truncation rounded up (negative fractions).
      const __m128i tx = _mm_cvttps_epi32(fx), ty = _mm_cvttps_epi32(fy);
      const __m128i x = _mm_add_epi32(tx, _mm_castps_si128(_mm_cmpgt_ps(_mm_cvtepi32_ps(tx), fx)));
      const __m128i y = _mm_add_epi32(ty, _mm_castps_si128(_mm_cmpgt_ps(_mm_cvtepi32_ps(ty), fy)));
      const __m128 ax = _mm_sub_ps(fx, _mm_cvtepi32_ps(x));
      const __m128 ay = _mm_sub_ps(fy, _mm_cvtepi32_ps(y));
      // 0 <= x <= x_last and 0 <= y <= y_last (all false without room for one cell).
      const __m128i in = _mm_and_si128(_mm_and_si128(_mm_cmpgt_epi32(x, minus1), _mm_cmplt_epi32(x, xlim)),
                                       _mm_and_si128(_mm_cmpgt_epi32(y, minus1), _mm_cmplt_epi32(y, ylim)));
      int mask = room ? _mm_movemask_ps(_mm_castsi128_ps(in)) : 0;
      if (n - i < 4) mask |= 0xF << (n - i);  // lanes past n: no reads, no fallback
      // Offsets of the top-left placements, y * stride + x, computed in float (exact: the
      // table has fewer than 2^24 entries, checked by the caller) so four offsets cost one
      // multiply. Outside lanes read the cell at (0, 0) (valid whenever any cell fits) and
      // are replaced by the fallback below.
      const __m128i off = _mm_and_si128(
          _mm_cvttps_epi32(_mm_add_ps(_mm_mul_ps(_mm_cvtepi32_ps(y), vrow), _mm_cvtepi32_ps(x))), in);
      const auto lane = [&off](int k) -> std::ptrdiff_t {
        switch (k) {
          case 0: return _mm_cvtsi128_si32(off);
          case 1: return _mm_cvtsi128_si32(_mm_shuffle_epi32(off, 0x55));
          case 2: return _mm_cvtsi128_si32(_mm_shuffle_epi32(off, 0xAA));
          default: return _mm_cvtsi128_si32(_mm_shuffle_epi32(off, 0xFF));
        }
      };
      __m128 c0, c1, c2, c3;  // the four placements of lanes 0..3
      if (!room) {
        c0 = c1 = c2 = c3 = _mm_setzero_ps();
      } else if (box > 1) {
        // Two horizontally adjacent entries are one 64-bit read; rows y and y + 1 share a
        // register (movq + movhps).
        const auto pair = [](const uint32_t* a, const uint32_t* c) {
          return _mm_castps_si128(_mm_loadh_pi(_mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(a))),
                                               reinterpret_cast<const __m64*>(c)));
        };
        const auto cell = [&](int k) {
          const uint32_t* p = sum + lane(k);
          const uint32_t* q = p + stride;
          const __m128i tl = pair(p, q), tr = pair(p + box, q + box);
          const __m128i bl = pair(p + down, q + down), br = pair(p + down + box, q + down + box);
          return _mm_cvtepi32_ps(_mm_add_epi32(_mm_sub_epi32(_mm_sub_epi32(br, tr), bl), tl));
        };
        c0 = cell(0);
        c1 = cell(1);
        c2 = cell(2);
        c3 = cell(3);
      } else {
        const auto cell = [&](int k) {
          const uint8_t* p = g0 + lane(k);
          const uint32_t v = p[0] | (p[1] << 8) | (p[gstep] << 16) | (static_cast<uint32_t>(p[gstep + 1]) << 24);
          const __m128i z = _mm_setzero_si128();
          return _mm_cvtepi32_ps(
              _mm_unpacklo_epi16(_mm_unpacklo_epi8(_mm_cvtsi32_si128(static_cast<int>(v)), z), z));
        };
        c0 = cell(0);
        c1 = cell(1);
        c2 = cell(2);
        c3 = cell(3);
      }
      _MM_TRANSPOSE4_PS(c0, c1, c2, c3);  // now c0 = placement (x, y) of the four lanes, ...
      const __m128 bx = _mm_sub_ps(one, ax), by = _mm_sub_ps(one, ay);
      __m128 r = _mm_add_ps(_mm_mul_ps(by, _mm_add_ps(_mm_mul_ps(bx, c0), _mm_mul_ps(ax, c1))),
                            _mm_mul_ps(ay, _mm_add_ps(_mm_mul_ps(bx, c2), _mm_mul_ps(ax, c3))));
      if (box > 1) r = _mm_mul_ps(r, vinv);
      _mm_storeu_ps(out + i, r);
      if (mask != 0xF) {
        for (int k = 0; k < 4; ++k) {
          if (!(mask >> k & 1)) out[i + k] = fallback(px[i + k], py[i + k]);
        }
      }
    }
#else
    const int room = x_last >= 0 && y_last >= 0;
    // One unsigned comparison per axis: x in [0, x_last] (no sample is inside if x_last < 0).
    const unsigned ux_last = room ? static_cast<unsigned>(x_last) : 0u;
    const unsigned uy_last = room ? static_cast<unsigned>(y_last) : 0u;
    int n_out = 0;
    for (int i = 0; i < n; ++i) {
      const float fx = px[i] - half, fy = py[i] - half;
      const int x = static_cast<int>(fx) - (static_cast<float>(static_cast<int>(fx)) > fx);
      const int y = static_cast<int>(fy) - (static_cast<float>(static_cast<int>(fy)) > fy);
      xi[i] = x;
      yi[i] = y;
      ax[i] = fx - static_cast<float>(x);
      ay[i] = fy - static_cast<float>(y);
      const int in = room & (static_cast<unsigned>(x) <= ux_last) & (static_cast<unsigned>(y) <= uy_last);
      inside[i] = in;
      n_out += 1 - in;
    }
    if (box > 1) {
      const std::ptrdiff_t down = box * stride;
      for (int i = 0; i < n; ++i) {
        float* bi = b[i];
        if (!inside[i]) {
          bi[0] = bi[1] = bi[2] = bi[3] = 0.f;
          continue;
        }
        const uint32_t* p = sum + static_cast<std::ptrdiff_t>(yi[i]) * stride + xi[i];
        const uint32_t* q = p + stride;
        bi[0] = static_cast<float>(static_cast<int32_t>(p[down + box] - p[box] - p[down] + p[0]));
        bi[1] = static_cast<float>(static_cast<int32_t>(p[down + box + 1] - p[box + 1] - p[down + 1] + p[1]));
        bi[2] = static_cast<float>(static_cast<int32_t>(q[down + box] - q[box] - q[down] + q[0]));
        bi[3] = static_cast<float>(static_cast<int32_t>(q[down + box + 1] - q[box + 1] - q[down + 1] + q[1]));
      }
      for (int i = 0; i < n; ++i) {
        out[i] = ((1.f - ay[i]) * ((1.f - ax[i]) * b[i][0] + ax[i] * b[i][1]) +
                  ay[i] * ((1.f - ax[i]) * b[i][2] + ax[i] * b[i][3])) *
                 inv_box2;
      }
    } else {
      const std::size_t step = gray8.step[0];
      for (int i = 0; i < n; ++i) {
        float* bi = b[i];
        if (!inside[i]) {
          bi[0] = bi[1] = bi[2] = bi[3] = 0.f;
          continue;
        }
        const uint8_t* p = gray8.ptr<uint8_t>(yi[i]) + xi[i];
        bi[0] = p[0];
        bi[1] = p[1];
        bi[2] = p[step];
        bi[3] = p[step + 1];
      }
      for (int i = 0; i < n; ++i) {
        out[i] = (1.f - ay[i]) * ((1.f - ax[i]) * b[i][0] + ax[i] * b[i][1]) +
                 ay[i] * ((1.f - ax[i]) * b[i][2] + ax[i] * b[i][3]);
      }
    }
    if (n_out == 0) return;
    for (int i = 0; i < n; ++i) {
      if (!inside[i]) out[i] = fallback(px[i], py[i]);
    }
#endif
  }
};

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
  if (p.first_octave < 0 || (p.octaves >= 1 && p.first_octave >= p.octaves)) {
    errors.push_back("surf.first_octave must be in [0, surf.octaves - 1]");
  }
  if (p.max_features < 0) errors.push_back("surf.max_features must be >= 0 (0 = no cap)");
  return errors;
}

int Surf::filterSize(int octave, int layer) { return 3 * ((2 << octave) * (layer + 1) + 1); }

Surf::Surf(SurfParams params) : params_(params) {
#if SEAVIO_SURF_AVX2
  use_avx2_ = params_.avx2 && __builtin_cpu_supports("avx2");
#endif
  for (int v = -kOriRadius; v <= kOriRadius; ++v) {
    for (int u = -kOriRadius; u <= kOriRadius; ++u) {
      if (u * u + v * v > kOriRadius * kOriRadius) continue;
      ori_offsets_.emplace_back(u, v);
      ori_weights_.push_back(
          std::exp(-static_cast<float>(u * u + v * v) / (2.f * kOriSigma * kOriSigma)));
    }
  }
  // Rows of the disc as runs (v, first u, count) for the four-lane gradient loop, and the
  // weights padded to a whole last group.
  for (std::size_t q = 0; q < ori_offsets_.size(); ++q) {
    if (ori_rows_.empty() || ori_rows_.back()[0] != ori_offsets_[q].y) {
      ori_rows_.emplace_back(ori_offsets_[q].y, ori_offsets_[q].x, 0);
    }
    ++ori_rows_.back()[2];
  }
  ori_weights_.resize(ori_offsets_.size() + 3, 0.f);
  desc_weights_.resize(kPatch * kPatch);
  for (int r = 0; r < kPatch; ++r) {
    for (int c = 0; c < kPatch; ++c) {
      const float dr = static_cast<float>(r) - (kPatch - 1) / 2.f;
      const float dc = static_cast<float>(c) - (kPatch - 1) / 2.f;
      desc_weights_[cellMajor(r, c)] = std::exp(-(dr * dr + dc * dc) / (2.f * kDescSigma * kDescSigma));
    }
  }
}

bool Surf::detectAndCompute(const cv::Mat& gray8, double hessian_threshold,
                            std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors) const {
  SurfWorkspace workspace;
  return run(gray8, hessian_threshold, keypoints, &descriptors, workspace);
}

bool Surf::detect(const cv::Mat& gray8, double hessian_threshold,
                  std::vector<cv::KeyPoint>& keypoints) const {
  SurfWorkspace workspace;
  return run(gray8, hessian_threshold, keypoints, nullptr, workspace);
}

bool Surf::detectAndCompute(const cv::Mat& gray8, double hessian_threshold, std::vector<cv::KeyPoint>& keypoints,
                            cv::Mat& descriptors, SurfWorkspace& workspace) const {
  return run(gray8, hessian_threshold, keypoints, &descriptors, workspace);
}

bool Surf::detect(const cv::Mat& gray8, double hessian_threshold, std::vector<cv::KeyPoint>& keypoints,
                  SurfWorkspace& workspace) const {
  return run(gray8, hessian_threshold, keypoints, nullptr, workspace);
}

bool Surf::run(const cv::Mat& gray8, double hessian_threshold, std::vector<cv::KeyPoint>& keypoints,
               cv::Mat* descriptors, SurfWorkspace& workspace) const {
  if (!gray8.empty() && gray8.type() != CV_8UC1) {
    keypoints.clear();
    if (descriptors != nullptr) fitRows(*descriptors, 0, descriptorSize(), CV_32F);
    return false;
  }
#if SEAVIO_SURF_AVX2
  if (use_avx2_) {
    runAvx2(gray8, hessian_threshold, keypoints, descriptors, workspace);
    return true;
  }
#endif
  runBaseline(gray8, hessian_threshold, keypoints, descriptors, workspace);
  return true;
}

template <bool kAvx2>
SEAVIO_SURF_INLINE void Surf::runWith(const cv::Mat& gray8, double hessian_threshold,
                                      std::vector<cv::KeyPoint>& keypoints, cv::Mat* descriptors,
                                      SurfWorkspace& workspace) const {
  keypoints.clear();
  // One allocation up front instead of a dozen regrowths (a caller reusing its vector pays none).
  keypoints.reserve(1024);
  // The caller's descriptor rows are kept for reuse (fitRows), not released.
  if (descriptors != nullptr) fitRows(*descriptors, 0, descriptorSize(), CV_32F);
  if (gray8.empty()) return;
  workspace.integral_.compute(gray8);
  const IntegralImage& integral = workspace.integral_;
  const int width = gray8.cols, height = gray8.rows;
  const std::ptrdiff_t stride = integral.stride();
  const uint32_t* sum = integral.data();
  const float threshold = static_cast<float>(hessian_threshold);
  const int n_layers = params_.octave_layers + 2;

  // --- Detection: det(H) over octaves and layers, 3x3x3 maxima, interpolation (Bay 2008, 3).
  // Only the middle layers of an octave (those that can hold a maximum) are computed in full;
  // the bottom and top layers serve only as neighbours, so their 3x3 patches are evaluated on
  // demand at the few positions that survive the threshold and the in-layer and full-layer
  // comparisons. That halves the box-filter work of the default 4-layer octave.
  const int n_full = n_layers - 2;
  // Response planes, uninitialised: only the valid ranges are written and read.
  std::size_t& plane_capacity = workspace.layers_capacity_;
  std::unique_ptr<float[]>& layers = workspace.layers_;
  // hessianLayerUnit: (L + 4) (n + 3 L) entries, n <= width, L <= 49.
  const std::size_t scratch_size = (4 + 49) * (static_cast<std::size_t>(width) + 3 * 49 + 8);
  if (scratch_size > workspace.scratch_capacity_) {
    workspace.scratch_.reset(new uint32_t[scratch_size]);
    workspace.scratch_capacity_ = scratch_size;
  }
  uint32_t* const row_scratch = workspace.scratch_.get();
  for (int octave = params_.first_octave; octave < params_.octaves; ++octave) {
    const int step = 1 << octave;
    const int rows = (height - 1) / step + 1, cols = (width - 1) / step + 1;
    // The largest filter of the octave bounds where a full 3x3x3 neighbourhood exists.
    int top_i0, top_i1, top_j0, top_j1;
    validRange(filterSize(octave, n_layers - 1), step, height, top_i0, top_i1);
    validRange(filterSize(octave, n_layers - 1), step, width, top_j0, top_j1);
    if (top_i1 - top_i0 < 2 || top_j1 - top_j0 < 2) break;
    const std::size_t plane = static_cast<std::size_t>(rows) * cols;
    if (plane * n_full > plane_capacity) {
      plane_capacity = plane * n_full;
      layers.reset(new float[plane_capacity]);
    }
    std::array<HessianFilter, 8 + 2> filters;  // octave_layers <= 8 (validate)
    for (int layer = 0; layer < n_layers; ++layer) filters[layer] = HessianFilter(filterSize(octave, layer), stride);
    const auto centre = [&](int i, int j) {
      return sum + static_cast<std::ptrdiff_t>(i) * step * stride + static_cast<std::ptrdiff_t>(j) * step;
    };

    for (int layer = 1; layer <= n_full; ++layer) {
      int i0, i1, j0, j1;
      validRange(filters[layer].size, step, height, i0, i1);
      validRange(filters[layer].size, step, width, j0, j1);
      float* det = layers.get() + plane * (layer - 1);
      hessianLayer(filters[layer], sum, stride, step, i0, i1, j0, j1, det, cols, row_scratch, kAvx2);
    }

    for (int layer = 1; layer <= n_full; ++layer) {
      // The layer above is the largest filter of the triple, so its valid range bounds all.
      int i0, i1, j0, j1;
      validRange(filters[layer + 1].size, step, height, i0, i1);
      validRange(filters[layer + 1].size, step, width, j0, j1);
      const float* here = layers.get() + plane * (layer - 1);
      // Neighbour planes: 0 below, 2 above; null when that layer is evaluated on demand.
      const float* full[3] = {layer - 1 >= 1 ? here - plane : nullptr, here,
                              layer + 1 <= n_full ? here + plane : nullptr};
      const int size = filters[layer].size;
      const int ds = size - filters[layer - 1].size;
      for (int i = i0 + 1; i <= i1 - 1; ++i) {
        const float* row = here + static_cast<std::size_t>(i) * cols;
        for (int jb = j0 + 1; jb <= j1 - 1; jb += kScanBlock) {
          const int je = std::min(jb + kScanBlock, j1);  // exclusive
          // Most responses are below the threshold: one vectorised test per block, then only
          // the columns above it, in order (the same candidates as testing each column).
          unsigned above = 0;
          if (je - jb == kScanBlock) {
            above = aboveMask(row + jb, threshold);
          } else {
            for (int j = jb; j < je; ++j) above |= static_cast<unsigned>(row[j] > threshold) << (j - jb);
          }
          while (above != 0) {
            const int j = jb + __builtin_ctz(above);
            above &= above - 1;
            const float v = row[j];
            // Cheapest first: the 8 neighbours in this layer (rows above and below in memory).
            const float* up = row - cols;
            const float* dn = row + cols;
            if (!(v > up[j - 1] && v > up[j] && v > up[j + 1] && v > row[j - 1] && v > row[j + 1] &&
                  v > dn[j - 1] && v > dn[j] && v > dn[j + 1]))
              continue;
            float n[3][9];
            bool is_max = true;
            for (int p : {0, 2}) {  // full neighbour layers before the ones computed on demand
              if (full[p] == nullptr) continue;
              const float* q = full[p] + static_cast<std::size_t>(i) * cols + j;
              for (int k = 0; k < 9 && is_max; ++k) {
                n[p][k] = q[(k / 3 - 1) * static_cast<std::ptrdiff_t>(cols) + (k % 3 - 1)];
                is_max = v > n[p][k];
              }
            }
            for (int p : {0, 2}) {
              if (!is_max || full[p] != nullptr) continue;
              const HessianFilter& f = filters[layer - 1 + p];
              for (int k = 0; k < 9 && is_max; ++k) {
                n[p][k] = hessianAt(f, centre(i + k / 3 - 1, j + k % 3 - 1));
                is_max = v > n[p][k];
              }
            }
            if (!is_max) continue;
            for (int k = 0; k < 9; ++k) n[1][k] = row[(k / 3 - 1) * static_cast<std::ptrdiff_t>(cols) + j + (k % 3 - 1)];
            cv::Vec3d offset;
            if (!interpolate(n, offset)) continue;
            const float trace = filters[layer].dxx(centre(i, j)) + filters[layer].dyy(centre(i, j));
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
  // Written in place: a caller passing the previous frame's descriptors allocates nothing.
  if (descriptors != nullptr) fitRows(*descriptors, static_cast<int>(keypoints.size()), dsize, CV_32F);
  // Gradient samples of the orientation disc (113 within radius 6), room for a whole last group.
  constexpr int kOriMax = 128;
  static_assert(kOriSamples + 3 <= kOriMax, "the disc and a padded last group fit");
  alignas(16) std::array<float, kOriMax> gx{}, gy{}, ang{};
  std::array<float, 360 + kOriWindowDeg> bin_x{}, bin_y{};
  alignas(16) std::array<float, CellSampler::kPad> patch{};
  // Orientation: the (2 kG + 1)^2 grid of cell means around a keypoint, zeros where never
  // sampled (read only by lanes whose results are dropped), and its sampled cells in order.
  constexpr int kG = kOriGrid;
  constexpr int kGW = 2 * kG + 1;
  alignas(16) std::array<float, (kGW * kGW + 3) / 4 * 4> grid{};
  alignas(16) std::array<float, (kOriGridCells + 3) / 4 * 4> cells{};
  static_assert(kOriGridCells <= CellSampler::kMax, "the sampled cells fit the sampler");
  std::array<float, kPatch * kPatch> pdx{}, pdy{};
  // Mean grey level of the box x box cell centred at (px, py) [px]: the integral image at the
  // sub-pixel centre (bilinear blend of the four integer placements); plain bilinear for box 1.
  const auto cellMean = [&](float px, float py, int box, float inv_box2) -> float {
    if (box <= 1) return bilinear(gray8, px, py);
    const float fx = px - (box - 1) * 0.5f, fy = py - (box - 1) * 0.5f;
    const int x = floorInt(fx), y = floorInt(fy);
    const float ax = fx - static_cast<float>(x), ay = fy - static_cast<float>(y);
    if (x >= 0 && y >= 0 && x + box + 1 <= width && y + box + 1 <= height) {
      return boxMeanInside(sum, stride, x, y, ax, ay, box, inv_box2);
    }
    if (box <= width && box <= height) {
      // Near the border: the box shifted inside the image (replicates the edge).
      const int cx = std::clamp(static_cast<int>(roundInt(fx)), 0, width - box);
      const int cy = std::clamp(static_cast<int>(roundInt(fy)), 0, height - box);
      return static_cast<float>(integral.boxSum(cx, cy, cx + box, cy + box)) * inv_box2;
    }
    return bilinear(gray8, px, py);
  };
  CellSampler sampler;
  const auto sampleCells = [&](int n, int box, float inv_box2, float* out, auto&& fallback) {
#if SEAVIO_SURF_AVX2
    if constexpr (kAvx2) {
      sampler.sampleAvx2(n, box, inv_box2, sum, stride, gray8, out, fallback);
      return;
    }
#endif
    sampler.sample(n, box, inv_box2, sum, stride, gray8, out, fallback);
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
      // Only the cells the stencil reads are sampled (kOriGridRows: 225 of 289), into `cells`
      // in row order, then placed in the grid; the unread corners keep their initial zeros.
      const int obox = std::max(1, static_cast<int>(std::lround(3.f * s)));  // smoothing box [px]
      const float inv_obox2 = 1.f / static_cast<float>(obox * obox);
      int m = 0;
      for (int v = -kG; v <= kG; ++v) {
        const int u0 = kOriGridRows[v + kG][0], count = kOriGridRows[v + kG][1];
        for (int u = u0; u < u0 + count; ++u, ++m) {
          sampler.px[m] = kp.pt.x + u * s;
          sampler.py[m] = kp.pt.y + v * s;
        }
      }
      sampleCells(m, obox, inv_obox2, cells.data(),
                  [&](float x, float y) { return cellMean(x, y, obox, inv_obox2); });
      m = 0;
      for (int v = -kG; v <= kG; ++v) {
        const int u0 = kOriGridRows[v + kG][0], count = kOriGridRows[v + kG][1];
        std::copy(cells.data() + m, cells.data() + m + count, grid.data() + (v + kG) * kGW + (u0 + kG));
        m += count;
      }
      std::size_t n = 0;
#if defined(__SSE2__)
      // Four samples of a disc row at once (same operations per lane as the scalar loop below;
      // lanes past a row's end are overwritten by the next row or ignored).
      for (const cv::Vec3i& seg : ori_rows_) {
        const float* row = grid.data() + (seg[0] + kG) * kGW + (seg[1] + kG);
        for (int k = 0; k < seg[2]; k += 4) {
          const float* g = row + k;
          const auto at = [g](int o) { return _mm_loadu_ps(g + o); };
          const __m128 three = _mm_set1_ps(3.f), ten = _mm_set1_ps(10.f);
          const __m128 hx = _mm_add_ps(
              _mm_add_ps(_mm_mul_ps(three, _mm_sub_ps(at(-2 * kGW + 2), at(-2 * kGW - 2))),
                         _mm_mul_ps(ten, _mm_sub_ps(at(2), at(-2)))),
              _mm_mul_ps(three, _mm_sub_ps(at(2 * kGW + 2), at(2 * kGW - 2))));
          const __m128 hy = _mm_add_ps(
              _mm_add_ps(_mm_mul_ps(three, _mm_sub_ps(at(2 * kGW - 2), at(-2 * kGW - 2))),
                         _mm_mul_ps(ten, _mm_sub_ps(at(2 * kGW), at(-2 * kGW)))),
              _mm_mul_ps(three, _mm_sub_ps(at(2 * kGW + 2), at(-2 * kGW + 2))));
          const __m128 w = _mm_loadu_ps(ori_weights_.data() + n + k);
          const __m128 vx = _mm_mul_ps(hx, w), vy = _mm_mul_ps(hy, w);
          _mm_storeu_ps(gx.data() + n + k, vx);
          _mm_storeu_ps(gy.data() + n + k, vy);
          _mm_storeu_ps(ang.data() + n + k, fastAtan2DegSse(vy, vx));
        }
        n += static_cast<std::size_t>(seg[2]);
      }
#else
      for (std::size_t q = 0; q < ori_offsets_.size(); ++q) {
        const float* g = grid.data() + (ori_offsets_[q].y + kG) * kGW + (ori_offsets_[q].x + kG);
        const float hx = 3.f * (g[-2 * kGW + 2] - g[-2 * kGW - 2]) + 10.f * (g[2] - g[-2]) +
                         3.f * (g[2 * kGW + 2] - g[2 * kGW - 2]);
        const float hy = 3.f * (g[2 * kGW - 2] - g[-2 * kGW - 2]) + 10.f * (g[2 * kGW] - g[-2 * kGW]) +
                         3.f * (g[2 * kGW + 2] - g[-2 * kGW + 2]);
        gx[n] = hx * ori_weights_[q];
        gy[n] = hy * ori_weights_[q];
        ang[n] = fastAtan2Deg(gy[n], gx[n]);
        ++n;
      }
#endif
      if (n == 0) continue;
      // Sliding 60 deg sector over 1 deg bins, in 1 deg steps (OpenCV: 5); the longest summed
      // vector gives the direction.
      std::fill(bin_x.begin(), bin_x.end(), 0.f);
      std::fill(bin_y.begin(), bin_y.end(), 0.f);
      std::array<uint64_t, (360 + kOriWindowDeg + 63) / 64 + 1> used{};  // bins that got a sample
      for (std::size_t q = 0; q < n; ++q) {
        const int b = std::min(359, static_cast<int>(ang[q]));
        bin_x[b] += gx[q];
        bin_y[b] += gy[q];
        used[b >> 6] |= uint64_t{1} << (b & 63);
      }
      for (int b = 0; b < kOriWindowDeg; ++b) {
        bin_x[360 + b] = bin_x[b];
        bin_y[360 + b] = bin_y[b];
        if (used[b >> 6] >> (b & 63) & 1) used[(360 + b) >> 6] |= uint64_t{1} << ((360 + b) & 63);
      }
      float wx = 0.f, wy = 0.f;
      for (int b = 0; b < kOriWindowDeg; ++b) {
        wx += bin_x[b];
        wy += bin_y[b];
      }
      float best = -1.f, best_x = 0.f, best_y = 0.f;
      const auto consider = [&] {
        if (wx * wx + wy * wy > best) {
          best = wx * wx + wy * wy;
          best_x = wx;
          best_y = wy;
        }
      };
      // The sector slides over mostly empty bins (113 samples, 360 bins). Where both the bin
      // entering and the one leaving are empty (+0) the update adds +0 and the sum, hence its
      // length, is unchanged, so the comparison can't pass either: only the starts whose
      // entering or leaving bin got a sample are visited, in order. Bit-identical to the
      // plain slide over all 360 starts.
      consider();
      for (int w = 0; w * 64 < 360; ++w) {
        constexpr int kShift = kOriWindowDeg % 64;  // bit of the entering bin, from the word above
        static_assert(kOriWindowDeg < 64, "entering bin within the next word");
        uint64_t changes = used[w] | (used[w] >> kShift) | (used[w + 1] << (64 - kShift));
        if (w * 64 + 64 > 360) changes &= (uint64_t{1} << (360 - w * 64)) - 1;
        while (changes != 0) {
          const int start = w * 64 + __builtin_ctzll(changes);
          changes &= changes - 1;
          wx += bin_x[start + kOriWindowDeg] - bin_x[start];
          wy += bin_y[start + kOriWindowDeg] - bin_y[start];
          if (start + 1 < 360) consider();
        }
      }
      angle_deg = fastAtan2Deg(best_y, best_x);
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
          sampler.px[r * (kPatch + 1) + c] = kp.pt.x + du * cs - dv * sn;
          sampler.py[r * (kPatch + 1) + c] = kp.pt.y + du * sn + dv * cs;
        }
      }
      sampleCells((kPatch + 1) * (kPatch + 1), box, inv_box2, patch.data(),
                     [&](float x, float y) { return cellMean(x, y, box, inv_box2); });
      float* vec = descriptors->ptr<float>(static_cast<int>(kept));
#if defined(__SSE2__)
      if (!params_.extended) {
        describe64(patch.data(), desc_weights_.data(), vec);
      } else
#endif
      {  // 128 floats, or no SSE2: scalar Haar responses, then the sums
        for (int r = 0; r < kPatch; ++r) {
          const float* p0 = patch.data() + r * (kPatch + 1);
          const float* p1 = p0 + (kPatch + 1);
          for (int cj = 0; cj < 4; ++cj) {
            for (int c5 = 0; c5 < 5; ++c5) {
              const int c = cj * 5 + c5;
              const float w = desc_weights_[cellMajor(r, c)];
              pdx[r * kPatch + c5 * 4 + cj] = (p0[c + 1] - p0[c] + p1[c + 1] - p1[c]) * w;
              pdy[r * kPatch + c5 * 4 + cj] = (p1[c] - p0[c] + p1[c + 1] - p0[c + 1]) * w;
            }
          }
        }
        if (params_.extended) {
          std::fill(vec, vec + dsize, 0.f);
          float* cell = vec;
          for (int ci = 0; ci < 4; ++ci) {
            for (int cj = 0; cj < 4; ++cj) {
              for (int r = ci * 5; r < ci * 5 + 5; ++r) {
                for (int c = cj * 5; c < cj * 5 + 5; ++c) {
                  const float tx = pdx[cellMajor(r, c)], ty = pdy[cellMajor(r, c)];
                  // Sums split by the sign of the other component (Bay 2008, 4.2, SURF-128).
                  const int oy = ty >= 0.f ? 0 : 2;
                  cell[oy] += tx;
                  cell[oy + 1] += std::abs(tx);
                  const int ox = tx >= 0.f ? 4 : 6;
                  cell[ox] += ty;
                  cell[ox + 1] += std::abs(ty);
                }
              }
              cell += 8;
            }
          }
        } else {
          // The four sub-regions of a band side by side (cellMajor), each summed in the order
          // r, c of the plain loop: the same sums, four at a time.
          for (int ci = 0; ci < 4; ++ci) {
            std::array<float, 4> sx{}, sy{}, sax{}, say{};
            for (int r = ci * 5; r < ci * 5 + 5; ++r) {
              for (int c5 = 0; c5 < 5; ++c5) {
                const float* tx = pdx.data() + cellMajor(r, c5);
                const float* ty = pdy.data() + cellMajor(r, c5);
                for (int cj = 0; cj < 4; ++cj) {
                  sx[cj] += tx[cj];
                  sy[cj] += ty[cj];
                  sax[cj] += std::abs(tx[cj]);
                  say[cj] += std::abs(ty[cj]);
                }
              }
            }
            for (int cj = 0; cj < 4; ++cj) {
              float* cell = vec + (ci * 4 + cj) * 4;
              cell[0] = sx[cj];
              cell[1] = sy[cj];
              cell[2] = sax[cj];
              cell[3] = say[cj];
            }
          }
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
  if (descriptors != nullptr) descriptors->resize(kept);  // in place: rows 0..kept-1 are the kept ones
}

SEAVIO_SURF_NOINLINE void Surf::runBaseline(const cv::Mat& gray8, double hessian_threshold,
                                            std::vector<cv::KeyPoint>& keypoints, cv::Mat* descriptors,
                                            SurfWorkspace& workspace) const {
  runWith<false>(gray8, hessian_threshold, keypoints, descriptors, workspace);
}

#if SEAVIO_SURF_AVX2
/// The whole call compiled for AVX2: box filters eight responses per step, the rest of the
/// vectorised and SSE2 code in three-operand VEX form (fewer register copies). No FMA, so
/// every float operation is the baseline's: bit-identical output.
__attribute__((target("avx2"))) SEAVIO_SURF_NOINLINE void Surf::runAvx2(const cv::Mat& gray8,
                                                                        double hessian_threshold,
                                                                        std::vector<cv::KeyPoint>& keypoints,
                                                                        cv::Mat* descriptors,
                                                                        SurfWorkspace& workspace) const {
  runWith<true>(gray8, hessian_threshold, keypoints, descriptors, workspace);
}
#endif

}  // namespace seavio::features
