#pragma once
/// Replays a loaded Dataset through the same source interfaces the live drivers
/// implement, as fast as the consumer reads (no real-time pacing).
#include <memory>

#include "drivers/dataset/dataset.hpp"
#include "drivers/source/sources.hpp"

namespace seavio::drivers {

/// Stereo frames of a dataset in order; images are loaded on each read(). Timestamps are
/// the dataset's own [ns]; `seq` is the frame index.
class DatasetCameraSource : public CameraSource {
 public:
  explicit DatasetCameraSource(std::shared_ptr<const Dataset> dataset);
  bool start() override;
  /// kOk with the next pair, kEnd after the last one, kError if an image is bad.
  ReadStatus read(StereoFrame& out, std::chrono::milliseconds timeout) override;
  void stop() override;
  std::string lastError() const override { return error_; }
  std::string name() const override;

 private:
  std::shared_ptr<const Dataset> ds_;
  std::size_t next_ = 0;
  bool started_ = false;
  std::string error_;
};

/// IMU samples of a dataset in order; kEnd after the last one.
class DatasetImuSource : public ImuSource {
 public:
  explicit DatasetImuSource(std::shared_ptr<const Dataset> dataset);
  bool start() override;
  ReadStatus read(ImuSample& out, std::chrono::milliseconds timeout) override;
  void stop() override;
  std::string lastError() const override { return error_; }
  std::string name() const override;

 private:
  std::shared_ptr<const Dataset> ds_;
  std::size_t next_ = 0;
  bool started_ = false;
  std::string error_;
};

}  // namespace seavio::drivers
