#pragma once
// The core odometry over a dataset the way `seavio run` hands it the IMU: the reference the
// replay tests compare the daemon's poses with.
#include <algorithm>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "core/camera/stereo_rectifier.hpp"
#include "core/odometry/odometry.hpp"
#include "drivers/dataset/dataset.hpp"

namespace seavio::tools::testing_support {

/// Core odometry over the dataset with `seavio run`'s IMU hand-over.
inline std::vector<OdometryResult> runDirectly(const drivers::Dataset& ds) {
  std::string error;
  auto rect = camera::StereoRectifier::create(ds.calibration, &error);
  EXPECT_TRUE(rect) << error;
  odometry::Odometry odo(std::move(*rect), ds.imu_noise, odometry::OdometryParams{}, {});
  std::vector<OdometryResult> out;
  std::size_t cursor = 0;
  for (std::size_t i = 0; i < ds.frames.size(); ++i) {
    const StereoFrame frame = drivers::loadFrame(ds, i);
    const std::size_t begin = cursor > 0 ? cursor - 1 : 0;
    while (cursor < ds.imu.size() && ds.imu[cursor].t_ns <= frame.t_ns) ++cursor;
    const std::size_t end = std::min(ds.imu.size(), cursor + 1);
    out.push_back(odo.process(frame, std::span<const ImuSample>(ds.imu.data() + begin, end - begin)));
  }
  return out;
}

}  // namespace seavio::tools::testing_support
