#pragma once
/// seaviod's pipeline: one object owning the sources, rings and threads.
///
///   camera thread --FrameRing--> estimator thread --SpscRing--> publisher thread --> LCM
///   IMU thread ----SpscRing----^      (worker pool: left/right preparation)
///   status thread: status_t at 1 Hz, sd_notify STATUS= / WATCHDOG=1
///   ICP thread (odometry mode global with a GlobalStage):
///     estimator --request ring--> ICP thread --correction ring--> estimator (next frame)
///                                     `--> LCM: the frame's refined pose (FLAG_GLOBAL_REFINED)
///
/// Lifecycle: construct, start(), then poll finished() or call stop() (any thread but the
/// pipeline's). Every wait inside has a timeout of at most 50 ms, so stop() returns within
/// the time of one frame's processing plus ~100 ms. Every frame received is processed,
/// counted as dropped in a ring, counted as dropped at shutdown, rejected for its stamp,
/// or counted as a processing failure: see accountedFrames().
#include <atomic>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "core/odometry/odometry.hpp"
#include "daemon/daemon_config.hpp"
#include "daemon/exit_codes.hpp"
#include "daemon/frame_processor.hpp"
#include "daemon/health.hpp"
#include "daemon/notifier.hpp"
#include "daemon/recorder.hpp"
#include "daemon/realtime.hpp"
#include "daemon/spsc_ring.hpp"
#include "daemon/worker_pool.hpp"
#include "drivers/lcm/lcm_bus.hpp"
#include "drivers/source/sources.hpp"
#include "seavio_lcm/status_t.hpp"

namespace seavio::daemon {

/// Monotonic clock of the daemon [ns] (CLOCK_MONOTONIC via steady_clock).
int64_t monotonicNowNs();

class Daemon;

/// The global map step on its own persistent thread: the odometry's
/// GlobalLink (give it as OdometryParams::global_link), then handed to the Daemon, which runs
/// the ICP thread. The estimator submits each frame's request into a fixed-capacity SPSC ring
/// (full: skipped and counted, never waits, see RingCapacities::global_requests) and drains
/// the corrections ring before each frame; the ICP thread refines, returns the correction
/// and publishes the frame's refined pose.
class GlobalStage : public odometry::GlobalLink {
 public:
  /// @param seed random stream of the re-observation RANSAC on the ICP thread
  explicit GlobalStage(const RingCapacities& rings, uint32_t seed = 1);
  ~GlobalStage() override = default;
  /// The refiner the ICP thread owns (Odometry::makeGlobalRefiner: the odometry's rig and
  /// parameters). Before Daemon::start(); start() fails without one.
  void setRefiner(odometry::GlobalRefiner refiner) { refiner_.emplace(std::move(refiner)); }
  bool hasRefiner() const { return refiner_.has_value(); }

  /// Estimator thread (inside Odometry::track): queue the request, or skip and count it.
  void submit(odometry::GlobalRequest&& request) override;
  /// Estimator thread: the next correction back from the ICP thread, if any.
  bool poll(odometry::GlobalCorrection& out) override;

  /// ICP thread: the refinement of one request (virtual so that tests can make it slow).
  virtual odometry::GlobalCorrection refine(const odometry::GlobalRequest& request);

  std::size_t requestCapacity() const { return requests_.capacity(); }

 private:
  friend class Daemon;
  struct Job {
    odometry::GlobalRequest request;
    int64_t recv_ns = 0;    ///< the frame reached the daemon (daemon clock) [ns]
    int64_t submit_ns = 0;  ///< the estimator submitted the request [ns]
  };

