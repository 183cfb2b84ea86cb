#pragma once
/// The matching tests' floor: sand-like texture, blurred white noise, grey 128 +- ~40.
#include <cstdint>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace seavio::matching::test {

/// `size` of it from `seed`, as `type` (CV_8U, or CV_32F to move it by sub-pixel amounts
/// before quantising).
inline cv::Mat sandTexture(int seed, cv::Size size, int type = CV_8U) {
  cv::Mat f(size, CV_32F);
  cv::RNG rng(static_cast<uint64_t>(seed));
  rng.fill(f, cv::RNG::NORMAL, 0, 1);
  cv::GaussianBlur(f, f, cv::Size(), 2.0);
  cv::Scalar mean, sd;
  cv::meanStdDev(f, mean, sd);
  cv::Mat out;
  f.convertTo(out, type, 40.0 / sd[0], 128 - 40.0 * mean[0] / sd[0]);
  return out;
}

}  // namespace seavio::matching::test
