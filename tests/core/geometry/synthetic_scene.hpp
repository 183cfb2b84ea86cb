#pragma once
// Tiny synthetic stereo scene for the geometry tests: a bumpy seafloor about 4 m below a
// downward-looking rig with the paper's 32 cm baseline.
#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "core/camera/rectified_rig.hpp"
#include "core/geometry/quadrifocal_ransac.hpp"

namespace seavio::geometry::testing {

inline camera::RectifiedRig makeRig() {
  camera::RectifiedRig rig;
  rig.width = 640;
  rig.height = 480;
  rig.f_px = 500;
  rig.cx = 320;
  rig.cy = 240;
  rig.baseline_m = 0.32;
  return rig;
}

/// T_prev_curr of a survey-like step: 15 cm forward, a little drift, a 2 degree turn.
inline Eigen::Isometry3d makeMotion() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(0.035, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitX()) *
                Eigen::AngleAxisd(-0.008, Eigen::Vector3d::UnitY()))
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.15, 0.03, 0.02);
  return T;
}

inline bool inImage(const camera::RectifiedRig& rig, const Eigen::Vector2d& uv) {
  return uv.x() >= 0 && uv.y() >= 0 && uv.x() < rig.width && uv.y() < rig.height;
}

struct Scene {
  std::vector<QuadMatch> matches;
  std::vector<bool> is_inlier;
};

/// `n` matches of seafloor points, `outlier_fraction` of them wrong in the current pair
/// (a consistent stereo observation of another point, as a wrong temporal match would be),
/// with Gaussian pixel noise `noise_px` on every coordinate.
inline Scene makeScene(const camera::RectifiedRig& rig, const Eigen::Isometry3d& T_prev_curr,
                       int n, double outlier_fraction, double noise_px, std::mt19937& rng) {
  std::uniform_real_distribution<double> ux(-1.9, 1.9), uy(-1.4, 1.4), u01(0, 1);
  std::normal_distribution<double> noise(0.0, noise_px);
  const Eigen::Isometry3d T_curr_prev = T_prev_curr.inverse();
  auto observe = [&](const Eigen::Vector3d& X, Eigen::Vector2f& l, Eigen::Vector2f& r) {
    const Eigen::Vector2d pl = rig.project(X, 0), pr = rig.project(X, 1);
    if (!inImage(rig, pl) || !inImage(rig, pr)) return false;
    l = Eigen::Vector2f(float(pl.x() + noise(rng)), float(pl.y() + noise(rng)));
    r = Eigen::Vector2f(float(pr.x() + noise(rng)), float(pr.y() + noise(rng)));
    return true;
  };
  auto seafloor = [&]() {
    const double x = ux(rng), y = uy(rng);
    return Eigen::Vector3d(x, y, 4.0 + 0.2 * std::sin(2.0 * x) * std::cos(1.5 * y));
  };
  Scene s;
  const int n_out = int(std::lround(outlier_fraction * n));
  while (int(s.matches.size()) < n) {
    const bool outlier = int(s.matches.size()) < n_out;
    const Eigen::Vector3d X = seafloor();
    QuadMatch m;
    if (!observe(X, m.left_prev, m.right_prev)) continue;
    const Eigen::Vector3d X_curr = outlier ? T_curr_prev * seafloor() : T_curr_prev * X;
    if (!observe(X_curr, m.left_curr, m.right_curr)) continue;
    s.matches.push_back(m);
    s.is_inlier.push_back(!outlier);
  }
  // Shuffle so that outliers are not grouped.
  for (int i = n - 1; i > 0; --i) {
    const int j = std::uniform_int_distribution<int>(0, i)(rng);
    std::swap(s.matches[i], s.matches[j]);
    const bool t = s.is_inlier[i];
    s.is_inlier[i] = s.is_inlier[j];
    s.is_inlier[j] = t;
  }
  return s;
}

inline double rotationError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
}

inline double translationError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm();
}

}  // namespace seavio::geometry::testing
