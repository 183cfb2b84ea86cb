#pragma once
/// The estimator stage's view of the odometry: one call per stereo frame with the IMU
/// samples since the previous frame. The daemon owns threads and rings; the processor owns
/// the estimation (core::odometry in production, simple processors in tests).
#include <functional>
#include <memory>
#include <span>
#include <string>

#include "core/common/types.hpp"
#include "core/imu/imu_noise.hpp"
#include "core/odometry/load_shedding.hpp"

namespace seavio::daemon {

class FrameProcessor {
 public:
  virtual ~FrameProcessor() = default;
  /// Estimates the pose at `frame.t_ns`. May throw; the daemon counts it as a processing
  /// failure and carries on with the next frame.
  /// @param imu the last sample at or before the previous frame, every sample up to this
  ///        frame, and the first sample after it when already received (as `seavio run`),
  ///        on the camera clock
  virtual OdometryResult process(const StereoFrame& frame, std::span<const ImuSample> imu) = 0;
  virtual std::string name() const = 0;
  /// What to leave out from the next frame on (the daemon's degrade ladder); processors
  /// with nothing to shed ignore it.
  virtual void setLoadShedding(const odometry::LoadShedding& shed) { (void)shed; }
  /// Runs `fn` once on each thread the processor owns (none by default), so the daemon can
  /// give its workers the frame path's scheduling. False if that failed.
  virtual bool runOnWorkerThreads(const std::function<void()>& fn) {
    (void)fn;
    return true;
  }
};

/// Vision-free fallback: strapdown integration of the IMU from the world origin at rest,
/// every pose flagged PoseSource::kImuOnly with a covariance growing with time. Used until
/// the visual odometry is wired, and by tests.
class ImuDeadReckoningProcessor : public FrameProcessor {
 public:
  explicit ImuDeadReckoningProcessor(const imu::ImuNoise& noise = {}) : noise_(noise) {}
  OdometryResult process(const StereoFrame& frame, std::span<const ImuSample> imu) override;
  std::string name() const override { return "imu-dead-reckoning"; }

 private:
  imu::ImuNoise noise_;
  NavState state_;
  bool have_state_ = false;
  double elapsed_s_ = 0;
};

}  // namespace seavio::daemon
