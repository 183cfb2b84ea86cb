#include "core/eval/trajectory_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <Eigen/SVD>

namespace seavio::eval {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

/// Ground truth at time t: interpolated between neighbours when t falls between two
/// samples not more than max_interp_gap apart, else the nearest within max_dt.
bool groundTruthAt(const std::vector<TimedPose>& gt, int64_t t, const EvalParams& p, Eigen::Isometry3d& out) {
  const auto it = std::lower_bound(gt.begin(), gt.end(), t, [](const TimedPose& a, int64_t v) { return a.t_ns < v; });
  if (it != gt.end() && it->t_ns == t) {
    out = it->T_W_B;
    return true;
  }
  if (it != gt.begin() && it != gt.end()) {
    const TimedPose& a = *(it - 1);
    const TimedPose& b = *it;
    if (b.t_ns - a.t_ns <= p.max_interp_gap_ns) {
      out = interpolate(a.T_W_B, b.T_W_B, double(t - a.t_ns) / double(b.t_ns - a.t_ns));
      return true;
    }
  }
  int64_t best = p.max_dt_ns + 1;
  if (it != gt.end() && it->t_ns - t < best) {
    best = it->t_ns - t;
    out = it->T_W_B;
  }
  if (it != gt.begin() && t - (it - 1)->t_ns < best) {
    best = t - (it - 1)->t_ns;
    out = (it - 1)->T_W_B;
  }
  return best <= p.max_dt_ns;
}

}  // namespace

Eigen::Isometry3d interpolate(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double s) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const Eigen::Quaterniond qa(a.rotation()), qb(b.rotation());
  T.linear() = qa.slerp(s, qb).toRotationMatrix();
  T.translation() = (1.0 - s) * a.translation() + s * b.translation();
  return T;
}

Eigen::Isometry3d alignUmeyama(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const std::size_t n = std::min(src.size(), dst.size());
  if (n == 0) return T;
  Eigen::Vector3d ms = Eigen::Vector3d::Zero(), md = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    ms += src[i];
    md += dst[i];
  }
  ms /= double(n);
  md /= double(n);
  Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < n; ++i) S += (dst[i] - md) * (src[i] - ms).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(S, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) D(2, 2) = -1;
  T.linear() = svd.matrixU() * D * svd.matrixV().transpose();
  T.translation() = md - T.linear() * ms;
  return T;
}

