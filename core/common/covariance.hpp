#pragma once
/// The 6x6 covariance type of a pose (tangent order rotation [rad], translation [m], as in
/// se3.hpp) and what every estimator does with one.
#include <Eigen/Core>
#include <Eigen/Eigenvalues>

namespace seavio {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

/// The nearest positive semi-definite matrix to the symmetric part of `A` (negative
/// eigenvalues cut to 0): a difference of two covariances is one only up to rounding and the
/// approximations that made them.
inline Matrix6d positivePart(const Matrix6d& A) {
  const Eigen::SelfAdjointEigenSolver<Matrix6d> es(0.5 * (A + A.transpose()));
  return es.eigenvectors() * es.eigenvalues().cwiseMax(0.0).asDiagonal() * es.eigenvectors().transpose();
}

}  // namespace seavio
