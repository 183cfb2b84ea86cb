#include "core/odometry/reference_alignment.hpp"

#include <algorithm>

#include "core/common/capacity.hpp"

namespace seavio::odometry {

void ReferenceAlignments::reset(uint64_t key, std::size_t n) {
  resizeWithHeadroom(state_, n);
  resizeWithHeadroom(uv_right_, n);
  std::fill(state_.begin(), state_.end(), State::kUnknown);
  key_ = key;
  valid_ = true;
}

void ReferenceAlignments::set(std::size_t i, bool aligned, const Eigen::Vector2f& uv_right) {
  if (i >= state_.size()) return;
  state_[i] = aligned ? State::kAligned : State::kFailed;
  uv_right_[i] = uv_right;
}

bool alignInReferenceRight(std::size_t i, const matching::PatchTemplate& tmpl, const cv::Mat& ref_right,
                           const Eigen::Vector2f& uv_right, const matching::PatchAlignParams& params,
                           ReferenceAlignments* cache, Eigen::Vector2f& aligned_uv_right) {
  const ReferenceAlignments::State known = cache ? cache->state(i) : ReferenceAlignments::State::kUnknown;
  if (known == ReferenceAlignments::State::kFailed) return false;
  if (!tmpl.ok) {
    if (cache) cache->set(i, false, uv_right);
    return false;
  }
  if (known == ReferenceAlignments::State::kAligned) {
    aligned_uv_right = cache->uvRight(i);
    return true;
  }
  const matching::PatchAlignment rp = matching::alignPatch(tmpl, ref_right, uv_right, Eigen::Matrix2f::Identity(), params);
  if (cache) cache->set(i, rp.ok, rp.uv);
  if (!rp.ok) return false;
  aligned_uv_right = rp.uv;
  return true;
}

}  // namespace seavio::odometry
