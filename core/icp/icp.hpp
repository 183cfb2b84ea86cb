#pragma once
/// Robust point-to-point ICP seeded by descriptor correspondences (paper section III-E).
#include <span>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/icp/point_cloud_index.hpp"

namespace seavio::icp {

struct IcpParams {
  int max_iterations = 30;
  /// Nearest-neighbour rejection distance of the first kd-tree iteration [m]; it shrinks by
  /// `shrink_factor` each iteration down to `final_max_distance_m` (paper III-E).
  double initial_max_distance_m = 0.3;
  double final_max_distance_m = 0.02;   ///< [m]
  double shrink_factor = 0.7;
  double huber_delta_m = 0.02;          ///< robust kernel width [m]
  double convergence_translation_m = 1e-5;  ///< step below this (and rotation) => converged [m]
  double convergence_rotation_rad = 1e-6;   ///< [rad]
  int min_correspondences = 12;
  /// Moving further than this from the initial guess is a divergence [m]; <= 0 disables.
  double max_divergence_translation_m = 1.0;
  /// As above for rotation [rad]; <= 0 disables.
  double max_divergence_rotation_rad = 0.5;
};

enum class IcpStatus {
  kOk,                      ///< converged
  kNotConverged,            ///< iteration limit reached; the pose is the last estimate
  kTooFewCorrespondences,   ///< fewer than min_correspondences at some iteration
  kDiverged,                ///< left the divergence limits around the initial guess
  kNumericalFailure,        ///< NaN or a degenerate (e.g. collinear) configuration
  kInvalidInput,            ///< empty clouds, model/index mismatch, non-finite initial guess
};

/// Short name of a status for logs ("ok", "diverged", ...).
const char* toString(IcpStatus s);

struct IcpResult {
  IcpStatus status = IcpStatus::kInvalidInput;
  /// Maps data points into the model frame [m]. On failure it holds the initial guess.
  Eigen::Isometry3d T_model_data = Eigen::Isometry3d::Identity();
  int iterations = 0;  ///< alignment steps done (the seeded one included)
  int inliers = 0;     ///< correspondences of the last step
  double rms_m = 0;    ///< RMS distance of those correspondences [m]
  /// Covariance of the left perturbation T = exp(d) * T_model_data, d = (rotation [rad],
  /// translation [m]) in the model frame, from the Gauss-Newton normal equations scaled by
  /// the residual variance. Identity on failure.
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity();
};

/// One correspondence of an ICP step: a data point (data frame), its model point, its weight.
struct IcpPair {
  Eigen::Vector3d d;
  Eigen::Vector3d m;
  double w = 1.0;
};

/// alignIcp's scratch, kept by a caller that aligns every frame so that a frame's ICP does not
/// call the heap once the buffers have their size.
struct IcpWorkspace {
  std::vector<IcpPair> pairs;
  std::vector<double> residuals_m;
};

/// Aligns `data` to `model` (paper section III-E). The first step uses
/// `seed_correspondences` (data index, model index) from descriptor matches when at least
/// `min_correspondences` of them are valid; every later step pairs each transformed data point
/// with its nearest model point from `model_index` within a threshold that shrinks each step.
/// Each step is a Huber-weighted closed-form (Horn/Umeyama) alignment.
/// @param model_index kd-tree built over exactly `model`
[[nodiscard]] IcpResult alignIcp(std::span<const Eigen::Vector3f> data,
                                 std::span<const Eigen::Vector3f> model,
                                 const PointCloudIndex& model_index,
                                 std::span<const std::pair<int, int>> seed_correspondences,
                                 const Eigen::Isometry3d& T_model_data_init,
                                 const IcpParams& params);
/// As above, with the caller's scratch.
[[nodiscard]] IcpResult alignIcp(std::span<const Eigen::Vector3f> data,
                                 std::span<const Eigen::Vector3f> model,
                                 const PointCloudIndex& model_index,
                                 std::span<const std::pair<int, int>> seed_correspondences,
                                 const Eigen::Isometry3d& T_model_data_init,
                                 const IcpParams& params, IcpWorkspace& workspace);

}  // namespace seavio::icp
