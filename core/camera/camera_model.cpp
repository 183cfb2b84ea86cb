#include "core/camera/camera_model.hpp"

#include <cmath>

namespace seavio::camera {
namespace {

/// Normalised undistorted (x, y) -> normalised distorted coordinates.
Eigen::Vector2d distort(const CameraIntrinsics& c, const Eigen::Vector2d& xy) {
  const auto& d = c.distortion;
  const double x = xy.x(), y = xy.y();
  switch (c.model) {
    case DistortionModel::kNone:
      return xy;
    case DistortionModel::kRadialTangential: {
      const double r2 = x * x + y * y;
      const double radial = 1.0 + d[0] * r2 + d[1] * r2 * r2;
      return {x * radial + 2.0 * d[2] * x * y + d[3] * (r2 + 2.0 * x * x),
              y * radial + d[2] * (r2 + 2.0 * y * y) + 2.0 * d[3] * x * y};
    }
    case DistortionModel::kEquidistant: {
      const double r = std::sqrt(x * x + y * y);
      if (r < 1e-12) return xy;
      const double th = std::atan(r);
      const double th2 = th * th;
      const double th_d = th * (1.0 + th2 * (d[0] + th2 * (d[1] + th2 * (d[2] + th2 * d[3]))));
      return xy * (th_d / r);
    }
  }
  return xy;
}

}  // namespace

Eigen::Vector2d CameraIntrinsics::project(const Eigen::Vector3d& p_C) const {
  const Eigen::Vector2d xd = distort(*this, p_C.head<2>() / p_C.z());
  return {fx * xd.x() + cx, fy * xd.y() + cy};
}

Eigen::Vector2d CameraIntrinsics::undistortToNormalized(const Eigen::Vector2d& uv) const {
  const Eigen::Vector2d target((uv.x() - cx) / fx, (uv.y() - cy) / fy);
  if (model == DistortionModel::kNone) return target;
  // Gauss-Newton on distort(x) = target from x = target. A numeric Jacobian keeps one
  // solver for both models; OpenCV's fixed-point iteration stalls near strong radial
  // distortion at the image corners, which is where round trips must still hold.
  Eigen::Vector2d x = target;
  constexpr double h = 1e-7;
  for (int it = 0; it < 50; ++it) {
    const Eigen::Vector2d r = distort(*this, x) - target;
    if (r.squaredNorm() < 1e-26) break;
    Eigen::Matrix2d J;
    J.col(0) = (distort(*this, x + Eigen::Vector2d(h, 0)) - distort(*this, x - Eigen::Vector2d(h, 0))) / (2 * h);
    J.col(1) = (distort(*this, x + Eigen::Vector2d(0, h)) - distort(*this, x - Eigen::Vector2d(0, h))) / (2 * h);
    const Eigen::Vector2d step = J.fullPivLu().solve(r);
    if (!step.allFinite()) break;
    x -= step;
    if (step.squaredNorm() < 1e-30) break;
  }
  return x;
}

cv::Mat CameraIntrinsics::K() const {
  return (cv::Mat_<double>(3, 3) << fx, 0, cx, 0, fy, cy, 0, 0, 1);
}

cv::Mat CameraIntrinsics::D() const {
  return (cv::Mat_<double>(1, 4) << distortion[0], distortion[1], distortion[2], distortion[3]);
}

std::optional<DistortionModel> parseDistortionModel(const std::string& name) {
  // EuRoC spells them "radial-tangential"/"equidistant", Kalibr "radtan"/"equidistant".
  if (name == "radial-tangential" || name == "radtan" || name == "plumb_bob") return DistortionModel::kRadialTangential;
  if (name == "equidistant" || name == "fisheye" || name == "equi") return DistortionModel::kEquidistant;
  if (name == "none" || name.empty()) return DistortionModel::kNone;
  return std::nullopt;
}

std::string toString(DistortionModel m) {
  switch (m) {
    case DistortionModel::kNone: return "none";
    case DistortionModel::kRadialTangential: return "radial-tangential";
    case DistortionModel::kEquidistant: return "equidistant";
  }
  return "none";
}

}  // namespace seavio::camera
