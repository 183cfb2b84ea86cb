#pragma once
/// The production estimator stage: core's stereo visual odometry (paper Sec. III) behind the
/// daemon's FrameProcessor interface. With two or more feature threads the left and right
/// images are detected and described in parallel: the right one on a persistent
/// worker, the left one on the calling (estimator) thread. Core stays single-threaded: the
/// processor drives Frontend's per-image calls and hands the result to Odometry::track.
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
    OdometryResult r;
    if (!pool_) {
      r = odo_.process(frame, imu);
    } else {
      // Into the buffers of an earlier frame, which track() hands back.
      extractParallel(frame, spare_);
      r = odo_.track(std::move(spare_), imu);
    }
    refusal_log_.add(r);
    return r;
  }
  std::string name() const override { return "stereo-odometry"; }
  void setLoadShedding(const odometry::LoadShedding& shed) override { odo_.setLoadShedding(shed); }
  bool runOnWorkerThreads(const std::function<void()>& fn) override { return !pool_ || pool_->runOnEachThread(fn); }

  /// Takes `odo` as it is (its clock included).
  explicit OdometryProcessor(odometry::Odometry odo, std::size_t feature_threads = 2) : odo_(std::move(odo)) {
    // A queue of one: the processor never has more than one job in flight. The same worker
    // shares the four-view RANSAC's hypotheses once the features are in (paper III-C).
    if (feature_threads >= 2) {
      pool_ = std::make_unique<WorkerPool>(1, 1);
      ransac_parallel_.emplace(*pool_);
      odo_.setParallelFor(&*ransac_parallel_);
    }
  }
  OdometryProcessor(const OdometryProcessor&) = delete;
  OdometryProcessor& operator=(const OdometryProcessor&) = delete;

  /// Threads used for feature extraction (1 or 2).
  std::size_t featureThreads() const { return pool_ ? 2 : 1; }
  /// Frames whose right image went to the worker (the rest ran sequentially, e.g. because
  /// the worker queue refused the job).
  std::size_t parallelFrames() const { return parallel_frames_; }
  /// RANSAC batches whose hypotheses were shared with the worker.
  std::size_t parallelRansacBatches() const { return ransac_parallel_ ? ransac_parallel_->sharedRuns() : 0; }
  const odometry::Odometry& odometry() const { return odo_; }

  /// std::chrono::steady_clock now [ns].
  static int64_t steadyNowNs() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
  }

 private:
  void extractParallel(const StereoFrame& frame, odometry::FrameFeatures& f) {
    const odometry::Frontend& frontend = odo_.frontend();
    f.times = StageTimes{};
    f.t_ns = frame.t_ns;
    f.seq = frame.seq;
    f.detector_threshold = odo_.detectorThreshold();
    StageTimer timer(now_);
    // Frontend's rectifySide and detect are const; each side has its own image, filter and
    // SURF buffers in ws_, so the right image is rectified and described on the worker while
    // the left one is on this thread (rectify_ms is then the left image's).
    const double threshold = f.detector_threshold;
    // The right image's job reads its inputs from here (set once per frame: posting it
    // allocates nothing).
    right_ = RightInput{&frame, threshold, &f.right};
    const bool posted = pool_->post(right_job_);
    try {
      frontend.rectifySide(0, frame, ws_);
      if (!posted) frontend.rectifySide(1, frame, ws_);
      f.times.rectify_ms = timer.lap_ms();
      frontend.detect(ws_.left_rect, threshold, ws_.surf_left, f.left);
    } catch (...) {
      // The job refers to `f` and the images: it must finish before they go out of scope.
      if (posted) {
        try {
          right_job_.wait();
        } catch (...) {  // the left image's exception is the one reported
        }
      }
      throw;
    }
    if (posted) {
      right_job_.wait();  // rethrows the worker's exception, if any
      ++parallel_frames_;
    } else {
      frontend.detect(ws_.right_rect, threshold, ws_.surf_right, f.right);
    }
    f.times.features_ms = timer.lap_ms();
    frontend.matchStereo(f.left, f.right, ws_, f.stereo);
    f.times.stereo_ms = timer.lap_ms();
    odometry::Frontend::keepImages(ws_, f);
  }

  /// What the right image's job works on this frame.
  struct RightInput {
    const StereoFrame* frame = nullptr;
    double threshold = 0;
    features::Features* out = nullptr;
  };

  odometry::Odometry odo_;
  RightInput right_;
  /// Rectifies and detects right_ on the worker; declared before pool_, so the pool (joined
  /// first) never outlives it. Captures only `this`: the processor is not movable.
  RecurringJob right_job_{[this] {
    odo_.frontend().rectifySide(1, *right_.frame, ws_);
    odo_.frontend().detect(ws_.right_rect, right_.threshold, ws_.surf_right, *right_.out);
  }};
  /// The worker as the RANSAC's ParallelFor; declared before pool_ for the same reason.
  std::optional<PoolParallelFor> ransac_parallel_;
  std::unique_ptr<WorkerPool> pool_;  ///< one persistent worker; null when sequential
  odometry::FrontendWorkspace ws_;    ///< rectified images and filter buffers, reused across frames
  odometry::FrameFeatures spare_;     ///< an earlier frame's buffers, refilled each frame
  std::size_t parallel_frames_ = 0;
  RefusalLog refusal_log_;
  const NowNsFn now_ = steadyNowNs;   ///< stage times of the parallel path
};

}  // namespace seavio::daemon
