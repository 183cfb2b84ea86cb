#include <random>

#include <gtest/gtest.h>

#include "core/common/se3.hpp"

namespace seavio {

TEST(Se3, ExpLogRoundTrip) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  for (int i = 0; i < 100; ++i) {
    se3::Vector6d xi;
    for (int k = 0; k < 6; ++k) xi[k] = u(rng);
    const se3::Vector6d back = se3::logSE3(se3::expSE3(xi));
    EXPECT_LT((back - xi).norm(), 1e-9) << xi.transpose();
  }
}

TEST(Se3, RightJacobianMatchesFiniteDifference) {
  // GIVEN a rotation vector and a small perturbation
  const Eigen::Vector3d w(0.3, -0.2, 0.5);
  const Eigen::Vector3d d(1e-6, -2e-6, 1.5e-6);
  // WHEN the perturbed exp is compared with exp(w) * exp(Jr d)
  const Eigen::Matrix3d lhs = se3::expSO3(w + d);
  const Eigen::Matrix3d rhs = se3::expSO3(w) * se3::expSO3(se3::rightJacobianSO3(w) * d);
  // THEN they agree to second order
  EXPECT_LT((lhs - rhs).norm(), 1e-11);
}

TEST(Se3, RowMajorParsingKeepsTranslationAndOrthonormalises) {
  const double d[16] = {0, -1, 0, 1.5, 1, 0, 0, -2, 0, 0, 1.0000001, 3, 0, 0, 0, 1};
  const Eigen::Isometry3d T = se3::fromRowMajor4x4(d);
  EXPECT_NEAR((T.rotation() * T.rotation().transpose() - Eigen::Matrix3d::Identity()).norm(), 0, 1e-12);
  EXPECT_EQ(T.translation(), Eigen::Vector3d(1.5, -2, 3));
  EXPECT_NEAR(T.rotation()(1, 0), 1.0, 1e-6);
}

}  // namespace seavio
