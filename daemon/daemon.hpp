#pragma once
/// seaviod's pipeline (issue 6): one object owning the sources, rings and threads.
///
///   camera thread --FrameRing--> estimator thread --SpscRing--> publisher thread --> LCM
///   IMU thread ----SpscRing----^      (worker pool: left/right preparation)
///   status thread: status_t at 1 Hz, sd_notify STATUS= / WATCHDOG=1
///
/// Lifecycle: construct, start(), then poll finished() or call stop() (any thread but the
/// pipeline's). Every wait inside has a timeout of at most 50 ms, so stop() returns within
/// the time of one frame's processing plus ~100 ms. Every frame received is processed,
/// counted as dropped in a ring, counted as dropped at shutdown, rejected for its stamp,
/// or counted as a processing failure: see accountedFrames().
#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "daemon/daemon_config.hpp"
#include "daemon/frame_processor.hpp"
#include "daemon/health.hpp"
#include "daemon/notifier.hpp"
#include "daemon/spsc_ring.hpp"
#include "daemon/worker_pool.hpp"
#include "drivers/lcm/lcm_bus.hpp"
#include "drivers/source/sources.hpp"
#include "seavio_lcm/status_t.hpp"

namespace seavio::daemon {

/// Monotonic clock of the daemon [ns] (CLOCK_MONOTONIC via steady_clock).
int64_t monotonicNowNs();

class Daemon {
 public:
  /// `imu` may be null (vision only). `notifier` null means NullNotifier.
  Daemon(DaemonConfig config, std::unique_ptr<drivers::CameraSource> camera,
         std::unique_ptr<drivers::ImuSource> imu, std::unique_ptr<FrameProcessor> processor,
         std::unique_ptr<Notifier> notifier = nullptr);
  ~Daemon();
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  /// Opens LCM and the sources, starts every thread. False with error() if anything fails
  /// (nothing is left running then).
  bool start();
  /// Stops acquisition, finishes the frame being processed, counts frames still queued
  /// as dropped at shutdown, publishes poses already computed, joins. Idempotent.
  void stop();
  /// True once the camera source reported kEnd and everything queued was handled.
  bool finished() const { return finished_.load(); }
  bool running() const { return running_.load(); }
  const std::string& error() const { return error_; }

  const HealthCounters& health() const { return health_; }
  uint64_t framesDroppedInRing() const { return frames_ ? frames_->dropped() : 0; }
  uint64_t imuOverflow() const { return imu_ ? imu_->overflowed() : 0; }
  /// Device faults counted by the sources' drivers (zero for sources without any).
  DriverFaults driverFaults() const;
  /// processed + dropped (ring, shutdown) + processing failures; equals frames_in after stop().
  uint64_t accountedFrames() const;
  /// Current status message (also what the status thread publishes).
  seavio_lcm::status_t statusMessage() const;
  /// Human-readable health summary (SIGUSR1, exit, STATUS=).
  std::string summary() const;
  /// One-line summary for sd_notify STATUS=.
  std::string shortStatus() const;

 private:
  struct FrameItem {
    StereoFrame frame;
    int64_t recv_ns = 0;
  };
  struct PoseItem {
    OdometryResult result;
    int64_t recv_ns = 0;
    int64_t proc_end_ns = 0;
  };

  void cameraLoop();
  void imuLoop();
  void estimatorLoop();
  void publisherLoop();
  void statusLoop();
  void estimate(FrameItem& item);
  void prepare(StereoFrame& f);
  void collectImu(int64_t up_to_ns, bool wait);
  void publishPose(PoseItem& p);

  DaemonConfig cfg_;
  std::unique_ptr<drivers::CameraSource> camera_;
  std::unique_ptr<drivers::ImuSource> imu_src_;
  std::unique_ptr<FrameProcessor> processor_;
  std::unique_ptr<Notifier> notifier_;
  std::unique_ptr<drivers::LcmBus> bus_;
  std::unique_ptr<FrameRing<FrameItem>> frames_;
  std::unique_ptr<SpscRing<ImuSample>> imu_;
  std::unique_ptr<SpscRing<PoseItem>> poses_;
  std::unique_ptr<WorkerPool> pool_;

  HealthCounters health_;
  std::atomic<bool> stop_acq_{false};      ///< camera + IMU threads
  std::atomic<bool> stop_pipeline_{false}; ///< estimator, publisher, status
  std::atomic<bool> camera_ended_{false};
  std::atomic<bool> imu_ended_{false};     ///< no IMU source, or it ended or was stopped
  std::atomic<bool> estimator_done_{false};
  std::atomic<bool> finished_{false};
  std::atomic<bool> running_{false};
  std::atomic<bool> ready_sent_{false};
  std::atomic<int64_t> start_ns_{0};
  std::string error_;

  // Estimator-thread state.
  std::vector<ImuSample> imu_pending_;
  std::vector<ImuSample> imu_batch_;
  std::optional<ImuSample> imu_carry_;  ///< last sample at or before the previous frame
  int64_t last_imu_ns_ = 0;

  std::atomic<double> frame_rate_hz_{0}, pose_rate_hz_{0}, imu_rate_hz_{0};

  std::thread camera_thread_, imu_thread_, estimator_thread_, publisher_thread_, status_thread_;
};

}  // namespace seavio::daemon
