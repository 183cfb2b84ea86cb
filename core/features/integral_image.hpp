#pragma once
/// Summed-area table of an 8-bit grey image (Bay et al. 2008, section 2.1): any axis-aligned
/// box sum in four reads, which makes SURF's box filters cost the same at every scale.
#include <cstddef>
#include <cstdint>
#include <memory>

#include <opencv2/core.hpp>

namespace seavio::features {

/// Integral image S with S(x, y) = sum of pixels in columns < x and rows < y, so it is one
/// row and one column larger than the source. Entries are unsigned 32-bit and wrap modulo
/// 2^32 on large images; a box sum is still exact as long as the box itself sums to less than
/// 2^32 (any box up to 16.8 Mpx of 8-bit data), so there is no image-size limit.
class IntegralImage {
 public:
  IntegralImage() = default;
  /// Builds the table of `gray8` (see compute).
  explicit IntegralImage(const cv::Mat& gray8) { compute(gray8); }

  /// Rebuilds the table, reusing the buffer when it is large enough. Every entry is written
  /// once (no zero-fill pass). False, and an empty table, unless `gray8` is CV_8UC1 (or empty).
  bool compute(const cv::Mat& gray8);

  int width() const { return width_; }    ///< source width [px]
  int height() const { return height_; }  ///< source height [px]
  /// Row stride of the table in elements (width() + 1).
  std::ptrdiff_t stride() const { return width_ + 1; }
  /// Pointer to S(0, 0); S(x, y) is data()[y * stride() + x].
  const uint32_t* data() const { return table_.get(); }
  /// S(x, y), 0 <= x <= width(), 0 <= y <= height().
  uint32_t at(int x, int y) const { return table_[static_cast<std::size_t>(y) * (width_ + 1) + x]; }

  /// Sum of pixels in the half-open box [x0, x1) x [y0, y1) (clipped to the image; an empty
  /// or fully outside box sums to 0).
  uint32_t boxSum(int x0, int y0, int x1, int y1) const;

 private:
  int width_ = 0;
  int height_ = 0;
  std::size_t capacity_ = 0;             // entries allocated
  std::unique_ptr<uint32_t[]> table_;  // uninitialised until compute() writes it
};

}  // namespace seavio::features
