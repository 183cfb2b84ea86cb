#include "tools/run_stats.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <stdexcept>

#include <spdlog/fmt/fmt.h>

namespace seavio::tools {

double RunStats::percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double idx = std::clamp(p / 100.0, 0.0, 1.0) * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(idx));
  const auto hi = static_cast<std::size_t>(std::ceil(idx));
  return v[lo] + (v[hi] - v[lo]) * (idx - static_cast<double>(lo));
}

const char* coastingName(CoastingCorrection c) {
  switch (c) {
    case CoastingCorrection::kNone: return "none";
    case CoastingCorrection::kInertial: return "inertial";
    case CoastingCorrection::kNoImu: return "no_imu";
    case CoastingCorrection::kHeld: return "held";
  }
  return "unknown";
}

LossCounts countLosses(const std::vector<OdometryResult>& frames) {
  LossCounts n;
  bool in_outage = false;
  for (const OdometryResult& r : frames) {
    const bool lost = r.source == PoseSource::kImuOnly;
    if (lost) {
      const auto kind = std::min(static_cast<std::size_t>(r.coasting), n.frames_by.size() - 1);
      ++n.imu_only_frames;
      ++n.frames_by[kind];
      ++n.refused_by[static_cast<std::size_t>(r.refusal.check)];
      if (!in_outage) {
        ++n.outages;
        ++n.outages_by[kind];
      }
    }
    in_outage = lost;
  }
  return n;
}

double rssGrowthPer1000Frames(const std::vector<MemorySample>& samples, std::size_t from_frames) {
  double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (const MemorySample& m : samples) {
    if (m.frames < from_frames) continue;
    const double x = static_cast<double>(m.frames) / 1000.0;
    n += 1, sx += x, sy += m.rss_mb, sxx += x * x, sxy += x * m.rss_mb;
  }
  const double den = n * sxx - sx * sx;
  if (n < 2 || den <= 0) return 0.0;
  return (n * sxy - sx * sy) / den;
}

void RunStats::printMemory(std::ostream& os) const {
  if (memory_.empty()) return;
  os << "RSS [MiB] after";
  for (const MemorySample& m : memory_) os << fmt::format(" {}: {:.1f};", m.frames, m.rss_mb);
  const std::size_t last = memory_.back().frames;
  os << fmt::format("\nRSS growth over the second half (frames >= {}): {:.2f} MiB per 1000 frames\n", last / 2,
                    rssGrowthPer1000Frames(memory_, last / 2));
}

namespace {

struct Column {
  const char* name;
  std::function<double(const OdometryResult&)> get;
  double paper_local_ms;   ///< paper Table II, local variant (negative: not reported)
  double paper_global_ms;  ///< paper Table II, global variant (negative: not reported)
};

std::vector<Column> columns() {
  return {
      {"rectify", [](const OdometryResult& r) { return r.times.rectify_ms; }, -1, -1},
      {"features (L+R)", [](const OdometryResult& r) { return r.times.features_ms; }, 224, 221},
      {"stereo match", [](const OdometryResult& r) { return r.times.stereo_ms; }, -1, -1},
      {"temporal match", [](const OdometryResult& r) { return r.times.temporal_ms; }, -1, -1},
      {"tensor (RANSAC)", [](const OdometryResult& r) { return r.times.tensor_ms; }, 5, 5},
      {"ICP", [](const OdometryResult& r) { return r.times.icp_ms; }, 37, 3165},
      {"total", [](const OdometryResult& r) { return r.times.total_ms; }, 266, 3391},
  };
}

}  // namespace

