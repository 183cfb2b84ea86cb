#pragma once
/// The production estimator stage: core's stereo visual odometry (paper Sec. III) behind the
/// daemon's FrameProcessor interface. With two or more feature threads a persistent worker is
/// lent to core as its ParallelFor: the right image is rectified and described on it while the
/// left one is on the calling (estimator) thread, and it shares the RANSAC's hypotheses. Core
/// starts no thread itself.
///
/// Header-only, like WorkerPool, so that `seavio run --threads` (tools/sequence_runner.cpp)
/// drives exactly this class without linking the daemon library and its drivers.
#include <chrono>
#include <cstddef>
#include <exception>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include <opencv2/core.hpp>

#include "core/camera/camera_model.hpp"
#include "core/common/stage_timer.hpp"
#include "core/odometry/odometry.hpp"
#include "daemon/frame_processor.hpp"
#include "daemon/pool_parallel_for.hpp"
#include "daemon/refusal_log.hpp"
#include "daemon/worker_pool.hpp"

namespace seavio::daemon {

class OdometryProcessor : public FrameProcessor {
 public:
  /// Empty optional and `error` set if the calibration cannot be rectified. The odometry
  /// times its stages with std::chrono::steady_clock [ns] (the daemon's monotonic clock).
  /// @param feature_threads threads extracting features per frame: 1 = all on the caller,
  ///        2 (default) = right image on one persistent worker in parallel with the left
  static std::unique_ptr<OdometryProcessor> create(const camera::StereoCalibration& calib,
                                                   const imu::ImuNoise& noise,
                                                   const odometry::OdometryParams& params,
                                                   std::string* error, std::size_t feature_threads = 2) {
    std::optional<camera::StereoRectifier> rect = camera::StereoRectifier::create(calib, error);
    if (!rect) return nullptr;
    return std::make_unique<OdometryProcessor>(odometry::Odometry(std::move(*rect), noise, params, steadyNowNs),
                                               feature_threads);
  }

  /// Output identical for any `feature_threads`: only the order of independent work changes.
  /// A refused frame is logged, rate-limited (refusal_log.hpp).
  OdometryResult process(const StereoFrame& frame, std::span<const ImuSample> imu) override {
    OdometryResult r = odo_.process(frame, imu);
    refusal_log_.add(r);
    return r;
  }
  std::string name() const override { return "stereo-odometry"; }
  void setLoadShedding(const odometry::LoadShedding& shed) override { odo_.setLoadShedding(shed); }
  bool runOnWorkerThreads(const std::function<void()>& fn) override { return !pool_ || pool_->runOnEachThread(fn); }

  /// Takes `odo` as it is (its clock included).
  explicit OdometryProcessor(odometry::Odometry odo, std::size_t feature_threads = 2) : odo_(std::move(odo)) {
    // A queue of one: the processor never has more than one job in flight. The worker takes
    // the right image's side of the frontend, then shares the four-view RANSAC's hypotheses
    // (paper III-C).
    if (feature_threads >= 2) {
      pool_ = std::make_unique<WorkerPool>(1, 1);
      parallel_.emplace(*pool_);
      odo_.setParallelFor(&*parallel_);
    }
  }
  OdometryProcessor(const OdometryProcessor&) = delete;
  OdometryProcessor& operator=(const OdometryProcessor&) = delete;

  /// Threads used for feature extraction (1 or 2).
  std::size_t featureThreads() const { return pool_ ? 2 : 1; }
  /// Fork-joins (a frame's two image sides, a RANSAC batch) shared with the worker; the others
  /// ran on the calling thread alone (the worker queue refused the job).
  std::size_t parallelRuns() const { return parallel_ ? parallel_->sharedRuns() : 0; }
  const odometry::Odometry& odometry() const { return odo_; }

  /// std::chrono::steady_clock now [ns].
  static int64_t steadyNowNs() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
  }

 private:
  odometry::Odometry odo_;
  /// The worker as core's ParallelFor; declared before pool_, so the pool (joined first) never
  /// outlives it.
  std::optional<PoolParallelFor> parallel_;
  std::unique_ptr<WorkerPool> pool_;  ///< one persistent worker; null when sequential
  RefusalLog refusal_log_;
};

}  // namespace seavio::daemon
