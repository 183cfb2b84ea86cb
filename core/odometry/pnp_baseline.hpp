#pragma once
/// The comparison baseline named in issue 4: frame-to-frame stereo odometry with PnP-RANSAC
/// on the previous frame's 3D points and the current left image, no IMU, constant-velocity
/// nothing: every frame is matched exhaustively. Not the paper's method; kept to measure it.
#include <optional>

#include "core/common/types.hpp"
#include "core/odometry/frontend.hpp"

namespace seavio::odometry {

struct PnpBaselineParams {
  double reprojection_px = 1.0;
  int iterations = 200;
  int min_inliers = 15;
  double threshold = 0.0;  ///< detector threshold, fixed (no count controller)
};

class PnpBaseline {
 public:
  PnpBaseline(const Frontend& frontend, const PnpBaselineParams& params) : frontend_(frontend), params_(params) {}
  OdometryResult process(const StereoFrame& frame);

 private:
  const Frontend& frontend_;
  PnpBaselineParams params_;
  std::optional<FrameFeatures> previous_;
  Eigen::Isometry3d T_W_R0_ = Eigen::Isometry3d::Identity();
};

}  // namespace seavio::odometry
