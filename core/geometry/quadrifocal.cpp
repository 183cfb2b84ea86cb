#include "core/geometry/quadrifocal.hpp"

#include <cmath>
#include <limits>

namespace seavio::geometry {
namespace {

int leviCivita(int i, int j, int k) {
  if (i == j || j == k || i == k) return 0;
  return ((j - i + 3) % 3 == 1) ? 1 : -1;
}

/// M_{pw} = x^i eps_{ipw}: column w is a line through x (H&Z 17.2 uses these line pairs).
Eigen::Matrix3d lineMatrix(const Eigen::Vector3d& x) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  for (int p = 0; p < 3; ++p)
    for (int w = 0; w < 3; ++w)
      for (int i = 0; i < 3; ++i) m(p, w) += x[i] * leviCivita(i, p, w);
  return m;
}

CameraMatrix kTimes(const camera::RectifiedRig& rig, const Eigen::Matrix<double, 3, 4>& Rt) {
  Eigen::Matrix3d K;
  K << rig.f_px, 0, rig.cx, 0, rig.f_px, rig.cy, 0, 0, 1;
  return K * Rt;
}

}  // namespace

QuadCameras quadCameras(const camera::RectifiedRig& rig, const Eigen::Isometry3d& T_prev_curr) {
  QuadCameras c;
  Eigen::Matrix<double, 3, 4> Rt = Eigen::Matrix<double, 3, 4>::Zero();
  Rt.leftCols<3>().setIdentity();
  c.P[kLeftPrev] = kTimes(rig, Rt);
  Rt(0, 3) = -rig.baseline_m;
  c.P[kRightPrev] = kTimes(rig, Rt);
  const Eigen::Isometry3d T_curr_prev = T_prev_curr.inverse();
  Rt.leftCols<3>() = T_curr_prev.linear();
  Rt.col(3) = T_curr_prev.translation();
  c.P[kLeftCurr] = kTimes(rig, Rt);
  Rt(0, 3) -= rig.baseline_m;
  c.P[kRightCurr] = kTimes(rig, Rt);
  return c;
}

QuadrifocalTensor::QuadrifocalTensor(const QuadCameras& cams) {
  Eigen::Matrix4d m;
  for (int p = 0; p < 3; ++p)
    for (int q = 0; q < 3; ++q)
      for (int r = 0; r < 3; ++r)
        for (int s = 0; s < 3; ++s) {
          m.row(0) = cams.P[0].row(p);
          m.row(1) = cams.P[1].row(q);
          m.row(2) = cams.P[2].row(r);
          m.row(3) = cams.P[3].row(s);
          q_[index(p, q, r, s)] = m.determinant();
        }
}

double QuadrifocalTensor::norm() const {
  double s = 0;
  for (double v : q_) s += v * v;
  return std::sqrt(s);
}

Eigen::Matrix<double, 81, 1> QuadrifocalTensor::constraints(const Eigen::Vector3d& x0,
                                                            const Eigen::Vector3d& x1,
                                                            const Eigen::Vector3d& x2,
                                                            const Eigen::Vector3d& x3) const {
  const Eigen::Matrix3d M0 = lineMatrix(x0), M1 = lineMatrix(x1), M2 = lineMatrix(x2),
                        M3 = lineMatrix(x3);
  // Contract one index at a time: 4 x 243 products instead of 81 x 81 x 16.
  std::array<double, 81> a{}, b{};
  for (int w = 0; w < 3; ++w)
    for (int q = 0; q < 3; ++q)
      for (int r = 0; r < 3; ++r)
        for (int s = 0; s < 3; ++s) {
          double acc = 0;
          for (int p = 0; p < 3; ++p) acc += M0(p, w) * q_[index(p, q, r, s)];
          a[index(w, q, r, s)] = acc;
        }
  for (int w = 0; w < 3; ++w)
    for (int x = 0; x < 3; ++x)
      for (int r = 0; r < 3; ++r)
        for (int s = 0; s < 3; ++s) {
          double acc = 0;
          for (int q = 0; q < 3; ++q) acc += M1(q, x) * a[index(w, q, r, s)];
          b[index(w, x, r, s)] = acc;
        }
  for (int w = 0; w < 3; ++w)
    for (int x = 0; x < 3; ++x)
      for (int y = 0; y < 3; ++y)
        for (int s = 0; s < 3; ++s) {
          double acc = 0;
          for (int r = 0; r < 3; ++r) acc += M2(r, y) * b[index(w, x, r, s)];
          a[index(w, x, y, s)] = acc;
        }
  Eigen::Matrix<double, 81, 1> out;
  for (int w = 0; w < 3; ++w)
    for (int x = 0; x < 3; ++x)
      for (int y = 0; y < 3; ++y)
        for (int z = 0; z < 3; ++z) {
          double acc = 0;
          for (int s = 0; s < 3; ++s) acc += M3(s, z) * a[index(w, x, y, s)];
          out[index(w, x, y, z)] = acc;
        }
  return out;
}

double QuadrifocalTensor::relativeResidual(const Eigen::Vector2d& left_prev,
                                           const Eigen::Vector2d& right_prev,
                                           const Eigen::Vector2d& left_curr,
                                           const Eigen::Vector2d& right_curr) const {
  const Eigen::Vector3d x0 = left_prev.homogeneous(), x1 = right_prev.homogeneous(),
                        x2 = left_curr.homogeneous(), x3 = right_curr.homogeneous();
  const double scale = norm() * x0.norm() * x1.norm() * x2.norm() * x3.norm();
  if (!(scale > 0) || !std::isfinite(scale)) return std::numeric_limits<double>::infinity();
  return constraints(x0, x1, x2, x3).norm() / scale;
}

}  // namespace seavio::geometry
