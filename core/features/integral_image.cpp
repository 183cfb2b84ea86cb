#include "core/features/integral_image.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace seavio::features {

void IntegralImage::compute(const cv::Mat& gray8) {
  if (!gray8.empty() && gray8.type() != CV_8UC1) {
    throw std::invalid_argument("IntegralImage: expected an 8-bit single-channel image, got type " +
                                std::to_string(gray8.type()));
  }
  width_ = gray8.cols;
  height_ = gray8.rows;
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
    for (int x = 0; x < width_; ++x) {
      run += src[x];
      row[x + 1] = above[x + 1] + run;
    }
  }
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
