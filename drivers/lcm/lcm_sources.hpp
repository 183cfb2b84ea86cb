#pragma once
/// Camera and IMU sources fed by LCM messages (seavio_lcm::stereo_t / imu_t), so a running
/// daemon takes its input from `lcm-logplayer` or another process exactly as from a driver
/// (issue 7). Each source owns its own LCM instance and is read by one thread.
#include <cstdint>
#include <deque>
#include <memory>
#include <string>

#include "drivers/lcm/lcm_bus.hpp"
#include "drivers/source/sources.hpp"

namespace seavio::drivers {

class LcmStereoSource : public CameraSource {
 public:
  /// @param max_queued frames kept between LCM and read(); beyond that the oldest is
  ///        discarded and counted in dropped()
  LcmStereoSource(std::string url, std::string channel, std::size_t max_queued = 4);
  bool start() override;
  ReadStatus read(StereoFrame& out, std::chrono::milliseconds timeout) override;
  void stop() override;
  std::string lastError() const override { return error_; }
  std::string name() const override { return "lcm:" + channel_; }
  uint64_t dropped() const { return dropped_; }
  /// Messages that did not decode or had inconsistent sizes.
  uint64_t badMessages() const { return bad_ + (bus_ ? bus_->decodeFailures() : 0); }

 private:
  std::string url_, channel_;
  std::size_t max_queued_;
  std::unique_ptr<LcmBus> bus_;
  std::deque<StereoFrame> queue_;
  uint64_t dropped_ = 0, bad_ = 0;
  std::string error_;
};

class LcmImuSource : public ImuSource {
 public:
  LcmImuSource(std::string url, std::string channel, std::size_t max_queued = 4096);
  bool start() override;
  ReadStatus read(ImuSample& out, std::chrono::milliseconds timeout) override;
  void stop() override;
  std::string lastError() const override { return error_; }
  std::string name() const override { return "lcm:" + channel_; }
  uint64_t dropped() const { return dropped_; }
  uint64_t badMessages() const { return bus_ ? bus_->decodeFailures() : 0; }

 private:
  std::string url_, channel_;
  std::size_t max_queued_;
  std::unique_ptr<LcmBus> bus_;
  std::deque<ImuSample> queue_;
  uint64_t dropped_ = 0;
  std::string error_;
};

}  // namespace seavio::drivers
