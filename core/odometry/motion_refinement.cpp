#include "core/odometry/motion_refinement.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "core/common/capacity.hpp"
#include "core/common/covariance.hpp"
#include "core/common/se3.hpp"

namespace seavio::odometry {
namespace {

using se3::Vector6d;
using Vector8d = Eigen::Matrix<double, 8, 1>;
using Matrix86d = Eigen::Matrix<double, 8, 6>;
using Matrix83d = Eigen::Matrix<double, 8, 3>;
using Matrix23d = Eigen::Matrix<double, 2, 3>;

constexpr double kMinDepthM = 0.05;

bool triangulate(const camera::RectifiedRig& rig, const Eigen::Vector2f& l, const Eigen::Vector2f& r,
                 Eigen::Vector3d& p) {
  const double d = static_cast<double>(l.x() - r.x());
  if (d < 0.5) return false;
  p = rig.triangulate(Eigen::Vector2d(l.x(), 0.5 * (l.y() + r.y())), d);
  return p.allFinite();
}

/// Pixel of `p` (in a rectified left camera) in the left (shift 0) or right (shift b) image.
Eigen::Vector2d project(const camera::RectifiedRig& rig, const Eigen::Vector3d& p, double shift) {
  return {rig.f_px * (p.x() - shift) / p.z() + rig.cx, rig.f_px * p.y() / p.z() + rig.cy};
}

Matrix23d projectJacobian(const camera::RectifiedRig& rig, const Eigen::Vector3d& p, double shift) {
  const double iz = 1.0 / p.z(), f = rig.f_px;
  Matrix23d J;
  J << f * iz, 0, -f * (p.x() - shift) * iz * iz,  //
      0, f * iz, -f * p.y() * iz * iz;
  return J;
}

/// Jp^T diag(w) Jp for a motion Jacobian whose first four rows (the reference pair's pixels,
/// which the motion does not move) are zero. Why not the product expression: at 6x6x8 it is
/// past Eigen's coefficient-based size, and the general matrix product's call, packing and
/// blocking cost several times the arithmetic, once per point and iteration. The sums run in
/// the order that product's kernel gives them on SSE2 without FMA (rows 4-5 of columns 0-3:
/// even and odd k apart, then added; all else in k order), so the two agree to the bit there
/// and the refinement's results do not depend on which one is used.
Matrix6d motionInformation(const Matrix86d& Jp, const Vector8d& w) {
  double a[4][6];  // (Jp^T diag(w))(i, k), k = 4..7
  for (int k = 0; k < 4; ++k)
    for (int i = 0; i < 6; ++i) a[k][i] = Jp(4 + k, i) * w[4 + k];
  Matrix6d H;
  for (int j = 0; j < 6; ++j)
    for (int i = 0; i < 6; ++i) {
      const double t4 = a[0][i] * Jp(4, j), t5 = a[1][i] * Jp(5, j), t6 = a[2][i] * Jp(6, j),
                   t7 = a[3][i] * Jp(7, j);
      if (i >= 4 && j < 4) {
        double even = 0.0, odd = 0.0;
        even += t4;
        odd += t5;
        even += t6;
        odd += t7;
        H(i, j) = even + odd;
      } else {
        double sum = 0.0;
        sum += t4;
        sum += t5;
        sum += t6;
        sum += t7;
        H(i, j) = sum;
      }
    }
  return H;
}

/// Huber cost of one residual [px^2] and its IRLS weight.
double huberCost(double r, double k) {
  const double a = std::abs(r);
  return a <= k ? r * r : 2.0 * k * a - k * k;
}
double huberWeight(double r, double k) {
  const double a = std::abs(r);
  return a <= k ? 1.0 : k / a;
}

/// X: point in the previous left camera, refined with the motion [m]; uv: left/right
/// previous, left/right current [px].
using Obs = MotionRefinementWorkspace::Obs;

}  // namespace

MotionRefinementResult refineMotion(const camera::RectifiedRig& rig, std::span<const geometry::QuadMatch> matches,
                                    std::span<const uint32_t> inliers, const Eigen::Isometry3d& T_prev_curr_init,
                                    const RotationPrior& prior, const MotionRefinementParams& params) {
  MotionRefinementWorkspace ws;
  return refineMotion(rig, matches, inliers, T_prev_curr_init, prior, params, ws);
}

MotionRefinementResult refineMotion(const camera::RectifiedRig& rig, std::span<const geometry::QuadMatch> matches,
                                    std::span<const uint32_t> inliers, const Eigen::Isometry3d& T_prev_curr_init,
                                    const RotationPrior& prior, const MotionRefinementParams& params,
                                    MotionRefinementWorkspace& ws, ReferenceSensitivity* sensitivity) {
  MotionRefinementResult out;
  out.T_prev_curr = T_prev_curr_init;
  std::vector<Obs>& obs = ws.obs;
  obs.clear();
  obs.reserve(inliers.size());
  for (uint32_t i : inliers) {
    if (i >= matches.size()) continue;
    const auto& m = matches[i];
    Obs o;
    o.match = i;
    Eigen::Vector3d Y;
    if (!triangulate(rig, m.left_prev, m.right_prev, o.X) || !triangulate(rig, m.left_curr, m.right_curr, Y))
      continue;
    o.uv << m.left_prev.x(), m.left_prev.y(), m.right_prev.x(), m.right_prev.y(), m.left_curr.x(), m.left_curr.y(),
        m.right_curr.x(), m.right_curr.y();
    obs.push_back(o);
  }
  if (obs.size() < 6) return out;

  // Four-view bundle adjustment: the motion and every point (triangulated in the previous
  // pair) are refined together, the points eliminated by the Schur complement. A transfer
  // error with the triangulated points held fixed treats their depth, the noisiest quantity,
  // as exact; over a flat floor only the depth spread tells surge from pitch, so that depth
  // noise dilutes the translation (regression dilution): steps came out 0.2 % short at
  // 0.1 px and 0.8 % at 0.2 px of pixel noise without the prior, and part of it leaked
  // through the gyro prior. Same reasoning as QuadrifocalRansac::refine (section III-C).
  const double w_px = 1.0 / params.pixel_sigma_px;
  const double w2 = w_px * w_px;
  const double k = params.huber_px;
  const double b = rig.baseline_m;
  Eigen::Matrix3d prior_info = Eigen::Matrix3d::Zero();
  if (prior.valid) {
    Eigen::Matrix3d C = prior.covariance;
    C += Eigen::Matrix3d::Identity() * params.min_rotation_sigma_rad * params.min_rotation_sigma_rad;
    prior_info = C.inverse();
    if (!prior_info.allFinite()) return out;
  }

  // Residuals of one point under motion T (previous <- current): p = T^-1 X in the current pair.
  auto residual = [&](const Eigen::Isometry3d& Tinv, const Obs& o, const Eigen::Vector3d& X, Vector8d& r) {
    const Eigen::Vector3d Y = Tinv * X;
    if (!(X.z() > kMinDepthM) || !(Y.z() > kMinDepthM)) return false;
    r.segment<2>(0) = project(rig, X, 0);
    r.segment<2>(2) = project(rig, X, b);
    r.segment<2>(4) = project(rig, Y, 0);
    r.segment<2>(6) = project(rig, Y, b);
    r -= o.uv;
    return r.allFinite();
  };
  auto priorResidual = [&](const Eigen::Matrix3d& R) -> Eigen::Vector3d {
    return prior.valid ? se3::logSO3(prior.R_prev_curr.transpose() * R) : Eigen::Vector3d::Zero();
  };
  // Robust cost, in units of pixel sigmas squared, plus the prior; sq_sum for the rms.
  auto totalCost = [&](const Eigen::Isometry3d& T, const std::vector<Eigen::Vector3d>& pts, double* sq_sum) {
    const Eigen::Isometry3d Tinv = T.inverse();
    double c = 0, sq = 0;
    Vector8d r;
    for (std::size_t j = 0; j < obs.size(); ++j) {
      if (!residual(Tinv, obs[j], pts[j], r)) return std::numeric_limits<double>::infinity();
      for (int q = 0; q < 8; ++q) c += w2 * huberCost(r[q], k);
      sq += r.squaredNorm();
    }
    const Eigen::Vector3d rp = priorResidual(T.rotation());
    if (sq_sum) *sq_sum = sq;
    return c + rp.dot(prior_info * rp);
  };

  std::vector<Eigen::Vector3d>& points = ws.points;
  std::vector<Eigen::Vector3d>& trial_points = ws.trial_points;
  resizeWithHeadroom(points, obs.size());
  resizeWithHeadroom(trial_points, obs.size());
  for (std::size_t j = 0; j < obs.size(); ++j) points[j] = obs[j].X;
  Eigen::Isometry3d T = T_prev_curr_init;
  double sq_sum = 0;
  double cost = totalCost(T, points, &sq_sum);
  if (!std::isfinite(cost)) return out;

  Matrix6d S;
  Vector6d g;
  // Per-point blocks of the current linearisation, kept for the back-substitution.
  std::vector<Eigen::Matrix3d>& Hll_inv = ws.Hll_inv;
  std::vector<Eigen::Matrix<double, 6, 3>>& Hpl = ws.Hpl;
  std::vector<Eigen::Vector3d>& gl = ws.gl;
  std::vector<Eigen::Matrix<double, 6, 4>>& Gref = ws.Gref;
  resizeWithHeadroom(Hll_inv, obs.size());
  resizeWithHeadroom(Hpl, obs.size());
  resizeWithHeadroom(gl, obs.size());
  std::vector<Eigen::Matrix<double, 6, 4>>& Gcur = ws.Gcur;
  std::vector<double>& residual_dof = ws.residual_dof;
  if (sensitivity) {
    resizeWithHeadroom(Gref, obs.size());
    resizeWithHeadroom(Gcur, obs.size());
    resizeWithHeadroom(residual_dof, obs.size());
  }
  // Under the template-aligned noise model the reference-left pixel carries none (its own
  // error is the template's origin, which the other three follow).
  const int first_noisy = params.template_aligned ? 2 : 0;
  // Left perturbation T = exp(d) T, d = (rotation, translation) in the previous camera:
  // p = T^-1 exp(-d) X gives dp/d(rot) = R^T [X]x, dp/d(trans) = -R^T, dp/dX = R^T.
  // `reference_gains`: also the gradient's reference-pixel part, needed at the solution only.
  auto buildSystem = [&](double damping, bool reference_gains) {
    S.setZero();
    g.setZero();
    const Eigen::Isometry3d Tinv = T.inverse();
    const Eigen::Matrix3d Rt = T.rotation().transpose();
    Vector8d r;
    for (std::size_t j = 0; j < obs.size(); ++j) {
      const Eigen::Vector3d& X = points[j];
      const Eigen::Vector3d Y = Tinv * X;
      residual(Tinv, obs[j], X, r);
      Matrix83d Jl;
      Jl.topRows<2>() = projectJacobian(rig, X, 0);
      Jl.middleRows<2>(2) = projectJacobian(rig, X, b);
      const Matrix23d Jy0 = projectJacobian(rig, Y, 0), Jy1 = projectJacobian(rig, Y, b);
      Jl.middleRows<2>(4) = Jy0 * Rt;
      Jl.bottomRows<2>() = Jy1 * Rt;
      Eigen::Matrix<double, 3, 6> dY;
      dY.leftCols<3>() = Rt * se3::skew(X);
      dY.rightCols<3>() = -Rt;
      Matrix86d Jp = Matrix86d::Zero();
      Jp.middleRows<2>(4) = Jy0 * dY;
      Jp.bottomRows<2>() = Jy1 * dY;
      Vector8d w;
      for (int q = 0; q < 8; ++q) w[q] = w2 * huberWeight(r[q], k);
      Matrix6d Hpp = motionInformation(Jp, w);
      const Eigen::Matrix<double, 6, 3> hpl = Jp.transpose() * w.asDiagonal() * Jl;
      Eigen::Matrix3d Hll = Jl.transpose() * w.asDiagonal() * Jl;
      const Vector8d wr = w.cwiseProduct(r);
      Hpp.diagonal() *= 1.0 + damping;
      Hll.diagonal() *= 1.0 + damping;
      Hll_inv[j] = Hll.inverse();
      Hpl[j] = hpl;
      gl[j] = Jl.transpose() * wr;
      // The reduced gradient's dependence on the reference pixels (rows 0-3): only through the
      // point, whose Jp rows there are zero.
      if (reference_gains) {
        Gref[j] = hpl * Hll_inv[j] * Jl.topRows<4>().transpose() * w.head<4>().asDiagonal();
        // The current pixels' part: through the point and directly (r = projection - uv).
        Gcur[j] = (hpl * Hll_inv[j] * Jl.bottomRows<4>().transpose() - Jp.bottomRows<4>().transpose()) *
                  w.tail<4>().asDiagonal();
        // The residual with the point refit is -(I - Jl Hll^-1 Jl^T W) e: its expected
        // Huber-weighted square under unit noise on the noisy pixels.
        const Eigen::Matrix<double, 8, 8> M =
            Eigen::Matrix<double, 8, 8>::Identity() - Jl * Hll_inv[j] * Jl.transpose() * w.asDiagonal();
        double dof = 0;
        for (int q = first_noisy; q < 8; ++q)
          for (int i = 0; i < 8; ++i) dof += w[i] / w2 * M(i, q) * M(i, q);
        residual_dof[j] = dof;
      }
      S += Hpp - hpl * Hll_inv[j] * hpl.transpose();
      g += Jp.transpose() * wr - hpl * Hll_inv[j] * gl[j];
    }
    if (prior.valid) {
      // r = Log(R_prior^T exp(d) R) ~ Log(R_prior^T R) + R^T d (d small, left perturbation).
      const Eigen::Vector3d rp = priorResidual(T.rotation());
      S.topLeftCorner<3, 3>() += Rt.transpose() * prior_info * Rt;
      g.head<3>() += Rt.transpose() * prior_info * rp;
    }
  };

  double lambda = 1e-4;
  for (int it = 0; it < params.iterations; ++it) {
    buildSystem(lambda, false);
    const Vector6d delta = -S.ldlt().solve(g);
    if (!delta.allFinite()) return out;
    Eigen::Isometry3d dT = Eigen::Isometry3d::Identity();
    dT.linear() = se3::expSO3(delta.head<3>());
    dT.translation() = delta.tail<3>();
    const Eigen::Isometry3d T_trial = dT * T;
    for (std::size_t j = 0; j < obs.size(); ++j)
      trial_points[j] = points[j] - Hll_inv[j] * (gl[j] + Hpl[j].transpose() * delta);
    double trial_sq = 0;
    const double trial = totalCost(T_trial, trial_points, &trial_sq);
    if (trial < cost) {
      T = T_trial;
      points.swap(trial_points);
      cost = trial;
      sq_sum = trial_sq;
      lambda = std::max(lambda * 0.2, 1e-9);
      if (delta.head<3>().norm() < 1e-9 && delta.tail<3>().norm() < 1e-8) break;
    } else {
      lambda *= 10.0;
      if (lambda > 1e8) break;
    }
  }
  if (!T.matrix().allFinite()) return out;
  buildSystem(0.0, sensitivity != nullptr);
  const Matrix6d cov = S.ldlt().solve(Matrix6d::Identity());
  if (!cov.allFinite()) return out;
  out.ok = true;
  out.T_prev_curr = T;
  out.rms_px = std::sqrt(sq_sum / static_cast<double>(8 * obs.size()));
  out.covariance = 0.5 * (cov + cov.transpose());
  if (sensitivity) {
    // The pixels' variance from the residuals: 8 per point less the point's 3 and the
    // motion's 6 degrees of freedom, Huber-weighted as the fit weighs them. Floored so that
    // noise-free input keeps a positive-definite claim.
    const Eigen::Isometry3d Tinv = T.inverse();
    double weighted_sq = 0;
    Vector8d r;
    for (std::size_t j = 0; j < obs.size(); ++j)
      if (residual(Tinv, obs[j], points[j], r))
        for (int q = 0; q < 8; ++q) weighted_sq += huberWeight(r[q], k) * r[q] * r[q];
    double dof = 5.0 * static_cast<double>(obs.size()) - 6.0;
    if (params.template_aligned) {
      dof = -6.0;
      for (std::size_t j = 0; j < obs.size(); ++j) dof += residual_dof[j];
    }
    const double f = std::max(weighted_sq / std::max(dof, 1.0) / (params.pixel_sigma_px * params.pixel_sigma_px), 1e-4);
    // The fit weighs pixels and prior by the model, so its motion errs by the sandwich
    // S^-1 Cov(g) S^-1: the gradient's pixel part f times the model's when every pixel is
    // noisy alike, else summed over the noisy pixels; the prior's as it was.
    Matrix6d S_prior = Matrix6d::Zero();
    if (prior.valid) S_prior.topLeftCorner<3, 3>() = T.rotation() * prior_info * T.rotation().transpose();
    Matrix6d pixel_part = f * (S - S_prior);
    if (params.template_aligned) {
      pixel_part.setZero();
      for (std::size_t j = 0; j < obs.size(); ++j)
        pixel_part += Gref[j].rightCols<2>() * Gref[j].rightCols<2>().transpose() + Gcur[j] * Gcur[j].transpose();
      pixel_part *= f * params.pixel_sigma_px * params.pixel_sigma_px;
    }
    const Matrix6d C = cov * (pixel_part + S_prior) * cov;
    sensitivity->variance_factor = f;
    sensitivity->covariance = 0.5 * (C + C.transpose());
    // d = -S^-1 g: a reference pixel error du (sigma sqrt(f)) moves the motion by S^-1 Gref du,
    // a prior error e (its residual's) by S^-1 [R prior_info e; 0].
    sensitivity->match.resize(obs.size());
    sensitivity->gain.resize(obs.size());
    for (std::size_t j = 0; j < obs.size(); ++j) {
      sensitivity->match[j] = obs[j].match;
      sensitivity->gain[j] = cov * Gref[j] * (params.pixel_sigma_px * std::sqrt(f));
      if (params.template_aligned) sensitivity->gain[j].leftCols<2>().setZero();
    }
    sensitivity->prior_gain.setZero();
    sensitivity->prior_covariance.setZero();
    if (prior.valid) {
      sensitivity->prior_gain = cov.leftCols<3>() * T.rotation() * prior_info;
      sensitivity->prior_covariance = prior_info.inverse();
    }
    if (!C.allFinite()) sensitivity->covariance = out.covariance;
  }
  return out;
}

}  // namespace seavio::odometry
