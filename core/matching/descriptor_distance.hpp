#pragma once
/// Distance between two descriptor rows: L2 for float descriptors (SURF, SIFT), Hamming for
/// binary ones (ORB, AKAZE). Inline because it is the innermost loop of every matcher.
#include <bit>
#include <cmath>
#include <cstdint>

#include <opencv2/core.hpp>

namespace seavio::matching {

inline float descriptorDistance(const cv::Mat& a, int row_a, const cv::Mat& b, int row_b) {
  if (a.type() == CV_32F) {
    const float* pa = a.ptr<float>(row_a);
    const float* pb = b.ptr<float>(row_b);
    float sum = 0.f;
    for (int i = 0; i < a.cols; ++i) {
      const float d = pa[i] - pb[i];
      sum += d * d;
    }
    return std::sqrt(sum);
  }
  const uint8_t* pa = a.ptr<uint8_t>(row_a);
  const uint8_t* pb = b.ptr<uint8_t>(row_b);
  int bits = 0;
  for (int i = 0; i < a.cols; ++i) bits += std::popcount(static_cast<unsigned>(pa[i] ^ pb[i]));
  return static_cast<float>(bits);
}

}  // namespace seavio::matching
