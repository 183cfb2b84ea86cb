#include "core/icp/icp.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/SVD>

#include "core/common/capacity.hpp"

namespace seavio::icp {
namespace {

using Pair = IcpPair;

bool finiteIso(const Eigen::Isometry3d& T) { return T.matrix().allFinite(); }

double huberWeight(double r, double delta) {
  delta = std::max(delta, 1e-9);
  return r <= delta ? 1.0 : delta / r;
}

/// Weighted closed-form rigid alignment (Horn / Umeyama without scale): argmin_T
/// sum w |T d - m|^2. False on degenerate (fewer than 3 non-collinear) input.
bool weightedAlign(const std::vector<Pair>& pairs, Eigen::Isometry3d& T) {
  double W = 0;
  Eigen::Vector3d mu_d = Eigen::Vector3d::Zero(), mu_m = Eigen::Vector3d::Zero();
  for (const Pair& p : pairs) {
    W += p.w;
    mu_d += p.w * p.d;
    mu_m += p.w * p.m;
  }
  if (!(W > 0)) return false;
  mu_d /= W;
  mu_m /= W;
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (const Pair& p : pairs) H += p.w * (p.d - mu_d) * (p.m - mu_m).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d s = svd.singularValues();
  if (!(s[0] > 0) || !(s[1] > 1e-9 * s[0])) return false;
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1.0 : 1.0;
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = svd.matrixV() * D * svd.matrixU().transpose();
  out.translation() = mu_m - out.linear() * mu_d;
  if (!finiteIso(out)) return false;
  T = out;
  return true;
}

double median(std::vector<double>& v) {
  const auto mid = v.begin() + std::ptrdiff_t(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

bool diverged(const Eigen::Isometry3d& T, const Eigen::Isometry3d& init, const IcpParams& p) {
  if (p.max_divergence_translation_m > 0 &&
      (T.translation() - init.translation()).norm() > p.max_divergence_translation_m)
    return true;
  if (p.max_divergence_rotation_rad > 0 &&
      Eigen::AngleAxisd(init.linear().transpose() * T.linear()).angle() >
          p.max_divergence_rotation_rad)
    return true;
  return false;
}

}  // namespace

const char* toString(IcpStatus s) {
  switch (s) {
    case IcpStatus::kOk: return "ok";
    case IcpStatus::kNotConverged: return "not_converged";
    case IcpStatus::kTooFewCorrespondences: return "too_few_correspondences";
    case IcpStatus::kDiverged: return "diverged";
    case IcpStatus::kNumericalFailure: return "numerical_failure";
    case IcpStatus::kInvalidInput: return "invalid_input";
  }
  return "unknown";
}

IcpResult alignIcp(std::span<const Eigen::Vector3f> data, std::span<const Eigen::Vector3f> model,
                   const PointCloudIndex& model_index,
                   std::span<const std::pair<int, int>> seed_correspondences,
                   const Eigen::Isometry3d& T_model_data_init, const IcpParams& params) {
  IcpWorkspace workspace;
  return alignIcp(data, model, model_index, seed_correspondences, T_model_data_init, params, workspace);
}

IcpResult alignIcp(std::span<const Eigen::Vector3f> data, std::span<const Eigen::Vector3f> model,
                   const PointCloudIndex& model_index,
                   std::span<const std::pair<int, int>> seed_correspondences,
                   const Eigen::Isometry3d& T_model_data_init, const IcpParams& params,
                   IcpWorkspace& workspace) {
  IcpResult result;
  const int min_corr = std::max(3, params.min_correspondences);
  if (!finiteIso(T_model_data_init) || data.empty() || model.empty() ||
      model_index.size() != model.size()) {
    result.status = IcpStatus::kInvalidInput;
    if (finiteIso(T_model_data_init)) result.T_model_data = T_model_data_init;
    return result;
  }
  result.T_model_data = T_model_data_init;
  auto fail = [&](IcpStatus s) {
    result.status = s;
    result.T_model_data = T_model_data_init;
    result.covariance.setIdentity();
    return result;
  };

  std::vector<Pair>& pairs = workspace.pairs;
  pairs.clear();
  reserveWithHeadroom(pairs, std::max(data.size(), seed_correspondences.size()));
  std::vector<double>& resid = workspace.residuals_m;
  resid.clear();
  reserveWithHeadroom(resid, seed_correspondences.size());
  Eigen::Isometry3d T = T_model_data_init;

  // Step 1 (III-E): descriptor correspondences fix the coarse alignment independently of the
  // initial guess. They hold outliers, so the step is itself a short IRLS whose Huber width
  // follows the median residual down to huber_delta_m.
  for (const auto& [di, mi] : seed_correspondences) {
    if (di < 0 || mi < 0 || std::size_t(di) >= data.size() || std::size_t(mi) >= model.size())
      continue;
    if (!data[di].allFinite() || !model[mi].allFinite()) continue;
    pairs.push_back({data[di].cast<double>(), model[mi].cast<double>(), 1.0});
  }
  if (int(pairs.size()) >= min_corr) {
    Eigen::Isometry3d Ts = T;
    if (!weightedAlign(pairs, Ts)) return fail(IcpStatus::kNumericalFailure);
    for (int inner = 0; inner < 8; ++inner) {
      resid.clear();
      for (const Pair& p : pairs) resid.push_back((Ts * p.d - p.m).norm());
      const double sigma = 1.4826 * median(resid);
      const double delta = std::max(params.huber_delta_m, sigma);
      const double cut = std::max(3.0 * params.huber_delta_m, 3.0 * sigma);
      int kept = 0;
      for (Pair& p : pairs) {
        const double r = (Ts * p.d - p.m).norm();
        p.w = r <= cut ? huberWeight(r, delta) : 0.0;
        kept += p.w > 0;
      }
      if (kept < min_corr || !weightedAlign(pairs, Ts)) break;
    }
    if (!finiteIso(Ts)) return fail(IcpStatus::kNumericalFailure);
    if (diverged(Ts, T_model_data_init, params)) return fail(IcpStatus::kDiverged);
    T = Ts;
    result.iterations = 1;
  }

  // Steps 2..n: nearest neighbours with a shrinking rejection threshold.
  double threshold = params.initial_max_distance_m;
  const double final_threshold = std::min(params.final_max_distance_m, threshold);
  bool converged = false;
  auto collect = [&](const Eigen::Isometry3d& Tc, double max_dist) {
    pairs.clear();
    const Eigen::Isometry3f Tf = Tc.cast<float>();
    const float max_d2 = float(max_dist * max_dist);
    for (const Eigen::Vector3f& d : data) {
      uint32_t mi = 0;
      float d2 = 0;
      if (!model_index.nearest(Tf * d, mi, d2) || d2 > max_d2) continue;
      const Eigen::Vector3d dd = d.cast<double>();
      const Eigen::Vector3d mm = model[mi].cast<double>();
      // Residual in double: the float tree distance only gates.
      pairs.push_back({dd, mm, huberWeight((Tc * dd - mm).norm(), params.huber_delta_m)});
    }
  };
  while (result.iterations < params.max_iterations) {
    collect(T, threshold);
    if (int(pairs.size()) < min_corr) return fail(IcpStatus::kTooFewCorrespondences);
    Eigen::Isometry3d Tn = T;
    if (!weightedAlign(pairs, Tn)) return fail(IcpStatus::kNumericalFailure);
    ++result.iterations;
    if (diverged(Tn, T_model_data_init, params)) return fail(IcpStatus::kDiverged);
    const Eigen::Isometry3d step = Tn * T.inverse();
    T = Tn;
    const bool small = step.translation().norm() < params.convergence_translation_m &&
                       Eigen::AngleAxisd(step.linear()).angle() < params.convergence_rotation_rad;
    if (small && threshold <= final_threshold) {
      converged = true;
      break;
    }
    threshold = std::max(final_threshold, threshold * params.shrink_factor);
  }

  // Statistics and covariance at the final pose: r = T d - m, dr/d(rot, trans) = [-[Td]x, I].
  collect(T, threshold);
  if (int(pairs.size()) < min_corr) return fail(IcpStatus::kTooFewCorrespondences);
  Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
  double sse = 0, wsse = 0;
  for (const Pair& p : pairs) {
    const Eigen::Vector3d q = T * p.d;
    const Eigen::Vector3d r = q - p.m;
    Eigen::Matrix<double, 3, 6> J;
    J << 0, q.z(), -q.y(), 1, 0, 0, -q.z(), 0, q.x(), 0, 1, 0, q.y(), -q.x(), 0, 0, 0, 1;
    H += p.w * J.transpose() * J;
    sse += r.squaredNorm();
    wsse += p.w * r.squaredNorm();
  }
  const double n = double(pairs.size());
  const double sigma2 = std::max(wsse / std::max(1.0, 3.0 * n - 6.0), 1e-10);
  const Eigen::Matrix<double, 6, 6> cov =
      sigma2 * H.ldlt().solve(Eigen::Matrix<double, 6, 6>::Identity());
  if (!finiteIso(T) || !cov.allFinite() || !std::isfinite(sse))
    return fail(IcpStatus::kNumericalFailure);
  result.status = converged ? IcpStatus::kOk : IcpStatus::kNotConverged;
  result.T_model_data = T;
  result.inliers = int(pairs.size());
  result.rms_m = std::sqrt(sse / n);
  result.covariance = 0.5 * (cov + cov.transpose());
  return result;
}

}  // namespace seavio::icp