TrajectoryMetrics evaluateTrajectory(const std::vector<TimedPose>& gt, const std::vector<TimedPose>& est,
                                     const EvalParams& params) {
  TrajectoryMetrics m;
  m.gt_poses = int(gt.size());
  m.est_poses = int(est.size());
  if (gt.empty() || est.empty()) return m;

  std::vector<Eigen::Isometry3d> G, E;
  for (const auto& e : est) {
    Eigen::Isometry3d g;
    if (!groundTruthAt(gt, e.t_ns, params, g)) continue;
    G.push_back(g);
    E.push_back(e.T_W_B);
    m.t_ns.push_back(e.t_ns);
  }
  m.associated = int(G.size());

  // Coverage: a ground-truth sample is covered when an estimate lies within 1.5 estimate
  // periods of it (max_dt at least), so a 20 Hz estimate covers 200 Hz truth while a
  // trajectory that stops early or drops a stretch of frames does not.
  std::vector<int64_t> dts;
  for (std::size_t i = 1; i < est.size(); ++i) dts.push_back(est[i].t_ns - est[i - 1].t_ns);
  int64_t period = 0;
  if (!dts.empty()) {
    std::nth_element(dts.begin(), dts.begin() + dts.size() / 2, dts.end());
    period = dts[dts.size() / 2];
  }
  const int64_t cover_dt = std::max<int64_t>(params.max_dt_ns, period * 3 / 2);
  const bool spanned = params.coverage_first_ns <= params.coverage_last_ns;
  int covered = 0, to_cover = 0;
  for (const auto& g : gt) {
    if (g.t_ns >= est.front().t_ns && g.t_ns <= est.back().t_ns) ++m.gt_in_span;
    if (spanned && (g.t_ns < params.coverage_first_ns || g.t_ns > params.coverage_last_ns)) continue;
    ++to_cover;
    const auto it =
        std::lower_bound(est.begin(), est.end(), g.t_ns, [](const TimedPose& a, int64_t v) { return a.t_ns < v; });
    bool near = it != est.end() && it->t_ns - g.t_ns <= cover_dt;
    near = near || (it != est.begin() && g.t_ns - (it - 1)->t_ns <= cover_dt);
    covered += near ? 1 : 0;
  }
  m.coverage = to_cover > 0 ? double(covered) / double(to_cover) : 0.0;
  m.incomplete = m.associated == 0 || m.coverage < params.min_coverage;
  if (G.empty()) return m;

  const std::size_t n = G.size();
  // Paper Table I: align on the first pose only, so the error is the drift accumulated
  // from the start.
  const Eigen::Isometry3d T_align = G[0] * E[0].inverse();
  double sum = 0, sum2 = 0, dist = 0, sum_h = 0, sum_v = 0, sum_yaw = 0, sum_tilt = 0, sum_step2 = 0, sum_gravity_tilt = 0;
  std::vector<double> step_sizes;
  // Turn about W's z of a rotation (R_est R_gt^T, or one truth step): the angle of its action
  // on the horizontal plane (atan2 of the antisymmetric over the symmetric part), exact for a
  // pure heading change and unaffected to first order by roll and pitch.
  const auto turnAboutZ = [](const Eigen::Matrix3d& R) { return std::atan2(R(1, 0) - R(0, 1), R(0, 0) + R(1, 1)); };
  for (std::size_t i = 0; i < n; ++i) {
    if (i > 0) dist += (G[i].translation() - G[i - 1].translation()).norm();
    const Eigen::Isometry3d aligned = T_align * E[i];
    const Eigen::Vector3d e = aligned.translation();
    const Eigen::Vector3d d = e - G[i].translation();
    const double err = d.norm();
    const Eigen::Matrix3d R_err = aligned.linear() * G[i].linear().transpose();
    const double yaw_deg = turnAboutZ(R_err) * 180.0 / std::numbers::pi;
    if (i > 0 && m.t_ns[i] > m.t_ns[i - 1]) {
      const double dt_s = 1e-9 * static_cast<double>(m.t_ns[i] - m.t_ns[i - 1]);
      const double gt_turn_rad = turnAboutZ(G[i].linear() * G[i - 1].linear().transpose());
      if (std::abs(gt_turn_rad) < params.straight_max_turn_rate_rad_s * dt_s) {
        const double step_rad = std::remainder((yaw_deg - m.heading_error_deg.back()) * std::numbers::pi / 180.0,
                                               2 * std::numbers::pi);
        sum_step2 += step_rad * step_rad;
        step_sizes.push_back(std::abs(step_rad));
        ++m.heading_steps;
      }
    }
    // Tilt: where R_err takes the vertical; atan2 of its horizontal over its vertical part
    // stays accurate at small angles, where acos of the dot product would not.
    const Eigen::Vector3d up = R_err.col(2);
    const double tilt_deg = std::atan2(up.head<2>().norm(), up.z()) * 180.0 / std::numbers::pi;
    // Gravity tilt: the body's up as each attitude states it, compared without alignment.
    const Eigen::Vector3d up_est_B = E[i].linear().row(2).transpose(), up_gt_B = G[i].linear().row(2).transpose();
    const double gravity_tilt_deg =
        std::atan2(up_est_B.cross(up_gt_B).norm(), up_est_B.dot(up_gt_B)) * 180.0 / std::numbers::pi;
    sum_gravity_tilt += gravity_tilt_deg;
    m.max_gravity_tilt_error_deg = std::max(m.max_gravity_tilt_error_deg, gravity_tilt_deg);
    m.distance_along_m.push_back(dist);
    m.error_m.push_back(err);
    m.heading_error_deg.push_back(yaw_deg);
    m.tilt_error_deg.push_back(tilt_deg);
    sum_tilt += tilt_deg;
    m.max_tilt_error_deg = std::max(m.max_tilt_error_deg, tilt_deg);
    sum_h += d.head<2>().norm();
    sum_v += std::abs(d.z());
    sum_yaw += std::abs(yaw_deg);
    m.max_heading_error_deg = std::max(m.max_heading_error_deg, std::abs(yaw_deg));
    m.gt_position.push_back(G[i].translation());
    m.est_first_aligned.push_back(e);
    sum += err;
    sum2 += err * err;
    m.max_error_m = std::max(m.max_error_m, err);
  }
  m.mean_error_m = sum / double(n);
  m.mean_horizontal_error_m = sum_h / double(n);
  m.mean_vertical_error_m = sum_v / double(n);
  m.mean_heading_error_deg = sum_yaw / double(n);
  m.mean_tilt_error_deg = sum_tilt / double(n);
  m.mean_gravity_tilt_error_deg = sum_gravity_tilt / double(n);
  if (m.heading_steps > 0) {
    m.heading_step_rms_rad = std::sqrt(sum_step2 / m.heading_steps);
    const auto rank = [&](double q) {
      const auto k = std::min(step_sizes.size() - 1, static_cast<std::size_t>(q * static_cast<double>(step_sizes.size())));
      std::nth_element(step_sizes.begin(), step_sizes.begin() + static_cast<std::ptrdiff_t>(k), step_sizes.end());
      return step_sizes[k];
    };
    m.heading_step_median_rad = rank(0.5);
    m.heading_step_p90_rad = rank(0.9);
  }
  m.std_error_m = std::sqrt(std::max(0.0, sum2 / double(n) - m.mean_error_m * m.mean_error_m));
  m.final_error_m = m.error_m.back();
  m.distance_m = dist;
  if (dist > 0) {
    m.mean_error_pct = 100.0 * m.mean_error_m / dist;
    m.final_error_pct = 100.0 * m.final_error_m / dist;
  }

  // Gravity-referenced: the first position and heading aligned, roll and pitch as published.
  const Eigen::Matrix3d R_heading =
      Eigen::AngleAxisd(turnAboutZ(G[0].linear() * E[0].linear().transpose()), Eigen::Vector3d::UnitZ())
          .toRotationMatrix();
  double sum_gravity = 0, last_gravity = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d e = G[0].translation() + R_heading * (E[i].translation() - E[0].translation());
    last_gravity = (e - G[i].translation()).norm();
    sum_gravity += last_gravity;
  }
  if (dist > 0) {
    m.mean_gravity_error_pct = 100.0 * sum_gravity / double(n) / dist;
    m.final_gravity_error_pct = 100.0 * last_gravity / dist;
  }

  std::vector<Eigen::Vector3d> est_pos(n);
  for (std::size_t i = 0; i < n; ++i) est_pos[i] = E[i].translation();
  const Eigen::Isometry3d T_u = n >= 3 ? alignUmeyama(est_pos, m.gt_position) : T_align;
  double ate2 = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d e = T_u * est_pos[i];
    m.est_umeyama_aligned.push_back(e);
    ate2 += (e - G[i].translation()).squaredNorm();
  }
  m.ate_rmse_m = std::sqrt(ate2 / double(n));

  // Relative pose error over segments of rpe_segment_m of ground-truth travel, from every
  // start pose, normalised by the segment's actual length.
  double rt = 0, rr = 0;
  std::size_t j = 0;
  for (std::size_t i = 0; i < n; ++i) {
    j = std::max(j, i + 1);
    while (j < n && m.distance_along_m[j] - m.distance_along_m[i] < params.rpe_segment_m) ++j;
    if (j >= n) break;
    const double len = m.distance_along_m[j] - m.distance_along_m[i];
    const Eigen::Isometry3d d = (G[i].inverse() * G[j]).inverse() * (E[i].inverse() * E[j]);
    rt += 100.0 * d.translation().norm() / len;
    rr += Eigen::AngleAxisd(d.rotation()).angle() * kRadToDeg / len;
    ++m.rpe_segments;
  }
  if (m.rpe_segments > 0) {
    m.rpe_trans_pct = rt / m.rpe_segments;
    m.rpe_rot_deg_per_m = rr / m.rpe_segments;
  }
  return m;
}

}  // namespace seavio::eval
