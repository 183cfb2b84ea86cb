#pragma once
/// Latency profile of a seaviod run from its LCM output log (`seavio profile`).
///
/// What the messages carry decides what can be measured:
///  - every pose_t has the frame's capture stamp `t_ns`, its publication time `publish_t_ns`
///    and the estimator's wall time `processing_ms`: these give exact per-frame figures;
///  - pose_t version 2 adds the receive time `recv_t_ns` and the frame's own stage split
///    (stage_names/stage_ms): these give exact per-stage p50/p90/p99/max;
///  - status_t carries the daemon's own per-stage histograms (rectify ... icp, queue,
///    process, publish, end_to_end, capture_to_publish) as p50/p99 only, 5 % bins: the
///    last status message of the log is reported as is.
/// Capture-to-publish per frame is only defined when the source stamps frames on the
/// daemon's monotonic clock (live drivers); replayed datasets keep their own epoch, and then
/// the per-frame end-to-end figure is receive to publish (version 2 poses), or the estimator
/// time as a lower bound (version 1 poses).
#include <cstdint>
#include <limits>
#include <ostream>
#include <string>
#include <vector>

#include "tools/lcm_trajectory.hpp"

namespace seavio::tools {

/// Percentiles of one latency [ms]. `per_frame` false: only p50/p99 from the daemon's
/// histogram are known (p90 and max are then NaN).
struct LatencyStats {
  std::string name;
  uint64_t count = 0;
  double p50_ms = 0, p90_ms = 0, p99_ms = 0, max_ms = 0;
  bool per_frame = true;
};

struct FrameTiming {
  int64_t seq = 0;
  int64_t t_ns = 0;             ///< capture stamp [ns]
  double publish_s = 0;         ///< publication time since the first pose [s]
  double processing_ms = 0;     ///< estimator wall time [ms]
  double end_to_end_ms = 0;     ///< capture (or receive) to publish [ms], see end_to_end_basis
  /// Capture to publish with the stamp put on the daemon clock by the replay's offset [ms]
  /// (see capture_to_publish_replay); NaN when the log does not allow it.
  double capture_to_publish_replay_ms = std::numeric_limits<double>::quiet_NaN();
  /// This frame's stage times [ms] in the order of ProfileReport::stages; 0 where the frame
  /// lacks the stage.
  std::vector<double> stage_ms;
};

struct ProfileParams {
  double budget_ms = 66.0;  ///< frame budget at 15 fps (paper Sec. V)
  /// Largest publish - capture difference [ms] taken as a real latency; beyond it (or
  /// negative) the stamps are on different clocks.
  double max_plausible_latency_ms = 10'000.0;
};

struct ProfileReport {
  ProfileParams params;
  std::vector<FrameTiming> frames;          ///< in log order
  int64_t first_publish_t_ns = 0;           ///< the first pose's publish_t_ns (daemon clock)
  std::vector<LatencyStats> per_frame;      ///< "process", "publish_interval", "end_to_end"
  /// When they apply: "capture_to_publish_replay" (stamps of a real-time replay put on the
  /// daemon clock) and "refined_end_to_end" (global mode's second, refined pose per frame).
  std::vector<LatencyStats> per_frame_extra;
  /// Per-frame stages from the poses' stage_names/stage_ms, in order of first appearance
  /// (empty for version 1 poses).
  std::vector<LatencyStats> stages;
  std::vector<LatencyStats> daemon_stages;  ///< from the last status message (may be empty)
  /// "capture_to_publish" if every frame's stamps share the daemon clock, else
  /// "receive_to_publish" if every pose carries recv_t_ns, else "processing (lower bound)".
  std::string end_to_end_basis;
  uint64_t over_budget = 0;        ///< frames whose end-to-end figure exceeds the budget
  uint64_t seq_gaps = 0;           ///< frames missing from the pose sequence numbers
  uint64_t repeated_or_backward_seq = 0;
  /// Refined poses (FLAG_GLOBAL_REFINED following the same seq's FLAG_LOCAL_ONLY pose): not
  /// frames; their receipt-to-publish is per_frame "refined_end_to_end".
  uint64_t refined_poses = 0;
  bool has_status = false;
  seavio_lcm::status_t last_status{};  ///< valid if has_status
  LogScanStats log;
};

/// Nearest-rank percentile (q in 0..1) of `v` [any unit]; 0 for an empty vector.
double percentile(std::vector<double> v, double q);

/// Stats of `v` [ms] under `name`.
LatencyStats latencyStats(const std::string& name, const std::vector<double>& v);

/// The poses published in [from_s, to_s) seconds after the first pose's publication, and
/// the status messages of that span (same daemon clock); `to_s` <= 0 means to the end. For
/// comparing the first and last minutes of a soak run.
DaemonOutputLog windowOf(const DaemonOutputLog& log, double from_s, double to_s);

ProfileReport computeProfile(const DaemonOutputLog& log, const ProfileParams& params = {});

/// Console table: per-frame figures, daemon stages, budget and drop counts, log damage.
void printProfile(std::ostream& os, const ProfileReport& r);

/// The same as JSON plus the per-frame arrays. Throws std::runtime_error naming the path.
void writeProfileJson(const std::string& path, const ProfileReport& r);

/// 1200 x 800 PNG: latency timeline (end-to-end and processing per frame, the stages stacked
/// as cumulative lines, budget line) over a histogram of the end-to-end figure. Throws std::runtime_error naming the path.
void writeProfilePlot(const std::string& path_png, const ProfileReport& r);

}  // namespace seavio::tools
