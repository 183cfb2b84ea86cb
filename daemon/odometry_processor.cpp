#include "daemon/odometry_processor.hpp"

#include <exception>
#include <future>
#include <utility>

#include "core/common/stage_timer.hpp"
#include "daemon/daemon.hpp"

namespace seavio::daemon {

std::unique_ptr<OdometryProcessor> OdometryProcessor::create(const camera::StereoCalibration& calib,
                                                             const imu::ImuNoise& noise,
                                                             const odometry::OdometryParams& params,
                                                             std::string* error, std::size_t feature_threads) {
  std::optional<camera::StereoRectifier> rect = camera::StereoRectifier::create(calib, error);
  if (!rect) return nullptr;
  // The odometry times its stages with the daemon's monotonic clock (StageTimes).
  return std::make_unique<OdometryProcessor>(
      odometry::Odometry(std::move(*rect), noise, params, [] { return monotonicNowNs(); }), feature_threads);
}

OdometryProcessor::OdometryProcessor(odometry::Odometry odo, std::size_t feature_threads) : odo_(std::move(odo)) {
  // A queue of one: the processor never has more than one job in flight.
  if (feature_threads >= 2) pool_ = std::make_unique<WorkerPool>(1, 1);
}

OdometryResult OdometryProcessor::process(const StereoFrame& frame, std::span<const ImuSample> imu) {
  if (!pool_) return odo_.process(frame, imu);
  return odo_.track(extractParallel(frame), imu);
}

odometry::FrameFeatures OdometryProcessor::extractParallel(const StereoFrame& frame) {
  const odometry::Frontend& frontend = odo_.frontend();
  odometry::FrameFeatures f;
  f.t_ns = frame.t_ns;
  f.seq = frame.seq;
  f.detector_threshold = odo_.detectorThreshold();
  const NowNsFn now = [] { return monotonicNowNs(); };
  StageTimer timer(now);
  frontend.rectify(frame, left_rect_, right_rect_);
  f.times.rectify_ms = timer.lap_ms();
  // Frontend::detect is const and stateless, so both images may be described at once.
  const double threshold = f.detector_threshold;
  std::optional<std::future<void>> right_done =
      pool_->submit([&] { f.right = frontend.detect(right_rect_, threshold); });
  try {
    f.left = frontend.detect(left_rect_, threshold);
  } catch (...) {
    // The job refers to `f` and the images: it must finish before they go out of scope.
    if (right_done) right_done->wait();
    throw;
  }
  if (right_done) {
    right_done->get();  // rethrows the worker's exception, if any
    ++parallel_frames_;
  } else {
    f.right = frontend.detect(right_rect_, threshold);
  }
  f.times.features_ms = timer.lap_ms();
  f.stereo = frontend.matchStereo(f.left, f.right);
  f.times.stereo_ms = timer.lap_ms();
  return f;
}

}  // namespace seavio::daemon
