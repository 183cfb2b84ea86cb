#pragma once
/// A reference stereo point's left patch and its alignment in the reference right image, the
/// first of the three alignments patch refinement and guided tracks make per point
/// (core/matching/patch_alignment.hpp).
///
/// Why a cache: that alignment depends on the reference pair alone. While frames track
/// against one keyframe (1.2 m, a dozen frames at 10 Hz) each frame would redo it for the
/// same points; kept per keyframe it runs once per point, and a point whose template or
/// alignment failed is not tried again. The results are the same to the bit.
#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "core/matching/patch_alignment.hpp"

namespace seavio::odometry {

/// Right-image alignments of one reference frame's points, by point index.
class ReferenceAlignments {
 public:
  /// Starts over for reference `key` (a keyframe's id) with `n` points; no allocation once
  /// the buffers have grown to the largest frame.
  void reset(uint64_t key, std::size_t n);
  /// True when the entries belong to reference `key`.
  bool holds(uint64_t key) const { return valid_ && key_ == key; }

  enum class State : uint8_t { kUnknown, kFailed, kAligned };
  State state(std::size_t i) const { return i < state_.size() ? state_[i] : State::kUnknown; }
  bool knownToFail(std::size_t i) const { return state(i) == State::kFailed; }
  const Eigen::Vector2f& uvRight(std::size_t i) const { return uv_right_[i]; }
  void set(std::size_t i, bool aligned, const Eigen::Vector2f& uv_right);

 private:
  bool valid_ = false;
  uint64_t key_ = 0;
  std::vector<State> state_;
  std::vector<Eigen::Vector2f> uv_right_;
};

/// Point i's reference-left template `tmpl` (made by the caller, so that it is built in place:
/// it is 11 KB) aligned in the reference right image from `uv_right`: its position there into
/// `aligned_uv_right`, or false when the template or the alignment fails. `cache` (may be null:
/// the reference is the previous frame, seen once) holds the points already tried against this
/// reference; a caller may skip making the template of a point `cache` knows to fail.
bool alignInReferenceRight(std::size_t i, const matching::PatchTemplate& tmpl, const cv::Mat& ref_right,
                           const Eigen::Vector2f& uv_right, const matching::PatchAlignParams& params,
                           ReferenceAlignments* cache, Eigen::Vector2f& aligned_uv_right);

}  // namespace seavio::odometry
