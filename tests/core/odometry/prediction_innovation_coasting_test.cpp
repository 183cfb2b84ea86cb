// The search windows after a coasting that was corrected for the leak
// (core/imu/coasting_leak.hpp, odometry.cpp): the corrected state carries no velocity lag, so
// the next prediction misses by the leak's dt^2 / 2 once, not k times the last fix's miss.
#include <gtest/gtest.h>

#include "core/odometry/prediction_innovation.hpp"

namespace seavio::odometry {
namespace prediction_innovation_coasting_test {
namespace {

TEST(PredictionInnovationCoasting, ACorrectedCoastingCentresTheNextWindowsOnItsOwnMissNotKTimesTheFixes) {
  // GIVEN a 1 Hz fix that missed by 0.48 m (the leak a x dt^2 with a = 0.48 m/s^2)
  PredictionInnovation corrected(1.0, 3), bare(1.0, 3);
  corrected.observe(Eigen::Vector3d(0.48, 0.0, 0.0), 1.0);
  bare.observe(Eigen::Vector3d(0.48, 0.0, 0.0), 1.0);
  // WHEN five frames coast, bare or corrected for the leak
  for (int k = 0; k < 5; ++k) {
    bare.coast();
    corrected.coastCorrected(Eigen::Vector3d(0.24, 0.0, 0.0), 1.0);
  }
  // THEN the bare one gave up (stale after 3), the corrected one expects a / 2 x dt^2, scaled
  // with the interval's square like a fix's miss
  EXPECT_EQ(bare.offset(1.0, 0.1), Eigen::Vector3d::Zero());
  EXPECT_NEAR(corrected.offset(1.0, 0.1).x(), 0.24, 1e-12);
  EXPECT_NEAR(corrected.offset(2.0, 0.1).x(), 0.96, 1e-12);
  // AND a fix afterwards measures the miss again
  corrected.observe(Eigen::Vector3d(0.0, 0.3, 0.0), 1.0);
  EXPECT_NEAR(corrected.offset(1.0, 0.1).y(), 0.3, 1e-12);
  EXPECT_EQ(corrected.offset(1.0, 0.1).x(), 0.0);
}

}  // namespace
}  // namespace prediction_innovation_coasting_test
}  // namespace seavio::odometry
