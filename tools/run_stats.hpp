#pragma once
/// Per-frame figures of a `seavio run`, summarised as the paper's Table II.
#include <array>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "core/common/types.hpp"

namespace seavio::tools {

/// Process resident size sampled during a run (for the memory goal of `seavio bench`).
struct MemorySample {
  std::size_t frames = 0;  ///< frames processed when sampled
  double rss_mb = 0;       ///< VmRSS [MiB]
};

/// The stats name of what a frame coasted on ("none", "inertial", "no_imu", "held").
const char* coastingName(CoastingCorrection c);

/// The vision losses of a run: IMU-only frames, and outages (runs of
/// consecutive IMU-only frames), each by what it coasted on (an outage by its first frame's).
struct LossCounts {
  static constexpr int kKinds = static_cast<int>(CoastingCorrection::kHeld) + 1;
  int imu_only_frames = 0;
  int outages = 0;
  std::array<int, kKinds> frames_by{};   ///< indexed by CoastingCorrection
  std::array<int, kKinds> outages_by{};  ///< indexed by CoastingCorrection
  std::array<int, kRefusalKinds> refused_by{};  ///< IMU-only frames by the check that refused them
  int frames(CoastingCorrection c) const { return frames_by[static_cast<std::size_t>(c)]; }
  int outagesOf(CoastingCorrection c) const { return outages_by[static_cast<std::size_t>(c)]; }
};
LossCounts countLosses(const std::vector<OdometryResult>& frames);

/// Least-squares slope of resident size over the samples taken at or after `from_frames`
/// [MiB per 1000 frames]; 0 with fewer than two such samples.
double rssGrowthPer1000Frames(const std::vector<MemorySample>& samples, std::size_t from_frames);

class RunStats {
 public:
  void add(const OdometryResult& r) { frames_.push_back(r); }
  std::size_t size() const { return frames_.size(); }
  /// Records the resident size after `frames` frames.
  void addMemorySample(std::size_t frames, double rss_mb) { memory_.push_back({frames, rss_mb}); }
  const std::vector<MemorySample>& memorySamples() const { return memory_; }
  /// Per-frame IMU biases the odometry held (SequenceRun); written beside each frame in the
  /// JSON when there is one per frame.
  void setImuBiases(std::vector<Eigen::Vector3d> gyro_rad_s, std::vector<Eigen::Vector3d> accel_m_s2) {
    gyro_bias_ = std::move(gyro_rad_s);
    accel_bias_ = std::move(accel_m_s2);
  }
  /// The run's vision losses so far.
  LossCounts losses() const { return countLosses(frames_); }
  /// "RSS after 1000 frames ... MiB; growth ..." line(s); nothing without samples.
  void printMemory(std::ostream& os) const;
  /// Which of the paper's Table II columns to print beside ours.
  enum class PaperVariant { kLocal, kGlobal };
  /// Median and p99 per stage, with the paper's figures for `variant` beside ours.
  void printTable(std::ostream& os, PaperVariant variant = PaperVariant::kLocal) const;
  /// One JSON object per frame plus a summary and the losses ("losses": IMU-only frames and
  /// outages by coasting correction; per frame "coasting", coastingName()). Per frame also the
  /// filter's bias sigmas ("gyro_bias_sigma_rad_s", "accel_bias_sigma_m_s2"; zero without IMU)
  /// and, on a visual increment only, "increment_cov": OdometryResult::increment_covariance's
  /// upper triangle row by row (21 values; rotation [rad^2] then translation [m^2]).
  void writeJson(const std::string& path) const;
  /// Percentile (0..100) of a per-frame quantity.
  static double percentile(std::vector<double> v, double p);

 private:
  std::vector<OdometryResult> frames_;
  std::vector<MemorySample> memory_;
  std::vector<Eigen::Vector3d> gyro_bias_, accel_bias_;
};

}  // namespace seavio::tools
