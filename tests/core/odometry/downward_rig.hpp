#pragma once
// Test helper: the simulator's stereo rig (640x480, f = 550 px, 0.32 m baseline) looking straight
// down, image top forward, for odometry tests that build their own synthetic frames.
#include <Eigen/Core>

#include "core/camera/camera_model.hpp"
#include "core/camera/rectified_rig.hpp"

namespace seavio::odometry::test {

inline camera::StereoCalibration downwardRig() {
  camera::StereoCalibration c;
  for (auto* k : {&c.cam0, &c.cam1}) {
    k->width = 640;
    k->height = 480;
    k->fx = k->fy = 550;
    k->cx = 319.5;
    k->cy = 239.5;
  }
  Eigen::Matrix3d R_B_C;
  R_B_C << 0, -1, 0, -1, 0, 0, 0, 0, -1;
  c.T_B_C0.linear() = c.T_B_C1.linear() = R_B_C;
  c.T_B_C0.translation() = Eigen::Vector3d(0.06, 0.16, -0.08);
  c.T_B_C1.translation() = c.T_B_C0.translation() + R_B_C.col(0) * 0.32;
  return c;
}

/// The same rig as the rectifier leaves it (640x480, f = 550 px, 0.32 m baseline), for tests
/// that start from rectified images or pixels.
inline camera::RectifiedRig rectifiedDownwardRig() {
  camera::RectifiedRig rig;
  rig.width = 640;
  rig.height = 480;
  rig.f_px = 550;
  rig.cx = 320;
  rig.cy = 240;
  rig.baseline_m = 0.32;
  return rig;
}

}  // namespace seavio::odometry::test
