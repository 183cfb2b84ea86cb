#pragma once
/// Saturating arithmetic on nanosecond stamps. Stamps from outside (devices, logs, the bus)
/// can be anything an int64 holds; a difference or an offset that overflows is undefined
/// behaviour in C++ and, in practice, wraps a far-future stamp into the far past. Clamping at
/// the int64 limits keeps every comparison on the right side.
#include <cstdint>
#include <limits>

namespace seavio {

inline constexpr int64_t kStampMaxNs = std::numeric_limits<int64_t>::max();
inline constexpr int64_t kStampMinNs = std::numeric_limits<int64_t>::min();

/// a + b, clamped to the int64 range.
inline int64_t saturatingAdd(int64_t a, int64_t b) {
  int64_t r = 0;
  if (__builtin_add_overflow(a, b, &r)) return b > 0 ? kStampMaxNs : kStampMinNs;
  return r;
}

/// a - b, clamped to the int64 range.
inline int64_t saturatingSub(int64_t a, int64_t b) {
  int64_t r = 0;
  if (__builtin_sub_overflow(a, b, &r)) return b < 0 ? kStampMaxNs : kStampMinNs;
  return r;
}

/// `x` [ns] as int64, clamped (a double outside the int64 range is undefined to convert).
inline int64_t saturatingFromDouble(double x) {
  if (!(x == x)) return 0;
  if (x >= 9.2e18) return kStampMaxNs;
  if (x <= -9.2e18) return kStampMinNs;
  return static_cast<int64_t>(x);
}

}  // namespace seavio