  SpscRing<Job> requests_;                            ///< estimator -> ICP thread
  SpscRing<odometry::GlobalCorrection> corrections_;  ///< ICP thread -> estimator
  std::optional<odometry::GlobalRefiner> refiner_;    ///< ICP thread only once started
  std::mt19937 rng_;                                  ///< ICP thread only
  HealthCounters* health_ = nullptr;                  ///< the daemon's, set before start
  int64_t recv_ns_ = 0;  ///< estimator thread: receive time of the frame being processed
};

class Daemon {
 public:
  /// `imu` may be null (vision only). `notifier` null means NullNotifier. `global`: the
  /// processor's odometry defers its global step to this stage (global mode with
  /// daemon.global_thread); null = no ICP thread.
  Daemon(DaemonConfig config, std::unique_ptr<drivers::CameraSource> camera,
         std::unique_ptr<drivers::ImuSource> imu, std::unique_ptr<FrameProcessor> processor,
         std::unique_ptr<Notifier> notifier = nullptr, std::shared_ptr<GlobalStage> global = nullptr);
  ~Daemon();
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  /// Records what the estimator consumes (daemon.record); before start().
  void setRecorder(std::unique_ptr<Recorder> recorder) { recorder_ = std::move(recorder); }
  /// Null without a recorder.
  const Recorder* recorder() const { return recorder_.get(); }

  /// Opens LCM and the sources, starts every thread. False with error() if anything fails
  /// (nothing is left running then).
  bool start();
  /// Stops acquisition, finishes the frame being processed, counts frames still queued
  /// as dropped at shutdown, publishes poses already computed, lets the ICP thread finish
  /// the request it holds and counts the queued ones as dropped at shutdown, joins.
  /// Idempotent.
  void stop();
  /// True once the camera source reported kEnd and everything queued was handled (the ICP
  /// thread's requests included).
  bool finished() const { return finished_.load(); }
  bool running() const { return running_.load(); }
  const std::string& error() const { return error_; }
  /// Non-zero once the daemon must exit (daemon/exit_codes.hpp): a thread or an LCM callback
  /// threw past every stage (kExitThreadFault), or the IMU died under dead_policy exit
  /// (kExitImuDead). The watchdog is no longer fed from then on; fault() says why.
  int faultExitCode() const { return fault_code_.load(); }
  std::string fault() const;

  const HealthCounters& health() const { return health_; }
  uint64_t framesDroppedInRing() const { return frames_ ? frames_->dropped() : 0; }
  uint64_t imuOverflow() const { return imu_ ? imu_->overflowed() : 0; }
  /// Device faults counted by the sources' drivers (zero for sources without any).
  DriverFaults driverFaults() const;
  /// processed + dropped (ring, shutdown) + processing failures; equals frames_in after stop().
  uint64_t accountedFrames() const;
  /// skipped + refined + dropped at shutdown + failed; equals health().global_requests after
  /// stop() (and once finished()).
  uint64_t accountedGlobalRequests() const;
  bool globalThread() const { return global_ != nullptr; }
  /// Current status message (also what the status thread publishes).
  seavio_lcm::status_t statusMessage() const;
  /// Human-readable health summary (SIGUSR1, exit, STATUS=).
  std::string summary() const;
  /// One-line summary for sd_notify STATUS=.
  std::string shortStatus() const;
  /// How each thread was scheduled (daemon.realtime), one entry per thread or
  /// worker as it started: "estimator: SCHED_FIFO 10", or why a setting was refused.
  std::vector<std::string> schedulingReport() const;
  /// False if any requested scheduling or memory lock was refused (see schedulingReport()).
  bool schedulingOk() const;

