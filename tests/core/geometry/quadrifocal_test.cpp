#include "core/geometry/quadrifocal.hpp"

#include <random>

#include <gtest/gtest.h>

#include "synthetic_scene.hpp"

namespace seavio::geometry {
namespace {

using testing::makeMotion;
using testing::makeRig;

Eigen::Vector2d dehom(const Eigen::Vector3d& x) { return x.hnormalized(); }

TEST(QuadCameras, ProjectLikeTheRig) {
  // GIVEN a rig, a motion and a point in the previous left frame
  const auto rig = makeRig();
  const Eigen::Isometry3d T = makeMotion();
  const QuadCameras c = quadCameras(rig, T);
  const Eigen::Vector3d X(0.4, -0.3, 4.1);
  const Eigen::Vector3d X_curr = T.inverse() * X;
  // THEN each camera matrix projects it where the rig does
  EXPECT_LT((dehom(c.P[kLeftPrev] * X.homogeneous()) - rig.project(X, 0)).norm(), 1e-9);
  EXPECT_LT((dehom(c.P[kRightPrev] * X.homogeneous()) - rig.project(X, 1)).norm(), 1e-9);
  EXPECT_LT((dehom(c.P[kLeftCurr] * X.homogeneous()) - rig.project(X_curr, 0)).norm(), 1e-9);
  EXPECT_LT((dehom(c.P[kRightCurr] * X.homogeneous()) - rig.project(X_curr, 1)).norm(), 1e-9);
}

TEST(QuadrifocalTensor, TransformsWithDeterminantUnderProjectiveChange) {
  // GIVEN four cameras and a projective change of world coordinates H
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  QuadCameras c = quadCameras(makeRig(), makeMotion());
  Eigen::Matrix4d H;
  for (int i = 0; i < 16; ++i) H(i / 4, i % 4) = u(rng);
  H += 2 * Eigen::Matrix4d::Identity();
  QuadCameras ch = c;
  for (auto& P : ch.P) P = P * H;
  // WHEN both tensors are built
  const QuadrifocalTensor q(c), qh(ch);
  // THEN Q(P H) = det(H) Q(P), entry by entry (the tensor is defined by 4x4 determinants)
  const double d = H.determinant();
  double max_err = 0;
  for (int i = 0; i < 81; ++i) max_err = std::max(max_err, std::abs(qh.data()[i] - d * q.data()[i]));
  EXPECT_LT(max_err, 1e-9 * qh.norm());
  EXPECT_GT(q.norm(), 0);
}

TEST(QuadrifocalTensor, ConstraintsVanishOnTrueCorrespondencesOnly) {
  // GIVEN the tensor of a known motion and exact projections of seafloor points
  const auto rig = makeRig();
  const Eigen::Isometry3d T = makeMotion();
  const QuadrifocalTensor Q(quadCameras(rig, T));
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> ux(-1.5, 1.5), uy(-1.0, 1.0), uz(3.6, 4.4);
  const Eigen::Isometry3d T_curr_prev = T.inverse();
  double worst_true = 0, best_wrong = 1e300;
  for (int k = 0; k < 50; ++k) {
    const Eigen::Vector3d X(ux(rng), uy(rng), uz(rng));
    const Eigen::Vector2d a = rig.project(X, 0), b = rig.project(X, 1),
                          c = rig.project(T_curr_prev * X, 0), d = rig.project(T_curr_prev * X, 1);
    worst_true = std::max(worst_true, Q.relativeResidual(a, b, c, d));
    // WHEN one image point is moved by 3 px (across and along the rows)
    const Eigen::Vector2d shift(2.0, 2.2);
    best_wrong = std::min(best_wrong, Q.relativeResidual(a, b, c + shift, d));
    best_wrong = std::min(best_wrong, Q.relativeResidual(a, b, c, d - shift));
    best_wrong = std::min(best_wrong, Q.relativeResidual(a + shift, b, c, d));
  }
  // THEN true correspondences satisfy all 81 constraints to rounding error
  // and wrong ones leave a residual orders of magnitude larger
  EXPECT_LT(worst_true, 1e-12);
  EXPECT_GT(best_wrong, 1e4 * worst_true);
  EXPECT_GT(best_wrong, 1e-6);
}

TEST(QuadrifocalTensor, ZeroTensorGivesInfiniteResidualNotNaN) {
  const QuadrifocalTensor Q;
  const double r = Q.relativeResidual({1, 2}, {0, 2}, {1, 2}, {0, 2});
  EXPECT_TRUE(std::isinf(r));
}

}  // namespace
}  // namespace seavio::geometry
