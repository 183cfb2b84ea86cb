#pragma once
/// Bilinear remap of 8-bit grey images over OpenCV's fixed-point maps, into a caller-owned
/// output (no allocation on the per-frame path). cv::remap allocates its tile buffers
/// on every call (four per image); this reads the maps in place.
#include <cstdint>

#include <opencv2/core.hpp>

namespace seavio::camera {

/// `dst`(x, y) = `src` sampled bilinearly at the map's point: `xy` (CV_16SC2) holds the
/// integer source pixel, `frac` (CV_16UC1) the 1/32-pixel fraction as fy * 32 + fx (the
/// CV_16SC2 form of cv::convertMaps). Equal byte for byte to
/// cv::remap(src, dst, xy, frac, INTER_LINEAR, BORDER_CONSTANT, border) for CV_8UC1: OpenCV's
/// weights are (32 - fx or fx)(32 - fy or fy) * 32 in 1/32768 (exact in float), so the
/// rounded sum equals ours in 1/1024. Corners outside `src` count as `border`, as OpenCV's.
/// `dst` is (re)created only when its size or type differs; it must not share `src`'s data.
/// Other image types are passed to cv::remap.
void remapBilinear(const cv::Mat& src, cv::Mat& dst, const cv::Mat& xy, const cv::Mat& frac, uint8_t border = 0);

}  // namespace seavio::camera