 private:
  struct FrameItem {
    StereoFrame frame;
    int64_t recv_ns = 0;
    /// Replay of a recorded log (drivers::ImuHorizonReporter): the newest IMU stamp the
    /// recording estimator held for this frame; the estimator takes exactly up to it.
    bool has_imu_horizon = false;
    int64_t imu_horizon_ns = 0;
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
  void collectImuUpTo(int64_t horizon_ns);
  void buildImuBatch(int64_t up_to_ns);
  void takeImu(const ImuSample& s);
  void publishPose(PoseItem& p);
  void globalLoop();
  void refineJob(GlobalStage::Job& job);
  void publishRefined(const OdometryResult& r, int64_t recv_ns, int64_t proc_end_ns);
  void maybeFinish();
  /// Runs a thread's body; an exception escaping it raises kExitThreadFault naming `thread`,
  /// then `on_fault` lets the threads downstream of it end as if it had.
  void runGuarded(const char* thread, void (Daemon::*body)(), void (Daemon::*on_fault)());
  void raiseFault(int code, const std::string& why);
  void endEstimator() { estimator_done_ = true; }
  void endPublisher() { publisher_done_ = true; }
  void endImu() { imu_ended_ = true; }
  void endGlobal() { global_done_ = true; }
  void endNothing() {}
  /// Estimator thread: appends one IMU sample to the pending buffer, bounded (see
  /// HealthCounters::imu_pending_dropped).
  void pendImu(const ImuSample& s);
  /// Status thread: raises or clears imu_dead; under dead_policy exit a dead IMU is fatal.
  void checkImuAlive(int64_t now_ns);
  /// Records a stage's latency and counts a deadline miss if it exceeds the frame budget.
  void recordStage(Stage stage, double ms);
  /// Estimator thread: feeds one frame's latency (arrival to estimate) to the degrade ladder
  /// and hands the processor what to shed when the rung changes.
  void updateLadder(double frame_ms);
  /// Applies `role` to the calling thread and records the outcome.
  void scheduleThisThread(ThreadRole role, const std::string& name);
  void noteScheduling(const SchedulingOutcome& outcome);

  DaemonConfig cfg_;
  std::unique_ptr<drivers::CameraSource> camera_;
  std::unique_ptr<drivers::ImuSource> imu_src_;
  std::unique_ptr<FrameProcessor> processor_;
  std::unique_ptr<Notifier> notifier_;
  std::unique_ptr<drivers::LcmBus> bus_;
  /// Status and refined poses (background threads) go out on their own LCM instance, so a
  /// background thread preempted inside LCM's publish lock never holds up a frame's pose;
  /// the same as bus_ for a file:// output (one writer per file).
  std::unique_ptr<drivers::LcmBus> background_bus_;
  drivers::LcmBus* bg_bus_ = nullptr;
  std::unique_ptr<FrameRing<FrameItem>> frames_;
  std::unique_ptr<SpscRing<ImuSample>> imu_;
  std::unique_ptr<SpscRing<PoseItem>> poses_;
  std::unique_ptr<WorkerPool> pool_;
  std::shared_ptr<GlobalStage> global_;
  std::unique_ptr<Recorder> recorder_;

  HealthCounters health_;
  std::atomic<bool> stop_acq_{false};      ///< camera + IMU threads
  std::atomic<bool> stop_pipeline_{false}; ///< estimator, publisher, status
  std::atomic<bool> camera_ended_{false};
  std::atomic<bool> imu_ended_{false};     ///< no IMU source, or it ended or was stopped
  std::atomic<bool> estimator_done_{false};
  std::atomic<bool> publisher_done_{false};
  std::atomic<bool> stop_global_{false};   ///< ICP thread
  std::atomic<bool> global_done_{false};
  std::atomic<bool> finished_{false};
  std::atomic<bool> running_{false};
  std::atomic<bool> ready_sent_{false};
  std::atomic<int64_t> start_ns_{0};
  std::string error_;
  std::atomic<int> fault_code_{0};
  mutable std::mutex fault_mutex_;
  std::string fault_;  ///< why fault_code_ was raised (fault_mutex_)
  mutable std::mutex sched_mutex_;
  std::vector<std::string> sched_report_;
  bool sched_ok_ = true;

  // Estimator-thread state.
  std::vector<ImuSample> imu_pending_;
  std::vector<ImuSample> imu_batch_;
  std::optional<ImuSample> imu_carry_;  ///< last sample at or before the previous frame
  std::optional<ImuSample> imu_lookahead_;  ///< taken from the ring, past the frame's IMU horizon
  std::optional<DegradeLadder> ladder_;
  int64_t last_imu_ns_ = 0;
  bool imu_seen_ = false;

  std::atomic<double> frame_rate_hz_{0}, pose_rate_hz_{0}, imu_rate_hz_{0};

  std::thread camera_thread_, imu_thread_, estimator_thread_, publisher_thread_, status_thread_, global_thread_;
};

}  // namespace seavio::daemon
