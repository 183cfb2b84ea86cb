#pragma once
// Test helper: the stereo features a rig at T_W_B sees of a synthetic floor of world points,
// with exact stereo geometry, pixel noise and each point's fixed descriptor, as the front end
// would hand them to Odometry::track.
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera/rectified_rig.hpp"
#include "core/imu/imu_integrator.hpp"
#include "core/odometry/frontend.hpp"

namespace seavio::odometry::test {

/// A flat synthetic seafloor: points in W and one random unit 64-float descriptor per point.
struct SyntheticFloor {
  std::vector<Eigen::Vector3d> points_W;
  cv::Mat descriptors;  ///< one CV_32F row per point
};

/// `n` points uniform over x in [x_min, x_max], y in [-half_width, half_width] at height
/// `z` [m], drawn from `rng` point by point (x, y, then the 64 descriptor values).
inline SyntheticFloor randomFloor(std::mt19937& rng, int n, double x_min, double x_max, double half_width,
                                  double z) {
  std::uniform_real_distribution<double> ux(x_min, x_max), uy(-half_width, half_width);
  std::normal_distribution<float> gauss(0.f, 1.f);
  SyntheticFloor f;
  f.points_W.resize(static_cast<std::size_t>(n));
  f.descriptors.create(n, 64, CV_32F);
  for (int i = 0; i < n; ++i) {
    f.points_W[static_cast<std::size_t>(i)] = Eigen::Vector3d(ux(rng), uy(rng), z);
    for (int d = 0; d < 64; ++d) f.descriptors.at<float>(i, d) = gauss(rng);
    cv::normalize(f.descriptors.row(i), f.descriptors.row(i));
  }
  return f;
}

/// @param world_W floor points in W; @param world_desc one 64-float descriptor row per point
/// @param pix pixel noise [px], drawn from `rng` in point order (u_left, v_left, u_right)
inline FrameFeatures floorFrame(const camera::RectifiedRig& rig, const std::vector<Eigen::Vector3d>& world_W,
                                const cv::Mat& world_desc, const Eigen::Isometry3d& T_W_B, uint64_t seq,
                                int64_t t_ns, std::normal_distribution<double>& pix, std::mt19937& rng) {
  const Eigen::Isometry3d T_R0_W = (T_W_B * rig.T_B_R0).inverse();
  FrameFeatures ff;
  ff.t_ns = t_ns;
  ff.seq = seq;
  std::vector<int> rows;
  for (int i = 0; i < static_cast<int>(world_W.size()); ++i) {
    const Eigen::Vector3d p = T_R0_W * world_W[static_cast<std::size_t>(i)];
    const Eigen::Vector2d l = rig.project(p, 0), r = rig.project(p, 1);
    if (l.x() < 5 || l.y() < 5 || r.x() < 5 || l.x() > 634 || l.y() > 474) continue;
    matching::StereoPoint sp;
    sp.left_index = sp.right_index = static_cast<int>(rows.size());
    sp.uv_left = Eigen::Vector2f(float(l.x() + pix(rng)), float(l.y() + pix(rng)));
    sp.uv_right = Eigen::Vector2f(float(r.x() + pix(rng)), sp.uv_left.y());
    sp.p_R0 = rig.triangulate(sp.uv_left.cast<double>(), double(sp.uv_left.x() - sp.uv_right.x())).cast<float>();
    ff.stereo.points.push_back(sp);
    ff.left.keypoints.emplace_back(sp.uv_left.x(), sp.uv_left.y(), 9.f);
    rows.push_back(i);
  }
  ff.stereo.descriptors.create(static_cast<int>(rows.size()), 64, CV_32F);
  for (std::size_t k = 0; k < rows.size(); ++k)
    world_desc.row(rows[k]).copyTo(ff.stereo.descriptors.row(static_cast<int>(k)));
  ff.stereo.laplacian_sign.assign(rows.size(), 1);
  ff.left.descriptors = ff.stereo.descriptors;
  ff.right = ff.left;
  return ff;
}

/// The 200 Hz IMU samples of a level vehicle at constant velocity from `next_t_ns` up to one
/// sample past `frame_t_ns` (advancing `next_t_ns`): gravity only on the accelerometer, and
/// `gyro_rad_s` on the gyro from t > 0 (zero before, the still start).
inline std::vector<ImuSample> levelImuUntil(int64_t& next_t_ns, int64_t frame_t_ns, const Eigen::Vector3d& gyro_rad_s) {
  std::vector<ImuSample> imu;
  for (; next_t_ns <= frame_t_ns + 5'000'000; next_t_ns += 5'000'000) {
    ImuSample s;
    s.t_ns = next_t_ns;
    s.gyro_rad_s = next_t_ns > 0 ? gyro_rad_s : Eigen::Vector3d::Zero();
    s.accel_m_s2 = -imu::gravityW();
    imu.push_back(s);
  }
  return imu;
}

}  // namespace seavio::odometry::test
