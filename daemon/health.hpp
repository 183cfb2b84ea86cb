#pragma once
/// Health counters and per-stage latency histograms of the daemon (issues 6, 7, 9).
/// Written by the pipeline threads with relaxed atomics, read by the status thread.
#include <array>
#include <atomic>
#include <cstdint>
#include <string>
#include <string_view>

#include "daemon/latency_histogram.hpp"

namespace seavio::daemon {

/// Stages with a latency histogram. The first six are the odometry's own StageTimes;
/// "queue" is acquisition to estimator start, "process" the estimator call, "publish"
/// estimator end to LCM publish, "end_to_end" acquisition to publish (all daemon clock),
/// "capture_to_publish" the frame's capture stamp to publish when the source stamps on
/// the daemon's monotonic clock.
enum class Stage : int {
  kRectify, kFeatures, kStereo, kTemporal, kTensor, kIcp,
  kQueue, kProcess, kPublish, kEndToEnd, kCaptureToPublish,
  kCount
};
inline constexpr std::array<std::string_view, static_cast<int>(Stage::kCount)> kStageNames = {
    "rectify", "features", "stereo", "temporal", "tensor", "icp",
    "queue", "process", "publish", "end_to_end", "capture_to_publish"};

struct HealthCounters {
  std::atomic<uint64_t> frames_in{0};           ///< accepted into the camera ring or dropped there
  std::atomic<uint64_t> frames_processed{0};    ///< estimator returned a pose
  std::atomic<uint64_t> frames_dropped_shutdown{0};  ///< in the ring at stop
  std::atomic<uint64_t> frames_rejected_stamp{0};    ///< duplicate/out-of-order frame stamps
  std::atomic<uint64_t> frames_missing_upstream{0};  ///< gaps in source sequence numbers
  std::atomic<uint64_t> poses_published{0};
  std::atomic<uint64_t> poses_dropped{0};       ///< pose ring full or unpublished at stop
  std::atomic<uint64_t> imu_samples{0};
  std::atomic<uint64_t> imu_gaps{0};
  std::atomic<uint64_t> out_of_order{0};
  std::atomic<uint64_t> duplicates{0};
  std::atomic<uint64_t> processing_failures{0};
  std::atomic<uint64_t> publish_failures{0};
  std::atomic<uint64_t> imu_only_frames{0};
  std::atomic<uint64_t> camera_source_errors{0};
  std::atomic<uint64_t> imu_source_errors{0};
  std::atomic<int64_t> last_frame_recv_ns{0};   ///< daemon clock [ns], 0 = never
  std::atomic<int64_t> last_pose_pub_ns{0};
  std::atomic<int> features_left{0}, features_right{0}, ransac_inliers{0}, icp_inliers{0};

  std::array<LatencyHistogram, static_cast<int>(Stage::kCount)> latency;
  LatencyHistogram& at(Stage s) { return latency[static_cast<int>(s)]; }
  const LatencyHistogram& at(Stage s) const { return latency[static_cast<int>(s)]; }
};

}  // namespace seavio::daemon
