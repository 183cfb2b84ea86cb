// The IMU prediction's systematic miss (core/odometry/prediction_innovation.hpp): a tilt error
// leaks gravity into the prediction, the visual velocity correction leaves a constant miss per
// interval, and the next frame's search windows are centred on the prediction moved by it.
#include <cmath>

#include <gtest/gtest.h>

#include "core/odometry/prediction_innovation.hpp"

namespace seavio::odometry {
namespace prediction_innovation_test {
namespace {

TEST(PredictionInnovation, NothingBeforeAFixNorBelowTheGate) {
  PredictionInnovation p(1.0);
  EXPECT_EQ(p.offset(1.0, 0.1), Eigen::Vector3d::Zero());
  p.observe(Eigen::Vector3d(0.05, 0.0, 0.0), 1.0);  // half a predicted sigma: noise
  EXPECT_EQ(p.offset(1.0, 0.1), Eigen::Vector3d::Zero());
  p.observe(Eigen::Vector3d(0.0, -0.4, 0.0), 1.0);  // four sigmas: a systematic miss
  EXPECT_TRUE(p.offset(1.0, 0.1).isApprox(Eigen::Vector3d(0.0, -0.4, 0.0)));
  PredictionInnovation off(0.0);  // gate 0 turns it off
  off.observe(Eigen::Vector3d(0.0, -0.4, 0.0), 1.0);
  EXPECT_EQ(off.offset(1.0, 0.1), Eigen::Vector3d::Zero());
}

TEST(PredictionInnovation, ScalesWithTheSquareOfTheInterval) {
  PredictionInnovation p(1.0);
  p.observe(Eigen::Vector3d(0.3, 0.0, 0.0), 1.0);
  EXPECT_NEAR(p.offset(2.0, 0.1).x(), 1.2, 1e-12);
  EXPECT_NEAR(p.offset(0.5, 0.01).x(), 0.075, 1e-12);
}

TEST(PredictionInnovation, GrowsWhileCoastingThenGivesUp) {
  PredictionInnovation p(1.0, 2);
  p.observe(Eigen::Vector3d(0.4, 0.0, 0.0), 1.0);
  p.coast();
  EXPECT_NEAR(p.offset(1.0, 0.1).x(), 0.8, 1e-12);
  p.coast();
  EXPECT_NEAR(p.offset(1.0, 0.1).x(), 1.2, 1e-12);
  p.coast();  // stale: the whole-image search is the fallback
  EXPECT_EQ(p.offset(1.0, 0.1), Eigen::Vector3d::Zero());
  p.observe(Eigen::Vector3d(0.4, 0.0, 0.0), 1.0);
  EXPECT_NEAR(p.offset(1.0, 0.1).x(), 0.4, 1e-12);
  p.reset();
  EXPECT_EQ(p.offset(1.0, 0.1), Eigen::Vector3d::Zero());
}

// The odometry's loop in one axis: IMU dead reckoning with a constant acceleration error (the
// gravity leak g * tilt), a visual fix each interval that sets the position and corrects the
// velocity by the miss over dt (odometry.cpp). The miss settles at a_err * dt^2, and the
// offset predicts it, so the windows' centre lands within a small fraction of it.
TEST(PredictionInnovation, CancelsTheGravityLeakOfAOneHertzSurvey) {
  const double g = 9.81, tilt = 1.8 * M_PI / 180.0, a_err = g * std::sin(tilt), dt = 1.0, v_true = 1.5;
  PredictionInnovation inn(1.0);
  double p = 0, v = v_true + 0.2;  // a start velocity error too
  double raw_miss = 0, centred_miss = 0;
  for (int k = 1; k <= 20; ++k) {
    const double p_true = v_true * dt * k;
    const double p_pred = p + v * dt + 0.5 * a_err * dt * dt;
    const double v_pred = v + a_err * dt;
    const double centre = p_pred + inn.offset(dt, 0.093).x();
    raw_miss = std::abs(p_pred - p_true);
    centred_miss = std::abs(centre - p_true);
    const double innovation = p_true - p_pred;
    inn.observe(Eigen::Vector3d(innovation, 0, 0), dt);
    v = v_pred + innovation / dt;
    p = p_true;
  }
  EXPECT_NEAR(raw_miss, a_err * dt * dt, 1e-9);  // ~0.31 m: ~40 px at 4 m, beyond a 3-sigma window
  EXPECT_LT(centred_miss, 0.01 * raw_miss);
}

}  // namespace
}  // namespace prediction_innovation_test
}  // namespace seavio::odometry
