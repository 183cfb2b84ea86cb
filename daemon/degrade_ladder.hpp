#pragma once
/// The per-frame deadline and what the estimator sheds to keep it. A frame is due
/// `frame_budget_ms` after it reached the daemon (66 ms: one frame period at 15 Hz, the
/// paper's camera rate). When the 90th percentile of the last `window_frames` frames'
/// latency (arrival to estimate) exceeds the budget, the ladder climbs one rung; when it
/// falls below `release_fraction` of the budget, it steps down one. Each rung keeps what the
/// rungs below it shed:
///   1 fewer features (the controller aims at `feature_fraction` of its targets),
///   2 no rescue retries for frames the RANSAC rejects,
///   3 no global-step work for tracked frames (the map catches up later).
/// After every change the window starts empty, so each decision reads frames processed
/// under the rung in force.
#include <cstddef>
#include <string_view>
#include <vector>

#include "core/odometry/load_shedding.hpp"

namespace seavio::daemon {

struct DeadlineConfig {
  int frame_budget_ms = 66;      ///< a frame's latency budget, arrival to estimate [ms]
  int window_frames = 30;        ///< frames in the recent p90 (2 s at 15 Hz)
  double release_fraction = 0.75;  ///< p90 below this share of the budget releases a rung
  double feature_fraction = 0.6;   ///< rung 1: share of the feature targets kept
  /// false: misses are counted but nothing is shed (deterministic replay: the poses must
  /// not depend on the host's load).
  bool degrade = true;
};

class DegradeLadder {
 public:
  static constexpr int kTopRung = 3;

  explicit DegradeLadder(const DeadlineConfig& cfg);
  /// Adds one frame's latency [ms]; true if the rung changed.
  bool add(double frame_ms);
  int rung() const { return rung_; }
  /// p90 of the frames in the current window [ms], 0 while it is empty.
  double recentP90Ms() const;
  /// The p90 that made the last change [ms], 0 before any.
  double changeP90Ms() const { return change_p90_ms_; }
  /// What the odometry sheds at `rung`.
  odometry::LoadShedding shedding(int rung) const;
  odometry::LoadShedding shedding() const { return shedding(rung_); }
  static std::string_view rungName(int rung);

 private:
  DeadlineConfig cfg_;
  std::vector<double> window_;  ///< ring of the latest latencies [ms]
  std::size_t next_ = 0;        ///< ring write position
  std::size_t filled_ = 0;
  int rung_ = 0;
  double change_p90_ms_ = 0;
  mutable std::vector<double> scratch_;  ///< for the percentile, no allocation per frame
};

}  // namespace seavio::daemon
