#pragma once
/// The production estimator stage: core's stereo visual odometry (paper Sec. III) behind the
/// daemon's FrameProcessor interface. With two or more feature threads the left and right
/// images are detected and described in parallel (issue 8): the right one on a persistent
/// worker, the left one on the calling (estimator) thread. Core stays single-threaded: the
/// processor drives Frontend's per-image calls and hands the result to Odometry::track.
#include <cstddef>
#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "core/camera/camera_model.hpp"
#include "core/odometry/odometry.hpp"
#include "daemon/frame_processor.hpp"
#include "daemon/worker_pool.hpp"

namespace seavio::daemon {

class OdometryProcessor : public FrameProcessor {
 public:
  /// Empty optional and `error` set if the calibration cannot be rectified.
  /// @param feature_threads threads extracting features per frame: 1 = all on the caller,
  ///        2 (default) = right image on one persistent worker in parallel with the left
  static std::unique_ptr<OdometryProcessor> create(const camera::StereoCalibration& calib,
                                                   const imu::ImuNoise& noise,
                                                   const odometry::OdometryParams& params,
                                                   std::string* error, std::size_t feature_threads = 2);
  /// Output identical for any `feature_threads`: only the order of independent work changes.
  OdometryResult process(const StereoFrame& frame, std::span<const ImuSample> imu) override;
  std::string name() const override { return "stereo-odometry"; }

  explicit OdometryProcessor(odometry::Odometry odo, std::size_t feature_threads = 2);

  /// Threads used for feature extraction (1 or 2).
  std::size_t featureThreads() const { return pool_ ? 2 : 1; }
  /// Frames whose right image went to the worker (the rest ran sequentially, e.g. because
  /// the worker queue refused the job).
  std::size_t parallelFrames() const { return parallel_frames_; }
  const odometry::Odometry& odometry() const { return odo_; }

 private:
  odometry::FrameFeatures extractParallel(const StereoFrame& frame);

  odometry::Odometry odo_;
  std::unique_ptr<WorkerPool> pool_;  ///< one persistent worker; null when sequential
  cv::Mat left_rect_, right_rect_;    ///< reused across frames (no per-frame allocation)
  std::size_t parallel_frames_ = 0;
};

}  // namespace seavio::daemon