void RunStats::printTable(std::ostream& os, PaperVariant variant) const {
  const bool global = variant == PaperVariant::kGlobal;
  os << fmt::format("\nper-stage time over {} frames [ms]   (paper Table II, {}, 2.67 GHz i7)\n", frames_.size(),
                    global ? "global" : "local");
  os << fmt::format("{:<18}{:>10}{:>10}{:>10}{:>12}\n", "stage", "median", "p99", "max", "paper");
  for (const Column& c : columns()) {
    std::vector<double> v;
    v.reserve(frames_.size());
    for (const auto& f : frames_) v.push_back(c.get(f));
    const double paper_ms = global ? c.paper_global_ms : c.paper_local_ms;
    const std::string paper = paper_ms < 0 ? "-" : fmt::format("{:.0f}", paper_ms);
    os << fmt::format("{:<18}{:>10.2f}{:>10.2f}{:>10.2f}{:>12}\n", c.name, percentile(v, 50), percentile(v, 99),
                      percentile(v, 100), paper);
  }
  std::vector<double> feat, stereo, temporal, inliers;
  for (const auto& f : frames_) {
    feat.push_back(f.quality.features_left);
    stereo.push_back(f.quality.stereo_matches);
    temporal.push_back(f.quality.temporal_matches);
    inliers.push_back(f.quality.ransac_inliers);
  }
  const LossCounts losses = countLosses(frames_);
  os << fmt::format("median features {:.0f}, stereo matches {:.0f}, inter-frame matches {:.0f}, RANSAC inliers {:.0f}; "
                    "IMU-only frames {}",
                    percentile(feat, 50), percentile(stereo, 50), percentile(temporal, 50), percentile(inliers, 50),
                    losses.imu_only_frames);
  if (losses.imu_only_frames > 0) {
    // What the losses coasted on: frames (outages) per kind.
    os << fmt::format(" in {} outages:", losses.outages);
    for (int k = 1; k < LossCounts::kKinds; ++k) {
      const auto c = static_cast<CoastingCorrection>(k);
      if (losses.frames(c) > 0)
        os << fmt::format(" {} {} ({})", coastingName(c), losses.frames(c), losses.outagesOf(c));
    }
    os << "; refused by";
    for (int k = 1; k < kRefusalKinds; ++k)
      if (losses.refused_by[static_cast<std::size_t>(k)] > 0)
        os << fmt::format(" {} {}", refusalName(static_cast<Refusal>(k)), losses.refused_by[static_cast<std::size_t>(k)]);
  }
  os << "\n\n";
}

