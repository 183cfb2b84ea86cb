#pragma once
/// The covariance of the increment between two consecutive frames tracked against one keyframe
/// (local mode, paper III-C against a keyframe). Each frame's motion d_k (left perturbation in
/// the keyframe camera) errs with the keyframe's pixels, which both frames observe through the
/// same points, and with the gyro prior since the keyframe, which the later frame extends; the
/// increment d_k - d_{k-1} sheds that shared error:
///     Cov(d_k - d_{k-1}) = C_k + C_{k-1} - X - X^T,  X = Cov(d_k, d_{k-1}),
/// with X summed over the keyframe points both motions used (their ReferenceSensitivity gains)
/// plus the prior's share. Claiming C_k alone, the whole keyframe-to-frame covariance, makes
/// the increment's claim several times too loose.
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/common/covariance.hpp"
#include "core/odometry/motion_refinement.hpp"

namespace seavio::odometry {

/// The covariance of a camera motion against the reference (left perturbation in the reference
/// camera), carried to the previous frame by `T_prev_ref` (rig frames) and expressed as
/// imu::RelativeMotion's body-frame covariance of the motion `T_prev_curr` (previous <- current rig).
Matrix6d bodyCovarianceSincePrevious(const Matrix6d& covariance_ref, const Eigen::Isometry3d& T_prev_ref,
                                     const Eigen::Isometry3d& T_prev_curr, const Eigen::Isometry3d& T_B_R0);

class KeyframeIncrementCovariance {
 public:
  /// Keeps a frame's motion against keyframe `keyframe_id`: its `sensitivity` (with its
  /// covariance), whose matches are the keyframe points `reference_of_match` (per match index)
  /// out of `reference_points`.
  void record(uint64_t keyframe_id, int64_t t_ns, const ReferenceSensitivity& sensitivity,
              std::span<const uint32_t> reference_of_match, std::size_t reference_points);
  void forget() { recorded_ = false; }

  /// The covariance (left perturbation in the keyframe camera) of the increment from the frame
  /// recorded last to a motion against the same keyframe with `sensitivity`; nullopt unless
  /// that frame is the one at `previous_t_ns` on keyframe `keyframe_id`.
  std::optional<Matrix6d> increment(uint64_t keyframe_id, int64_t previous_t_ns, const ReferenceSensitivity& sensitivity,
                                    std::span<const uint32_t> reference_of_match) const;

 private:
  bool recorded_ = false;
  uint64_t keyframe_id_ = 0;
  int64_t t_ns_ = 0;
  Matrix6d covariance_ = Matrix6d::Zero();
  Eigen::Matrix<double, 6, 3> prior_gain_ = Eigen::Matrix<double, 6, 3>::Zero();
  Eigen::Matrix3d prior_covariance_ = Eigen::Matrix3d::Zero();
  /// Per keyframe point: its gain in the recorded motion, valid where `used_` is set.
  std::vector<Eigen::Matrix<double, 6, 4>> gain_;
  std::vector<uint8_t> used_;
};

}  // namespace seavio::odometry
