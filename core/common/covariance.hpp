#pragma once
/// The 6x6 covariance type of a pose (tangent order rotation [rad], translation [m], as in
/// se3.hpp) and what every estimator does with one.
#include <Eigen/Core>
#include <Eigen/Eigenvalues>

namespace seavio {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

/// The nearest positive semi-definite matrix to the symmetric part of square `A` (negative
/// eigenvalues cut to 0): a difference of two covariances, or one a long run of Joseph-form
/// updates rounded, is one only up to rounding and the approximations that made it.
template <typename Derived>
typename Derived::PlainObject positivePart(const Eigen::MatrixBase<Derived>& A) {
  using Matrix = typename Derived::PlainObject;
  const Eigen::SelfAdjointEigenSolver<Matrix> es(Matrix(0.5 * (A + A.transpose())));
  return es.eigenvectors() * es.eigenvalues().cwiseMax(0.0).asDiagonal() * es.eigenvectors().transpose();
}

}  // namespace seavio