void RunStats::writeJson(const std::string& path) const {
  std::ofstream os(path);
  if (!os) throw std::runtime_error(path + ": cannot open for writing");
  os << "{\n  \"summary\": {";
  bool first = true;
  for (const Column& c : columns()) {
    std::vector<double> v;
    for (const auto& f : frames_) v.push_back(c.get(f));
    os << (first ? "" : ",") << fmt::format("\n    \"{}\": {{\"median_ms\": {:.4f}, \"p99_ms\": {:.4f}}}", c.name,
                                            percentile(v, 50), percentile(v, 99));
    first = false;
  }
  const LossCounts losses = countLosses(frames_);
  os << fmt::format("\n  }},\n  \"losses\": {{\"imu_only_frames\": {}, \"outages\": {}", losses.imu_only_frames,
                    losses.outages);
  for (int k = 1; k < LossCounts::kKinds; ++k) {
    const auto c = static_cast<CoastingCorrection>(k);
    os << fmt::format(", \"{}\": {{\"frames\": {}, \"outages\": {}}}", coastingName(c), losses.frames(c),
                      losses.outagesOf(c));
  }
  os << ", \"refused\": {";
  for (int k = 1; k < kRefusalKinds; ++k)
    os << (k > 1 ? ", " : "")
       << fmt::format("\"{}\": {}", refusalName(static_cast<Refusal>(k)), losses.refused_by[static_cast<std::size_t>(k)]);
  os << "}},\n  \"memory\": [";
  for (std::size_t i = 0; i < memory_.size(); ++i)
    os << (i ? "," : "") << fmt::format("\n    {{\"frames\": {}, \"rss_mb\": {:.2f}}}", memory_[i].frames, memory_[i].rss_mb);
  os << fmt::format("\n  ],\n  \"rss_growth_mb_per_1000_frames_second_half\": {:.4f},",
                    memory_.empty() ? 0.0 : rssGrowthPer1000Frames(memory_, memory_.back().frames / 2));
  os << "\n  \"frames\": [";
  for (std::size_t i = 0; i < frames_.size(); ++i) {
    const auto& f = frames_[i];
    os << (i ? "," : "")
       << fmt::format(
              "\n    {{\"t_ns\": {}, \"seq\": {}, \"source\": {}, \"features_left\": {}, \"features_right\": {}, "
              "\"stereo_matches\": {}, \"temporal_matches\": {}, \"ransac_inliers\": {}, \"icp_iterations\": {}, "
              "\"icp_inliers\": {}, \"icp_rms_m\": {:.6f}, \"model_points\": {}, \"detector_threshold\": {:.3f}, "
              "\"rectify_ms\": {:.3f}, \"features_ms\": {:.3f}, \"stereo_ms\": {:.3f}, \"temporal_ms\": {:.3f}, "
              "\"tensor_ms\": {:.3f}, \"icp_ms\": {:.3f}, \"total_ms\": {:.3f}",
              f.t_ns, f.seq, static_cast<int>(f.source), f.quality.features_left, f.quality.features_right,
              f.quality.stereo_matches, f.quality.temporal_matches, f.quality.ransac_inliers, f.quality.icp_iterations,
              f.quality.icp_inliers, f.quality.icp_rms_m, f.quality.model_points, f.quality.detector_threshold,
              f.times.rectify_ms, f.times.features_ms, f.times.stereo_ms, f.times.temporal_ms, f.times.tensor_ms,
              f.times.icp_ms, f.times.total_ms);
    // What corrected an IMU-only frame's coasting ("none" on visual frames).
    os << fmt::format(", \"coasting\": \"{}\"", coastingName(f.coasting));
    // Which check refused the visual estimate, what it measured and the limit it missed.
    os << fmt::format(", \"refusal\": \"{}\", \"refusal_value\": {:.4g}, \"refusal_limit\": {:.4g}",
                      refusalName(f.refusal.check), f.refusal.value, f.refusal.limit);
    os << fmt::format(", \"guided_tracks\": {}, \"patch_ms\": {:.3f}", f.quality.guided_tracks, f.times.patch_ms);
    os << fmt::format(", \"stereo_completed\": {}", f.quality.stereo_completed);
    // The position sigma the odometry claims (global mode sizes its revisit search by it).
    os << fmt::format(", \"position_sigma_m\": {:.4f}, \"map_refined\": {}",
                      std::sqrt(std::max(f.covariance.bottomRightCorner<3, 3>().trace(), 0.0)),
                      f.quality.map_refined ? 1 : 0);
    if (gyro_bias_.size() == frames_.size() && accel_bias_.size() == frames_.size()) {
      const Eigen::Vector3d& g = gyro_bias_[i];
      const Eigen::Vector3d& a = accel_bias_[i];
      os << fmt::format(", \"gyro_bias_rad_s\": [{:.4e}, {:.4e}, {:.4e}], \"accel_bias_m_s2\": [{:.5f}, {:.5f}, {:.5f}]",
                        g.x(), g.y(), g.z(), a.x(), a.y(), a.z());
    }
    // What the estimate claims, for consistency checks against a simulator's truth.
    const Eigen::Vector3d& sg = f.gyro_bias_sigma_rad_s;
    const Eigen::Vector3d& sa = f.accel_bias_sigma_m_s2;
    os << fmt::format(", \"gyro_bias_sigma_rad_s\": [{:.4e}, {:.4e}, {:.4e}], "
                      "\"accel_bias_sigma_m_s2\": [{:.4e}, {:.4e}, {:.4e}]",
                      sg.x(), sg.y(), sg.z(), sa.x(), sa.y(), sa.z());
    if (!f.increment_covariance.isZero(0.0)) {
      os << ", \"increment_cov\": [";
      for (int r = 0, k = 0; r < 6; ++r)
        for (int c = r; c < 6; ++c, ++k) os << (k ? ", " : "") << fmt::format("{:.6e}", f.increment_covariance(r, c));
      os << "]";
    }
    os << "}";
  }
  os << "\n  ]\n}\n";
}

}  // namespace seavio::tools
