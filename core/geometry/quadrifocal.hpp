#pragma once
/// The quadrifocal tensor of two rectified stereo pairs (paper section III-C; Hartley &
/// Zisserman, "Multiple View Geometry", 2nd ed., ch. 17). For a calibrated rig the tensor is
/// fixed by the 6-DoF motion between the pairs, so seavio estimates the motion (see
/// quadrifocal_ransac.hpp) and builds the explicit tensor from it for checks and diagnostics.
#include <array>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/camera/rectified_rig.hpp"

namespace seavio::geometry {

using CameraMatrix = Eigen::Matrix<double, 3, 4>;

/// Index of the four views, in the order the tensor's indices p, q, r, s refer to them.
enum QuadView : int { kLeftPrev = 0, kRightPrev = 1, kLeftCurr = 2, kRightCurr = 3 };

/// The four 3x4 projection matrices of (left_prev, right_prev, left_curr, right_curr), all
/// mapping homogeneous points of the previous left rectified camera frame (R0 at k-1) to
/// homogeneous rectified pixels.
struct QuadCameras {
  std::array<CameraMatrix, 4> P;
};

/// Builds the four camera matrices: left_prev = K[I|0], right_prev = K[I|-b e_x],
/// left_curr = K[R^T | -R^T t], right_curr = left_curr shifted by the baseline.
/// @param T_prev_curr maps points from the current left rectified frame to the previous one [m]
[[nodiscard]] QuadCameras quadCameras(const camera::RectifiedRig& rig,
                                      const Eigen::Isometry3d& T_prev_curr);

/// Explicit 3x3x3x3 quadrifocal tensor, Q^{pqrs} = det[a^p; b^q; c^r; d^s] with a^p the p-th
/// row of the first camera matrix, b^q of the second and so on (H&Z eq. 17.15).
class QuadrifocalTensor {
 public:
  QuadrifocalTensor() { q_.fill(0.0); }
  /// Tensor of four general camera matrices.
  explicit QuadrifocalTensor(const QuadCameras& cams);

  double operator()(int p, int q, int r, int s) const { return q_[index(p, q, r, s)]; }
  /// Frobenius norm of the 81 entries (scale reference for the constraints).
  [[nodiscard]] double norm() const;
  const std::array<double, 81>& data() const { return q_; }

  /// The 81 quadrilinear constraints of one correspondence (H&Z eq. 17.16):
  /// x^i x'^j x''^k x'''^l eps_ipw eps_jqx eps_kry eps_lsz Q^{pqrs} = 0_wxyz, with the points
  /// in homogeneous rectified pixels. Entry (w, x, y, z) is at 27w + 9x + 3y + z.
  [[nodiscard]] Eigen::Matrix<double, 81, 1> constraints(const Eigen::Vector3d& x0,
                                                         const Eigen::Vector3d& x1,
                                                         const Eigen::Vector3d& x2,
                                                         const Eigen::Vector3d& x3) const;

  /// Scale-free size of the constraints: |constraints| / (|Q| |x0| |x1| |x2| |x3|), taking
  /// rectified pixels (u, v) to (u, v, 1). Zero on an exact correspondence; grows with the
  /// geometric error. Returns +inf for a zero tensor.
  [[nodiscard]] double relativeResidual(const Eigen::Vector2d& left_prev,
                                        const Eigen::Vector2d& right_prev,
                                        const Eigen::Vector2d& left_curr,
                                        const Eigen::Vector2d& right_curr) const;

 private:
  static constexpr int index(int p, int q, int r, int s) { return 27 * p + 9 * q + 3 * r + s; }
  std::array<double, 81> q_{};
};

}  // namespace seavio::geometry
