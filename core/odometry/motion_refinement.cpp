#include "core/odometry/motion_refinement.hpp"

#include <cmath>
#include <vector>

#include "core/common/se3.hpp"

namespace seavio::odometry {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

bool triangulate(const camera::RectifiedRig& rig, const Eigen::Vector2f& l, const Eigen::Vector2f& r,
                 Eigen::Vector3d& p) {
  const double d = static_cast<double>(l.x() - r.x());
  if (d < 0.5) return false;
  p = rig.triangulate(Eigen::Vector2d(l.x(), 0.5 * (l.y() + r.y())), d);
  return p.allFinite();
}

/// Projection of p (in the target camera R0) into left and right; Jacobian wrt p.
void project(const camera::RectifiedRig& rig, const Eigen::Vector3d& p, Eigen::Vector4d& uv,
             Eigen::Matrix<double, 4, 3>& J) {
  const double iz = 1.0 / p.z(), f = rig.f_px;
  uv << f * p.x() * iz + rig.cx, f * p.y() * iz + rig.cy, f * (p.x() - rig.baseline_m) * iz + rig.cx,
      f * p.y() * iz + rig.cy;
  J << f * iz, 0, -f * p.x() * iz * iz,  //
      0, f * iz, -f * p.y() * iz * iz,   //
      f * iz, 0, -f * (p.x() - rig.baseline_m) * iz * iz,  //
      0, f * iz, -f * p.y() * iz * iz;
}

}  // namespace

MotionRefinementResult refineMotion(const camera::RectifiedRig& rig, std::span<const geometry::QuadMatch> matches,
                                    std::span<const uint32_t> inliers, const Eigen::Isometry3d& T_prev_curr_init,
                                    const RotationPrior& prior, const MotionRefinementParams& params) {
  MotionRefinementResult out;
  out.T_prev_curr = T_prev_curr_init;
  struct Obs {
    Eigen::Vector3d X_prev, Y_curr;
    Eigen::Vector4d uv_prev, uv_curr;
  };
  std::vector<Obs> obs;
  obs.reserve(inliers.size());
  for (uint32_t i : inliers) {
    const auto& m = matches[i];
    Obs o;
    if (!triangulate(rig, m.left_prev, m.right_prev, o.X_prev) || !triangulate(rig, m.left_curr, m.right_curr, o.Y_curr))
      continue;
    o.uv_prev << m.left_prev.x(), m.left_prev.y(), m.right_prev.x(), m.right_prev.y();
    o.uv_curr << m.left_curr.x(), m.left_curr.y(), m.right_curr.x(), m.right_curr.y();
    obs.push_back(o);
  }
  if (obs.size() < 6) return out;

  const double w_px = 1.0 / params.pixel_sigma_px;
  Eigen::Matrix3d prior_info = Eigen::Matrix3d::Zero();
  if (prior.valid) {
    Eigen::Matrix3d C = prior.covariance;
    C += Eigen::Matrix3d::Identity() * params.min_rotation_sigma_rad * params.min_rotation_sigma_rad;
    prior_info = C.inverse();
  }
  Eigen::Isometry3d T = T_prev_curr_init;
  Matrix6d H = Matrix6d::Identity();
  double sq_sum = 0;
  int n_res = 0;
  for (int it = 0; it < params.iterations; ++it) {
    H.setZero();
    Vector6d g = Vector6d::Zero();
    sq_sum = 0;
    n_res = 0;
    const Eigen::Isometry3d Tinv = T.inverse();
    const Eigen::Matrix3d R = T.rotation();
    for (const Obs& o : obs) {
      // Forward: X_prev -> current camera: p = T^-1 X. Perturbation T = exp(d) T gives
      // p = T^-1 exp(-d) X: dp/d(rot) = Tinv.R * [X]x, dp/d(trans) = -Tinv.R.
      {
        const Eigen::Vector3d p = Tinv * o.X_prev;
        if (p.z() <= 0.05) continue;
        Eigen::Vector4d uv;
        Eigen::Matrix<double, 4, 3> Jp;
        project(rig, p, uv, Jp);
        Eigen::Matrix<double, 3, 6> dp;
        dp.leftCols<3>() = R.transpose() * se3::skew(o.X_prev);
        dp.rightCols<3>() = -R.transpose();
        const Eigen::Matrix<double, 4, 6> J = Jp * dp;
        const Eigen::Vector4d r = uv - o.uv_curr;
        for (int k = 0; k < 4; ++k) {
          const double a = std::abs(r[k]);
          const double w = (a <= params.huber_px ? 1.0 : params.huber_px / a) * w_px * w_px;
          H += w * J.row(k).transpose() * J.row(k);
          g += w * J.row(k).transpose() * r[k];
          sq_sum += r[k] * r[k];
          ++n_res;
        }
      }
      // Backward: Y_curr -> previous camera: q = exp(d) T Y; dq/d(rot) = -[TY]x, dq/d(trans) = I.
      {
        const Eigen::Vector3d q = T * o.Y_curr;
        if (q.z() <= 0.05) continue;
        Eigen::Vector4d uv;
        Eigen::Matrix<double, 4, 3> Jq;
        project(rig, q, uv, Jq);
        Eigen::Matrix<double, 3, 6> dq;
        dq.leftCols<3>() = -se3::skew(q);
        dq.rightCols<3>() = Eigen::Matrix3d::Identity();
        const Eigen::Matrix<double, 4, 6> J = Jq * dq;
        const Eigen::Vector4d r = uv - o.uv_prev;
        for (int k = 0; k < 4; ++k) {
          const double a = std::abs(r[k]);
          const double w = (a <= params.huber_px ? 1.0 : params.huber_px / a) * w_px * w_px;
          H += w * J.row(k).transpose() * J.row(k);
          g += w * J.row(k).transpose() * r[k];
          sq_sum += r[k] * r[k];
          ++n_res;
        }
      }
    }
    // The two directions see the same measurements twice: halve their information.
    H *= 0.5;
    g *= 0.5;
    if (prior.valid) {
      // r = Log(R_prior^T exp(d) R) ~ Log(R_prior^T R) + R_prior^T d  (d small, left perturbation)
      const Eigen::Vector3d r = se3::logSO3(prior.R_prev_curr.transpose() * R);
      const Eigen::Matrix3d J = R.transpose();
      H.topLeftCorner<3, 3>() += J.transpose() * prior_info * J;
      g.head<3>() += J.transpose() * prior_info * r;
    }
    const Vector6d delta = -H.ldlt().solve(g);
    if (!delta.allFinite()) return out;
    Eigen::Isometry3d dT = Eigen::Isometry3d::Identity();
    dT.linear() = se3::expSO3(delta.head<3>());
    dT.translation() = delta.tail<3>();
    T = dT * T;
    if (delta.head<3>().norm() < 1e-9 && delta.tail<3>().norm() < 1e-8) break;
  }
  if (n_res == 0 || !T.matrix().allFinite()) return out;
  out.ok = true;
  out.T_prev_curr = T;
  out.rms_px = std::sqrt(sq_sum / n_res);
  out.covariance = H.inverse();
  return out;
}

}  // namespace seavio::odometry
