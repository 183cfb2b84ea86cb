#pragma once
/// Health counters and per-stage latency histograms of the daemon.
/// Written by the pipeline threads with relaxed atomics, read by the status thread.
#include <array>
#include <atomic>
#include <cstdint>
#include <string>
#include <string_view>

#include "core/common/types.hpp"
#include "daemon/latency_histogram.hpp"

namespace seavio::daemon {

/// Stages with a latency histogram. The first six are the odometry's own StageTimes;
/// "queue" is acquisition to estimator start, "process" the estimator call, "publish"
/// estimator end to LCM publish, "end_to_end" acquisition to publish (all daemon clock),
/// "capture_to_publish" the frame's capture stamp to publish when the source stamps on
/// the daemon's monotonic clock. With the global step on its own thread:
/// "global_queue" request submitted to refinement start, "global" the refinement itself,
/// "refined_end_to_end" acquisition to the refined pose's publication and
/// "refined_capture_to_publish" its capture stamp to publication (same clock condition).
/// "imu_wait": inside "process", the estimator waiting for the IMU samples that reach the
/// frame's time (at 200 Hz up to 5 ms of every frame, see DaemonConfig::imu_hold_ms).
enum class Stage : int {
  kRectify, kFeatures, kStereo, kTemporal, kTensor, kIcp,
  kQueue, kProcess, kPublish, kEndToEnd, kCaptureToPublish,
  kGlobalQueue, kGlobal, kRefinedEndToEnd, kRefinedCaptureToPublish,
  kImuWait,
  kCount
};
inline constexpr std::array<std::string_view, static_cast<int>(Stage::kCount)> kStageNames = {
    "rectify", "features", "stereo", "temporal", "tensor", "icp",
    "queue", "process", "publish", "end_to_end", "capture_to_publish",
    "global_queue", "global", "refined_end_to_end", "refined_capture_to_publish",
    "imu_wait"};

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
  /// Frames on which vision and the IMU had disagreed long enough for the IMU to be judged at
  /// fault (OdometryResult quality.imu_fault; countPose). In the summary; on LCM as the
  /// pose's FLAG_IMU_FAULT.
  std::atomic<uint64_t> imu_faults{0};
  /// IMU samples the estimator dropped from its pending buffer: the buffer was full (samples
  /// on another time base, ahead of every frame), or the stream restarted on an earlier
  /// clock and left them ahead of every frame to come.
  std::atomic<uint64_t> imu_pending_dropped{0};
  std::atomic<bool> imu_dead{false};            ///< no IMU sample for daemon.imu.dead_after_ms
  std::atomic<uint64_t> imu_dead_episodes{0};   ///< times imu_dead was raised
  std::atomic<int64_t> last_imu_recv_ns{0};     ///< daemon clock [ns], 0 = never
  /// Of the IMU-only frames: by the check that refused the visual estimate (indexed by
  /// Refusal; OdometryResult::refusal). In the summary; on LCM as the pose's FLAG_REFUSED_* bits.
  std::array<std::atomic<uint64_t>, kRefusalKinds> imu_only_refused{};
  std::atomic<uint64_t> camera_source_errors{0};
  std::atomic<uint64_t> imu_source_errors{0};
  // Global step on its own thread (daemon.global_thread). Every request the estimator makes
  // ends in exactly one of: skipped (ring full), refined, dropped at shutdown, failed:
  // global_requests = global_skipped + global_refined + global_dropped_shutdown + global_failures
  // once stopped. Of the refined: applied (the map moved the frame), rejected (ICP gated),
  // the rest had no older ground near them.
  std::atomic<uint64_t> global_requests{0};     ///< frames handed to the global step
  std::atomic<uint64_t> global_skipped{0};      ///< request ring full: frame kept its local pose
  std::atomic<uint64_t> global_refined{0};      ///< refinements completed (refined pose published or counted)
  std::atomic<uint64_t> global_applied{0};      ///< ...of which moved the frame (revisit or ICP)
  std::atomic<uint64_t> global_rejected{0};     ///< ...of which ICP ran but was refused (failed or too large)
  std::atomic<uint64_t> global_dropped_shutdown{0};  ///< still queued at stop
  std::atomic<uint64_t> global_failures{0};     ///< refinement threw
  std::atomic<uint64_t> global_lost{0};         ///< correction ring full (cannot happen by sizing)
  std::atomic<uint64_t> global_corrections_applied{0};  ///< corrections the estimator composed in
  std::atomic<uint64_t> refined_published{0};   ///< FLAG_GLOBAL_REFINED poses on LCM
  std::atomic<int64_t> last_frame_recv_ns{0};   ///< daemon clock [ns], 0 = never
  std::atomic<int64_t> last_pose_pub_ns{0};
  std::atomic<int> features_left{0}, features_right{0}, ransac_inliers{0}, icp_inliers{0};

