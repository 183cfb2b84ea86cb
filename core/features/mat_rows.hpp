#pragma once
/// Row-count changes of a cv::Mat that keep its allocation across frames (no
/// allocation on the per-frame path once running).
#include <algorithm>
#include <cstddef>

#include <opencv2/core.hpp>

namespace seavio::features {

/// Makes `m` a rows x cols matrix of `type` for writing (contents undefined), keeping its
/// allocation when it fits: cv::Mat::resize changes the row count in place while the rows fit
/// the allocation, and growth leaves half again as much headroom so a slowly rising count
/// does not reallocate every frame. A buffer shared with another Mat header (refcount > 1,
/// e.g. descriptors a keyframe still refers to) or a view into a larger Mat is never written
/// into: `m` then gets a fresh allocation.
inline void fitRows(cv::Mat& m, int rows, int cols, int type) {
  const bool reusable = m.u != nullptr && m.u->refcount == 1 && m.dims == 2 && m.cols == cols && m.type() == type &&
                        !m.isSubmatrix() && m.step[0] > 0;
  const auto capacity = reusable ? static_cast<std::size_t>(m.datalimit - m.datastart) / m.step[0] : 0;
  if (!reusable || static_cast<std::size_t>(rows) > capacity) {
    if (rows == 0) {  // nothing to hold yet: an empty header of the right shape, no allocation
      m = cv::Mat(0, cols, type);
      return;
    }
    m = cv::Mat(rows + rows / 2, cols, type);
  }
  m.resize(static_cast<std::size_t>(rows));
}

}  // namespace seavio::features
