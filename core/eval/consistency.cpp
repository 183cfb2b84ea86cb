#include "core/eval/consistency.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>

#include "core/common/se3.hpp"
#include "core/eval/trajectory_metrics.hpp"

namespace seavio::eval {
namespace {

/// The truth at time t: interpolated between neighbours not more than max_interp_gap apart
/// (pose: linear and slerp; biases: linear), else the nearest sample within max_dt.
bool truthAt(const std::vector<TruthSample>& truth, int64_t t, const ConsistencyParams& p, TruthSample& out) {
  const auto it =
      std::lower_bound(truth.begin(), truth.end(), t, [](const TruthSample& a, int64_t v) { return a.t_ns < v; });
  if (it != truth.end() && it->t_ns == t) {
    out = *it;
    return true;
  }
  if (it != truth.begin() && it != truth.end() && it->t_ns - (it - 1)->t_ns <= p.max_interp_gap_ns) {
    const TruthSample& a = *(it - 1);
    const TruthSample& b = *it;
    const double s = double(t - a.t_ns) / double(b.t_ns - a.t_ns);
    out.t_ns = t;
    out.T_W_B = interpolate(a.T_W_B, b.T_W_B, s);
    out.gyro_bias_rad_s = (1 - s) * a.gyro_bias_rad_s + s * b.gyro_bias_rad_s;
    out.accel_bias_m_s2 = (1 - s) * a.accel_bias_m_s2 + s * b.accel_bias_m_s2;
    return true;
  }
  int64_t best = p.max_dt_ns + 1;
  if (it != truth.end() && it->t_ns - t < best) {
    best = it->t_ns - t;
    out = *it;
  }
  if (it != truth.begin() && t - (it - 1)->t_ns < best) {
    best = t - (it - 1)->t_ns;
    out = *(it - 1);
  }
  return best <= p.max_dt_ns;
}

double medianOf(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// e^T C^-1 e, or a negative value when C is not positive definite.
template <int N>
double mahalanobis2(const Eigen::Matrix<double, N, 1>& e, const Eigen::Matrix<double, N, N>& C) {
  const Eigen::LLT<Eigen::Matrix<double, N, N>> llt(0.5 * (C + C.transpose()));
  if (llt.info() != Eigen::Success) return -1;
  return e.dot(llt.solve(e));
}

}  // namespace

IncrementNees incrementNees(const Eigen::Isometry3d& est_prev_curr, const Eigen::Isometry3d& true_prev_curr,
                            const Matrix6d& cov) {
  Eigen::Matrix<double, 6, 1> e;
  e.head<3>() = se3::logSO3(true_prev_curr.rotation().transpose() * est_prev_curr.rotation());
  e.tail<3>() = est_prev_curr.translation() - true_prev_curr.translation();
  IncrementNees n;
  n.full = mahalanobis2<6>(e, cov);
  n.rotation = mahalanobis2<3>(Eigen::Vector3d(e.head<3>()), Eigen::Matrix3d(cov.topLeftCorner<3, 3>()));
  n.translation = mahalanobis2<3>(Eigen::Vector3d(e.tail<3>()), Eigen::Matrix3d(cov.bottomRightCorner<3, 3>()));
  n.ok = e.allFinite() && n.full >= 0 && n.rotation >= 0 && n.translation >= 0;
  return n;
}

ConsistencyFigures evaluateConsistency(const std::vector<TruthSample>& truth,
                                       const std::vector<ConsistencyFrame>& frames, const ConsistencyParams& params) {
  ConsistencyFigures f;
  if (truth.empty() || frames.empty()) return f;
  // A recording that does not know its biases writes zeros: nothing to hold the filter against.
  const bool truth_has_biases = std::any_of(truth.begin(), truth.end(), [](const TruthSample& s) {
    return !s.gyro_bias_rad_s.isZero(0.0) || !s.accel_bias_m_s2.isZero(0.0);
  });
  const auto settle_ns = static_cast<int64_t>(std::llround(params.bias_settle_s * 1e9));
  int within = 0;
  std::vector<double> rotation, translation;
  TruthSample prev_truth;
  bool have_prev_truth = false;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const ConsistencyFrame& fr = frames[i];
    TruthSample t;
    const bool have_truth = truthAt(truth, fr.t_ns, params, t);
    if (have_truth && truth_has_biases && fr.t_ns - frames.front().t_ns >= settle_ns) {
      Eigen::Matrix<double, 6, 1> error, sigma;
      error << fr.gyro_bias_rad_s - t.gyro_bias_rad_s, fr.accel_bias_m_s2 - t.accel_bias_m_s2;
      sigma << fr.gyro_bias_sigma_rad_s, fr.accel_bias_sigma_m_s2;
      if ((sigma.array() > 0).all()) {
        ++f.bias_frames;
        within += (error.array().abs() <= params.bias_sigmas * sigma.array()).all();
      }
    }
    if (i > 0 && have_truth && have_prev_truth && !fr.increment_covariance.isZero(0.0)) {
      const IncrementNees n = incrementNees(frames[i - 1].T_W_B.inverse() * fr.T_W_B,
                                            prev_truth.T_W_B.inverse() * t.T_W_B, fr.increment_covariance);
      if (n.ok) {
        f.nees.push_back(n.full);
        rotation.push_back(n.rotation);
        translation.push_back(n.translation);
      }
    }
    prev_truth = t;
    have_prev_truth = have_truth;
  }
  f.bias_known = f.bias_frames > 0;
  if (f.bias_known) f.bias_within_fraction = double(within) / f.bias_frames;
  f.nees_frames = static_cast<int>(f.nees.size());
  if (f.nees_frames > 0) {
    const auto in_band = std::count_if(f.nees.begin(), f.nees.end(),
                                       [&](double v) { return v >= params.nees_low && v <= params.nees_high; });
    f.nees_in_band_fraction = double(in_band) / f.nees_frames;
  }
  f.nees_median = medianOf(f.nees);
  f.nees_rotation_median = medianOf(rotation);
  f.nees_translation_median = medianOf(translation);
  return f;
}

}  // namespace seavio::eval