  std::array<LatencyHistogram, static_cast<int>(Stage::kCount)> latency;
  /// Per stage: frames whose time in the stage exceeded daemon.deadline.frame_budget_ms.
  std::array<std::atomic<uint64_t>, static_cast<int>(Stage::kCount)> deadline_misses{};
  std::atomic<int> degrade_rung{0};             ///< DegradeLadder rung in force
  std::atomic<uint64_t> degrade_climbs{0};      ///< times the ladder climbed a rung
  std::atomic<double> recent_p90_ms{0};         ///< the ladder's window p90 at its last decision
  LatencyHistogram& at(Stage s) { return latency[static_cast<int>(s)]; }
  const LatencyHistogram& at(Stage s) const { return latency[static_cast<int>(s)]; }
};

/// Counts a published pose's IMU fault, and a pose that coasted, by the check that refused it.
inline void countPose(HealthCounters& h, const OdometryResult& r) {
  if (r.quality.imu_fault) h.imu_faults++;
  if (r.source != PoseSource::kImuOnly) return;
  h.imu_only_frames++;
  h.imu_only_refused[static_cast<std::size_t>(r.refusal.check)]++;
}

/// Faults a driver counts itself below the CameraSource/ImuSource interface:
/// reconnects, unpaired or corrupt frames, protocol errors. Folded into status_t.
struct DriverFaults {
  uint64_t camera_reconnects = 0;       ///< camera reopened after it vanished
  uint64_t camera_unpaired_frames = 0;  ///< left/right frames without a partner in tolerance
  uint64_t camera_lost_frames = 0;      ///< device frame-id / sequence gaps
  uint64_t camera_corrupt_frames = 0;   ///< incomplete buffers, wrong format or size
  uint64_t imu_checksum_errors = 0;     ///< serial packets failing their CRC
  uint64_t imu_garbage_bytes = 0;       ///< serial bytes skipped while resynchronising
  uint64_t imu_partial_packets = 0;     ///< reads ending inside a packet (serial or CAN)
  uint64_t imu_reconnects = 0;          ///< serial port or CAN bus reopened after a failure
  uint64_t imu_bus_errors = 0;          ///< CAN error frames, bus-off, unknown ids, short frames
  uint64_t timestamp_jumps = 0;         ///< device clocks jumping (camera and IMU)

  DriverFaults& operator+=(const DriverFaults& o) {
    camera_reconnects += o.camera_reconnects;
    camera_unpaired_frames += o.camera_unpaired_frames;
    camera_lost_frames += o.camera_lost_frames;
    camera_corrupt_frames += o.camera_corrupt_frames;
    imu_checksum_errors += o.imu_checksum_errors;
    imu_garbage_bytes += o.imu_garbage_bytes;
    imu_partial_packets += o.imu_partial_packets;
    imu_reconnects += o.imu_reconnects;
    imu_bus_errors += o.imu_bus_errors;
    timestamp_jumps += o.timestamp_jumps;
    return *this;
  }
};

/// Implemented next to CameraSource/ImuSource by sources whose driver counts faults; the
/// daemon's status thread calls it while the source's own thread reads, so implementations
/// must be thread-safe.
class FaultReporter {
 public:
  virtual ~FaultReporter() = default;
  /// Current totals since start.
  virtual DriverFaults faults() const = 0;
};

}  // namespace seavio::daemon
