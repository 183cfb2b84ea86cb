#pragma once
/// Capacity growth for the per-frame buffers (no allocation on the per-frame path).
#include <cstddef>

namespace seavio {

/// Makes room for at least `n` elements in `v` (a std::vector), with half as much again when it
/// has to grow. The buffers a frame reuses hold the largest frame seen so far; growing them to
/// the exact size would allocate again at each slightly larger frame after the warm-up, while
/// the headroom absorbs the frame-to-frame spread of the counts (features, matches, inliers).
template <class Vector>
void reserveWithHeadroom(Vector& v, std::size_t n) {
  if (v.capacity() < n) v.reserve(n + n / 2);
}

/// `v.resize(n)` on a buffer with headroom (reserveWithHeadroom).
template <class Vector>
void resizeWithHeadroom(Vector& v, std::size_t n) {
  reserveWithHeadroom(v, n);
  v.resize(n);
}

}  // namespace seavio
