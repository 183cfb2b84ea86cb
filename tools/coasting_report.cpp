#include "tools/coasting_report.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>

#include <spdlog/fmt/fmt.h>

namespace seavio::tools {

namespace {

/// Ground truth at the sample nearest `t_ns`.
const drivers::GroundTruthState& nearestTruth(const drivers::Dataset& ds, int64_t t_ns) {
  const auto& gt = ds.ground_truth;
  auto it = std::lower_bound(gt.begin(), gt.end(), t_ns,
                             [](const drivers::GroundTruthState& g, int64_t t) { return g.t_ns < t; });
  if (it == gt.end()) return gt.back();
  if (it != gt.begin() && t_ns - std::prev(it)->t_ns < it->t_ns - t_ns) --it;
  return *it;
}

double positionSigma(const OdometryResult& r) {
  return std::sqrt(std::max(0.0, r.covariance.bottomRightCorner<3, 3>().trace()));
}

}  // namespace

std::vector<LossStretch> readLossStretches(const std::string& dataset_dir) {
  const std::string path = (std::filesystem::path(dataset_dir) / "mav0" / "vision_loss.csv").string();
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open (render the survey with vision-loss stretches)");
  std::vector<LossStretch> out;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.empty() || line[0] == '#') continue;
    std::stringstream ss(line);
    std::string kind, a, b;
    LossStretch s;
    try {
      if (!std::getline(ss, kind, ',') || !std::getline(ss, a, ',') || !std::getline(ss, b, ','))
        throw std::invalid_argument("three fields expected");
      s = {kind, std::stoll(a), std::stoll(b)};
    } catch (const std::exception&) {
      throw std::runtime_error(fmt::format("{}:{}: not 'kind,start_ns,end_ns': '{}'", path, n, line));
    }
    if (s.to_ns <= s.from_ns) throw std::runtime_error(fmt::format("{}:{}: the stretch ends before it starts", path, n));
    out.push_back(s);
  }
  return out;
}

CoastFigures coastFigures(const drivers::Dataset& ds, const std::vector<OdometryResult>& results,
                          const LossStretch& stretch, const std::vector<double>& at_s, double after_s) {
  const int64_t from_ns = stretch.from_ns, to_ns = stretch.to_ns;
  CoastFigures f;
  f.after_s = after_s;
  std::size_t ref = 0;
  bool have_ref = false;
  for (std::size_t i = 0; i < results.size(); ++i) {
    const OdometryResult& r = results[i];
    f.finite = f.finite && r.T_W_B.matrix().allFinite() && r.covariance.allFinite();
    if (r.t_ns < from_ns) {
      ref = i;
      have_ref = true;
    }
  }
  if (!have_ref || ds.ground_truth.empty()) return f;
  const OdometryResult& r0 = results[ref];
  const Eigen::Isometry3d gt0 = nearestTruth(ds, r0.t_ns).T_W_B;
  auto error = [&](const OdometryResult& r) {
    const Eigen::Vector3d est = (r0.T_W_B.inverse() * r.T_W_B).translation();
    const Eigen::Vector3d truth = (gt0.inverse() * nearestTruth(ds, r.t_ns).T_W_B).translation();
    return (est - truth).norm();
  };
  f.sigma_start_m = positionSigma(r0);
  if (const auto& g = nearestTruth(ds, r0.t_ns); g.has_velocity) f.handover_velocity_error_m_s = (r0.v_W - g.v_W).norm();
  const Eigen::Vector3d up_est = r0.T_W_B.rotation().transpose() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d up_true = gt0.rotation().transpose() * Eigen::Vector3d::UnitZ();
  f.handover_tilt_error_rad = std::atan2(up_est.cross(up_true).norm(), up_est.dot(up_true));
  double prev_var = f.sigma_start_m * f.sigma_start_m;
  std::size_t next_at = 0;
  Eigen::Vector3d prev_gt = gt0.translation();
  const int64_t after_ns = to_ns + static_cast<int64_t>(after_s * 1e9);
  for (std::size_t i = ref + 1; i < results.size(); ++i) {
    const OdometryResult& r = results[i];
    if (r.t_ns < to_ns) {
      ++f.frames_in_loss;
      const bool coasting = r.source == PoseSource::kImuOnly;
      f.flagged_in_loss += coasting;
      const double var = positionSigma(r) * positionSigma(r);
      if (coasting && !(var > prev_var)) f.covariance_grows = false;
      prev_var = var;
      f.sigma_end_m = positionSigma(r);
      f.error_end_m = error(r);
      const Eigen::Vector3d p = nearestTruth(ds, r.t_ns).T_W_B.translation();
      f.distance_m += (p - prev_gt).norm();
      prev_gt = p;
      while (next_at < at_s.size() && static_cast<double>(r.t_ns - from_ns) * 1e-9 >= at_s[next_at]) {
        f.error_at_s.push_back(at_s[next_at++]);
        f.error_m.push_back(error(r));
        f.sigma_added_m.push_back(std::sqrt(std::max(0.0, var - f.sigma_start_m * f.sigma_start_m)));
      }
      continue;
    }
    if (f.recovery_s < 0 && r.source == PoseSource::kVision) {
      f.recovery_s = static_cast<double>(r.t_ns - to_ns) * 1e-9;
      const OdometryResult& before = results[i - 1];
      const Eigen::Vector3d est = r.T_W_B.translation() - before.T_W_B.translation();
      const Eigen::Vector3d truth =
          nearestTruth(ds, r.t_ns).T_W_B.translation() - nearestTruth(ds, before.t_ns).T_W_B.translation();
      f.recovery_jump_m = (est - truth).norm();
    }
    if (r.t_ns <= after_ns) f.error_after_m = error(r);
  }
  return f;
}

std::string formatCoastFigures(const std::string& what, const LossStretch& s, const CoastFigures& f) {
  std::string line = fmt::format(
      "{:<28} {:<11} {:5.1f} s: flagged {}/{}, sigma {:.3f} -> {:.3f} m, hand-over velocity error {:.3f} m/s, "
      "tilt error {:.1f} mrad, error",
      what, s.kind, static_cast<double>(s.to_ns - s.from_ns) * 1e-9, f.flagged_in_loss, f.frames_in_loss,
      f.sigma_start_m, f.sigma_end_m, f.handover_velocity_error_m_s, 1e3 * f.handover_tilt_error_rad);
  for (std::size_t i = 0; i < f.error_m.size(); ++i)
    line += fmt::format(" @{:.1f}s {:.3f} (3sigma {:.3f})", f.error_at_s[i], f.error_m[i], 3 * f.sigma_added_m[i]);
  line += fmt::format(" end {:.3f} m ({:.2f} m travelled); vision back after {:.2f} s (jump {:.3f} m), error {:.1f} s "
                      "later {:.3f} m",
                      f.error_end_m, f.distance_m, f.recovery_s, f.recovery_jump_m, f.after_s, f.error_after_m);
  return line;
}

}  // namespace seavio::tools
